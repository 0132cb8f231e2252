#!/usr/bin/env python3
"""The middle-ear Δp-ramp time study, NumPy module against compiled module, in one run.

Model: the middle-ear EMBS of ``neweul middle-ear build`` (the parametric TM + air
u–p body on ISYS, quintic Hermite weights in the static volume displacement, the ossicles
through node frames), retargeted and ramped by ``examples/middle_ear/time_study.py``
(``Δp(t) = dp_ramp sin²(π t / t_ramp)``, a tone ``Q = Q_amp sin 2π f t`` in the canal).

Measured in one run (BLAS single-threaded): the sizes of the data file and the modules;
``import + first rhs`` of both modules in fresh processes, and the peak resident memory of
such a process; ``rhs`` per call at a constant
Δp and with Δp moving at every call; the ramp of ``time_study.tone`` (generalized-α,
``--steps-per-period`` steps, over ``--t-ramp``) with each module — the NumPy module in the
Python loop, the compiled one in its C loop (``generalized_alpha_steps``; ``--repeat`` runs,
default 3, whose median is compared: a run of 1.3 s feels a busy neighbour on a shared
machine more than one of 27 s) — wall time, rhs
calls (residual evaluations in C), the ratio NumPy / compiled and the largest difference of
the umbo velocity relative to its largest value (the two loops stop at different Newton
iterates: within the tolerance, docs/analysis.md). Nothing is asserted.

Usage (after ``neweul middle-ear build --dir DATA``)::

    python benchmarks/bench_time_study.py --dir DATA [--t-ramp 0.02] [--steps-per-period 100]
        [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
import timeit
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples" / "middle_ear"))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_parametric_compiled import import_first_rhs, peak_memory  # noqa: E402


def _modules(data: Path, out: Path):
    """The NumPy and the compiled module of the ramp description (generation times)."""
    from time_study import ramp_description

    from neweul_py.analysis import load_generated
    from neweul_py.api import load_description
    from neweul_py.codegen import generate_module
    from neweul_py.codegen.c_module import write_c_module
    from neweul_py.description import description_hash
    from neweul_py.equations import newton_euler

    out.mkdir(parents=True, exist_ok=True)
    desc = out / "middle_ear_ramp.yaml"
    desc.write_text(ramp_description(data))
    t0 = time.perf_counter()
    eq = newton_euler(load_description(desc))
    npath = generate_module(eq, description_hash(desc.read_bytes()),
                            out / "generated" / "middle_ear_ramp.py")
    t1 = time.perf_counter()
    wrapper = write_c_module(eq, npath)
    t2 = time.perf_counter()
    subprocess.run([sys.executable, "-c", f"import runpy; runpy.run_path({str(wrapper)!r})"],
                   check=True)
    return load_generated(npath), load_generated(wrapper), npath, wrapper, t1 - t0, t2 - t1


def _per_call(fn) -> float:
    fn()
    number = max(1, int(0.3 / max(timeit.timeit(fn, number=1), 1e-6)))
    return min(timeit.repeat(fn, number=number, repeat=3)) / number


def main() -> None:
    from time_study import parameters, tone

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", type=Path, required=True, help="a build of neweul middle-ear build")
    ap.add_argument("--out", type=Path, default=None, help="modules (default DIR/bench_c)")
    ap.add_argument("--t-ramp", type=float, default=0.02, help="ramp duration [s]")
    ap.add_argument("--dp-peak", type=float, default=2000.0)
    ap.add_argument("--f-tone", type=float, default=1000.0)
    ap.add_argument("--q-amp", type=float, default=1e-5, help="tone amplitude [m^3/s^2]")
    ap.add_argument("--steps-per-period", type=int, default=100)
    ap.add_argument("--repeat", type=int, default=3,
                    help="runs of the compiled ramp; its median is compared (default 3)")
    args = ap.parse_args()
    if args.repeat < 1:
        ap.error("--repeat must be at least 1")
    mnp, mc, npath, wrapper, g_np, g_c = _modules(args.dir, args.out or args.dir / "bench_c")
    n = mnp.STATE_SIZE // 2
    print(f"middle-ear ramp module: {n} coordinates; generation NumPy {g_np:.1f} s, "
          f"C sources {g_c:.1f} s; backend {mc.BACKEND}")
    print("\n| file | size |\n|---|---|")
    for f in (*npath.parent.glob("middle_ear_ramp.*.npz"), npath, wrapper,
              wrapper.with_suffix(".c"), wrapper.with_name(wrapper.stem + "_jac.c")):
        print(f"| {f.name} | {f.stat().st_size / 1e6:.3f} MB |")
    print("\n| module | import + first rhs (bytecode cached) | (source compiled) | peak "
          "memory |\n|---|---|---|---|")
    for key, path in (("NumPy", npath), ("compiled", wrapper)):
        print(f"| {key} | {import_first_rhs(path, True):.2f} s | "
              f"{import_first_rhs(path, False):.2f} s | {peak_memory(path):.0f} MB |")
    x = 1e-12 * np.random.default_rng(1).standard_normal(2 * n)
    print("\n| per call | NumPy [ms] | C [ms] | NumPy / C |\n|---|---|---|---|")
    for name, moving in (("rhs, constant Δp", False), ("rhs, Δp moving", True)):
        got = []
        for m in (mnp, mc):
            p = parameters(m, dp=500.0, dp_ramp=args.dp_peak, t_ramp=0.35)
            clock = [0.01]

            def call(m=m, p=p, clock=clock, moving=moving):
                clock[0] += 1e-6 if moving else 0.0
                return m.rhs(clock[0], x, p)

            got.append(_per_call(call))
        print(f"| {name} | {1e3 * got[0]:.3f} | {1e3 * got[1]:.3f} | {got[0] / got[1]:.1f} |")
    runs = []
    for m, count in ((mnp, 1), (mc, args.repeat)):
        p = parameters(m, dp=0.0, dp_ramp=args.dp_peak, t_ramp=args.t_ramp, f_tone=args.f_tone,
                       Q_amp=args.q_amp)
        runs.append([tone(m, p, args.t_ramp, args.f_tone, args.steps_per_period, 0.5)
                     for _ in range(count)])
    (a,), bs = runs
    b = bs[0]
    c_seconds = float(np.median([r.seconds for r in bs]))
    key = "umbo_velocity_z"
    dev = float(np.abs(a.out[key] - b.out[key]).max() / np.abs(a.out[key]).max())
    print(f"\nramp {args.dp_peak:g} Pa over {args.t_ramp:g} s, tone {args.f_tone:g} Hz, "
          f"generalized-α with {args.steps_per_period} steps per period:")
    each = ", ".join(f"{r.seconds:.2f}" for r in bs)
    print(f"| backend | wall | rhs calls |\n|---|---|---|\n| NumPy | {a.seconds:.1f} s | "
          f"{a.nfev} |\n| C | {c_seconds:.2f} s (median of {each}) | {b.nfev} |")
    print(f"ratio NumPy / C: {a.seconds / c_seconds:.1f}; largest difference of the umbo "
          f"velocity: {dev:.1e} of its largest value")


if __name__ == "__main__":
    main()
