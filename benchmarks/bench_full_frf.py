#!/usr/bin/env python3
"""Full-FE frequency response of the refine-1 middle ear: the checked sweep against direct solves.

Model: ``neweul fem middle-ear --pressures=0 --refine 1`` (6 584 DOFs: TM displacements, ear
canal and tympanic-cavity pressures, u–p coupled, loss factors) and, for the command's
comparison, its reduced body ``neweul reduce … --modes 30 --static-correction``; both are
built in ``--dir`` when absent (not timed). Input ``canal_volume_acceleration``, output
``umbo_uz``, 200 frequencies 100 Hz–10 kHz, logarithmic.

Measured, each job a fresh process, CPU time (user + system) from
``resource.getrusage(RUSAGE_CHILDREN)`` around it:

1. the command as a user runs it, ``neweul compare-frf MODEL BODY --input … --response …
   --f 100:10000:200 --log -q`` (the full FRF by the checked sweep, its default), ``--runs``
   times, the median;
2. one worker computing the same full FRF by the sweep
   (``neweul_py.elastic.quality.measures.frf_full_checked``, what the command runs) and by
   direct solves at every frequency (``frf_sweep.frf_direct``: one complex sparse LU per
   frequency), each timed in CPU; the relative error per frequency
   ``|H_sweep − H_direct| / |H_direct|`` over all 200 frequencies (max and median), the sweep's
   number of factorizations and its own held-out check.

Both sides run with the same environment; ``--blas-threads N`` sets ``OPENBLAS_NUM_THREADS =
OMP_NUM_THREADS = N`` (OpenBLAS's idle threads spin and are billed as CPU time). Nothing is
asserted.

Usage::

    python benchmarks/bench_full_frf.py --dir DATA [--runs 3] [--blas-threads 1]
"""

from __future__ import annotations

import argparse
import atexit
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _processes import timed_process

INPUT, OUTPUT, GRID = "canal_volume_acceleration", "umbo_uz", "100:10000:200"


def _worker(model: str) -> None:
    """Sweep and direct FRF of the model, their CPU times and the error of the sweep."""
    import numpy as np

    from neweul_py.elastic import read_fe_model
    from neweul_py.elastic.quality.frf_sweep import frequency_form, frf_direct
    from neweul_py.elastic.quality.measures import frf_full_checked

    fe = read_fe_model(model)
    f = np.geomspace(100.0, 10000.0, 200)
    c0 = time.process_time()
    H, res = frf_full_checked(fe, f, INPUT, OUTPUT)
    c1 = time.process_time()
    fl = frequency_form(fe, "loss")
    Hd = frf_direct(fl, f, fl.B(INPUT), fl.C(OUTPUT))
    c2 = time.process_time()
    err = np.abs(H - Hd).ravel() / np.abs(Hd).ravel()
    print(json.dumps({"sweep_cpu": c1 - c0, "direct_cpu": c2 - c1,
                      "factorizations": int(res.solved_hz.size + res.checked_hz.size),
                      "order": res.order, "checked": res.max_checked_error,
                      "max": float(err.max()), "median": float(np.median(err)),
                      "over_1e-6": int((err > 1e-6).sum()),
                      "worst_hz": float(f[int(np.argmax(err))])}))


def _build(data: Path, cli: list[str], env: dict[str, str]) -> tuple[Path, Path]:
    model, body = data / "model_dp+00000.npz", data / "body.npz"
    if not model.exists():
        subprocess.run([*cli, "fem", "middle-ear", "--pressures=0", "-o", str(data),
                        "--refine", "1", "-q"], check=True, env=env)
    if not body.exists():
        subprocess.run([*cli, "reduce", str(model), "--modes", "30", "--static-correction",
                        "-o", str(body)], check=True, env=env, capture_output=True)
    return model, body


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--dir", required=True, help="data directory (built when empty)")
    parser.add_argument("--runs", type=int, default=3, help="command runs (default 3)")
    parser.add_argument("--blas-threads", type=int, default=None, metavar="N",
                        help="OPENBLAS_NUM_THREADS = OMP_NUM_THREADS = N")
    args = parser.parse_args()
    if args.worker:
        _worker(args.worker)
        return
    pycache = tempfile.mkdtemp(prefix="neweul-bench-pyc-")
    atexit.register(shutil.rmtree, pycache, True)
    env = {**os.environ, "PYTHONPYCACHEPREFIX": pycache}
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    if args.blas_threads is not None:
        env["OPENBLAS_NUM_THREADS"] = env["OMP_NUM_THREADS"] = str(args.blas_threads)
    cli = [sys.executable, "-m", "neweul_py.cli"]
    data = Path(args.dir)
    data.mkdir(parents=True, exist_ok=True)
    model, body = _build(data, cli, env)
    cmd = [*cli, "compare-frf", str(model), str(body), "--input", INPUT, "--response", OUTPUT,
           "--f", GRID, "--log", "-q"]
    timed_process(cmd, env)  # warm the bytecode cache; not measured
    print(f"neweul compare-frf, refine-1 middle ear, {GRID} Hz (log); BLAS threads: "
          f"{args.blas_threads if args.blas_threads is not None else 'as the environment'}; "
          f"load average {os.getloadavg()[0]:.1f}")
    cpus = []
    for k in range(args.runs):
        cpu, out = timed_process(cmd, env)
        cpus.append(cpu)
        print(f"  run {k + 1}: {cpu:6.2f} s CPU")
    print(f"  median {statistics.median(cpus):.2f} s CPU; it printed:")
    for line in out.strip().splitlines():
        print(f"    {line}")
    cpu, out = timed_process([sys.executable, __file__, "--worker", str(model), "--dir",
                              str(data)], env)
    w = json.loads(out.strip().splitlines()[-1])
    print(f"full FRF in one process ({cpu:.1f} s CPU): sweep {w['sweep_cpu']:.2f} s CPU, "
          f"{w['factorizations']} factorizations, order {w['order']}, held-out check "
          f"{w['checked']:.1e}; direct solves {w['direct_cpu']:.1f} s CPU, 200 "
          f"factorizations (×{w['direct_cpu'] / w['sweep_cpu']:.0f})")
    print(f"sweep against direct solves, all 200 frequencies: relative error max "
          f"{w['max']:.1e} (at {w['worst_hz']:.0f} Hz), median {w['median']:.1e}, "
          f"{w['over_1e-6']} above 1e-6; load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
