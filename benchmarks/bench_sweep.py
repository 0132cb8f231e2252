"""Per-case overhead of a Dask sweep against a plain Python loop, in the same run.

Task: ``simulate`` of the double pendulum (``generated/double_pendulum.py``) for ``t_end``
seconds with RK45, one case per value of ``m1`` — the same work in

- the peer: a plain Python loop of :func:`neweul_py.analysis.simulate` in this process, and
- :func:`neweul_py.analysis.sweep.sweep` on a local Dask cluster of 1 and of 2 worker processes
  (cluster start-up excluded: the cluster is started first, its first sweep warms it up).

Run: ``python benchmarks/bench_sweep.py [N_CASES] [T_END]`` (defaults 48 cases of 2 s). Prints the
per-case times, the ratio sweep/loop on one worker (goal ≤ 2) and the speed-up of 2 workers over
1 (goal near 2 on 2 idle cores; the machine is shared, so expect less).
"""

from __future__ import annotations

import logging
import sys
import time
from pathlib import Path

import numpy as np

from neweul_py.analysis import load_generated, simulate
from neweul_py.analysis.sweep import sweep
from neweul_py.analysis.sweep_cases import grid

MODULE = Path(__file__).resolve().parents[1] / "generated" / "double_pendulum.py"


def loop(cases: list[dict], t_end: float) -> float:
    """Seconds of the plain loop (the peer)."""
    mod = load_generated(MODULE)
    t0 = time.perf_counter()
    for c in cases:
        simulate(mod, t_end, p=c, n_out=101)
    return time.perf_counter() - t0


def on_dask(cases: list[dict], t_end: float, workers: int) -> tuple[float, int]:
    """Seconds of the sweep on a warmed local cluster of ``workers`` processes, failures."""
    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      dashboard_address=None, silence_logs=logging.ERROR) as cluster, \
            Client(cluster) as client:
        sweep(MODULE, cases[:4], "simulate", client=client, t_end=t_end, n_out=101)  # warm-up
        t0 = time.perf_counter()
        res = sweep(MODULE, cases, "simulate", client=client, t_end=t_end, n_out=101)
        return time.perf_counter() - t0, len(res.failures)


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 48
    t_end = float(sys.argv[2]) if len(sys.argv) > 2 else 2.0
    cases = grid({"m1": np.linspace(0.5, 2.0, n)})
    t_loop = min(loop(cases, t_end) for _ in range(2))
    t1, bad1 = on_dask(cases, t_end, 1)
    t2, bad2 = on_dask(cases, t_end, 2)
    print(f"{n} cases of simulate(double_pendulum, t_end={t_end:g}) per case:")
    print(f"  plain loop           {1e3 * t_loop / n:8.2f} ms")
    print(f"  Dask, 1 worker       {1e3 * t1 / n:8.2f} ms   ratio to the loop {t1 / t_loop:.2f}"
          "  (goal ≤ 2)")
    print(f"  Dask overhead        {1e3 * (t1 - t_loop) / n:8.2f} ms per case (1 worker − loop)")
    print(f"  Dask, 2 workers      {1e3 * t2 / n:8.2f} ms   speed-up over 1 worker "
          f"{t1 / t2:.2f}  (goal ≈ 2)")
    if bad1 or bad2:
        print(f"  failures: {bad1} / {bad2}")


if __name__ == "__main__":
    main()
