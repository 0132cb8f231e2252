#!/usr/bin/env python3
"""The middle ear's FE model at scale: the FE sweep and one two-sided reduction, per stage.

Runs each stage in a child process: its CPU time as the operating system accounts it
(``resource.getrusage(RUSAGE_CHILDREN)``), its peak memory as the child's own ``VmHWM``
(``/proc/self/status``, Linux):

1. the FE sweep (:func:`neweul_py.middle_ear.sweep.pressure_sweep`) at the working points
   ``--pressures`` into ``DIR/fem`` — the nonlinear static states and the linearized u–p
   models (docs/equations-middle-ear.md §2–4);
2. one two-sided reduction of the working point ``--reduce-at``
   (:func:`neweul_py.elastic.parametric.two_sided_basis.balanced_snapshot_basis`, the
   snapshots of ``neweul middle-ear build --basis two-sided`` at ``--frequencies``), with
   the cost of one factorization ``K + iωD − ω²M`` and the order kept.

Each figure is printed next to the target of the refinement::

    python benchmarks/bench_middle_ear_fe_scale.py --dir fe_r3 --refine 3
    python benchmarks/bench_middle_ear_fe_scale.py --dir fe_r2 --refine 2 --pressures 0,2000

Targets: refine 3 — the sweep and one two-sided reduction within 16 GB each.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

#: Peak memory targets per refinement [GB].
MEMORY_GB = {2: 4.0, 3: 16.0}

SWEEP = """
import json, sys
from neweul_py.middle_ear.sweep import pressure_sweep
args = json.loads(sys.argv[1])
res = pressure_sweep(args["pressures"], refine=args["refine"], out_dir=args["out"])
print(json.dumps({"points": len(args["pressures"]),
                  "peak": next(int(line.split()[1]) for line in open("/proc/self/status")
                               if line.startswith("VmHWM")) / 1e6}))
"""

REDUCE = """
import json, sys, time
import numpy as np
from neweul_py.elastic.io.fe_files import read_fe_model
from neweul_py.elastic.parametric.two_sided_basis import (balanced_snapshot_basis,
                                                          zero_mode_pairs)
from neweul_py.elastic.reductors.eigen import SparseLU
from neweul_py.middle_ear.embs import model_path
from neweul_py.middle_ear.parameters import MiddleEarParameters
from neweul_py.middle_ear.sampling import interface_loads
args = json.loads(sys.argv[1])
sweep = json.loads(open(args["out"] + "/sweep.json").read())
fe = read_fe_model(model_path(args["out"], args["at"]))
params = MiddleEarParameters(**sweep["parameters"])
umbo = int(sweep["interface_nodes"]["umbo"])
Kx, F, C = interface_loads(fe, umbo, params.k_tm_manubrium)
w = 2 * np.pi * 1000.0
t0 = time.process_time()
lu = SparseLU((fe.K + Kx + 1j * w * fe.D - w * w * fe.M).tocsc())
one = time.process_time() - t0
fill = int(lu.lu.L.nnz + lu.lu.U.nnz)
del lu
t0 = time.process_time()
b = balanced_snapshot_basis([fe], [F], [C], args["freqs"], Kx, pairs=[zero_mode_pairs(fe)])
print(json.dumps({"dofs": int(fe.n_dofs), "order": int(b.order), "lu_seconds": one,
                  "lu_entries": fill, "reduction_seconds": time.process_time() - t0,
                  "peak": next(int(line.split()[1]) for line in open("/proc/self/status")
                               if line.startswith("VmHWM")) / 1e6}))
"""


def _child(code: str, args: dict) -> tuple[dict, float, float, float]:
    """Run ``code`` in a child interpreter; its JSON answer, CPU [s], wall [s] and peak
    memory [GB] (the child's own Linux ``VmHWM``; ``ru_maxrss`` would keep the parent's peak
    across ``fork`` and ``exec``)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", code, json.dumps(args)],
                          capture_output=True, text=True)
    wall = time.perf_counter() - wall
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode:
        sys.exit(f"stage failed: {done.stderr.strip().splitlines()[-3:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    answer = json.loads(done.stdout.strip().splitlines()[-1])
    return answer, cpu, wall, answer["peak"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", type=Path, required=True, help="where the FE sweep goes")
    ap.add_argument("--refine", type=int, default=3)
    ap.add_argument("--pressures", default="0", help="working points [Pa], comma-separated")
    ap.add_argument("--reduce-at", type=float, default=None,
                    help="working point of the reduction (default: the first)")
    ap.add_argument("--frequencies", default="20,100,300,1000,3000,6000",
                    help="snapshot frequencies [Hz] of the reduction, comma-separated")
    ap.add_argument("--no-reduce", action="store_true", help="the FE sweep only")
    args = ap.parse_args()
    pressures = [float(p) for p in args.pressures.split(",")]
    target = MEMORY_GB.get(args.refine)
    out = str(args.dir / "fem")
    args.dir.mkdir(parents=True, exist_ok=True)
    _, cpu, wall, peak = _child(SWEEP, {"pressures": pressures, "refine": args.refine,
                                        "out": out})
    size = sum(p.stat().st_size for p in Path(out).glob("*.npz")) / 1e6
    print(f"refine {args.refine}: FE sweep of {len(pressures)} working point(s): "
          f"CPU {cpu:.1f} s, wall {wall:.1f} s, peak {peak:.2f} GB (target {target} GB), "
          f"files {size:.0f} MB")
    if args.no_reduce:
        return
    at = pressures[0] if args.reduce_at is None else args.reduce_at
    freqs = [float(f) for f in args.frequencies.split(",")]
    res, cpu, wall, peak = _child(REDUCE, {"out": out, "at": at, "freqs": freqs})
    print(f"refine {args.refine}: {res['dofs']} DOFs; one factorization of K + iωD − ω²M "
          f"{res['lu_seconds']:.1f} s CPU, {res['lu_entries'] / 1e6:.0f}·10⁶ factor entries")
    print(f"refine {args.refine}: two-sided reduction at {at:+.0f} Pa from {len(freqs)} "
          f"frequencies: order {res['order']}, {res['reduction_seconds']:.1f} s CPU "
          f"(child CPU {cpu:.1f} s, wall {wall:.1f} s), peak {peak:.2f} GB "
          f"(target {target} GB)")


if __name__ == "__main__":
    main()
