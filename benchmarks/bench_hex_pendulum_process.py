#!/usr/bin/env python3
"""Hex20 flexible pendulum as whole processes: ours against Exudyn, in CPU time.

Each run is a fresh process doing everything from nothing:

* ours, ``benchmarks/_ours_hex_pendulum.py NX MODES generalized-alpha 1e-3 0.9`` in this
  Python: Hex20 assembly (``neweul_py.fem.solid_box``), fixed-interface modes and invariants,
  the body file, the description, derivation and generation of the NumPy module, its import
  and 1 s of generalized-α (h = 1e-3, ρ∞ = 0.9);
* the peer, ``benchmarks/_peer_exudyn.py NX MODES`` in the peer's own venv
  (``--peer-python``; exudyn and scikit-fem, never dependencies of neweul-py): scikit-fem
  assembly of the same block, Exudyn's Hurty–Craig–Bampton modes, ``ObjectFFRFreducedOrder``
  and 1 s of its generalized-α with the same step.

The two alternate (ours, peer, ours, peer, …); the CPU time (user + system) of each process is
the difference of ``resource.getrusage(RUSAGE_CHILDREN)`` around it, and the ratio ours/peer is
taken pair by pair (a drift of the shared machine's speed then cancels) and printed with its
median. Both processes get the same environment: bytecode caching on (a temporary
``PYTHONPYCACHEPREFIX``, warmed by one unmeasured run of each, as for installed packages) and,
with ``--blas-threads N``, ``OPENBLAS_NUM_THREADS = OMP_NUM_THREADS = N`` (default: the
environment as it is; OpenBLAS's idle threads spin and are billed as CPU time, so on a shared
2-core machine both sides cost less with 1). The tips at t = 1 s of both are printed: they must
agree (an independent FFRF implementation). Nothing is asserted.

Usage::

    python benchmarks/bench_hex_pendulum_process.py --peer-python PEER_VENV/bin/python
    python benchmarks/bench_hex_pendulum_process.py --peer-python … --runs 7 --blas-threads 1

The peer venv: ``python3 -m venv PEER_VENV && PEER_VENV/bin/pip install exudyn scikit-fem``.
"""

from __future__ import annotations

import argparse
import atexit
import json
import os
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

from _processes import timed_process

HERE = Path(__file__).resolve().parent


def _process(cmd: list[str], env: dict[str, str]) -> tuple[float, dict]:
    """CPU seconds of the whole process ``cmd`` and the JSON of its last output line."""
    cpu, out = timed_process(cmd, env)
    return cpu, json.loads(out.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--peer-python", required=True, help="Python of the venv with exudyn")
    parser.add_argument("--runs", type=int, default=5, help="pairs of processes (default 5)")
    parser.add_argument("--nx", type=int, default=16, help="elements along the block (16)")
    parser.add_argument("--modes", type=int, default=10, help="fixed-interface modes (10)")
    parser.add_argument("--blas-threads", type=int, default=None, metavar="N",
                        help="OPENBLAS_NUM_THREADS = OMP_NUM_THREADS = N for both sides")
    args = parser.parse_args()
    pycache = tempfile.mkdtemp(prefix="neweul-bench-pyc-")
    atexit.register(shutil.rmtree, pycache, True)
    env = {**os.environ, "PYTHONPYCACHEPREFIX": pycache, "PYTHONHASHSEED": "0"}
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    if args.blas_threads is not None:
        env["OPENBLAS_NUM_THREADS"] = env["OMP_NUM_THREADS"] = str(args.blas_threads)
    ours = [sys.executable, str(HERE / "_ours_hex_pendulum.py"), str(args.nx), str(args.modes),
            "generalized-alpha", "1e-3", "0.9"]
    peer = [args.peer_python, str(HERE / "_peer_exudyn.py"), str(args.nx), str(args.modes)]
    _process(ours, env)  # warm the bytecode caches; not measured
    _process(peer, env)
    print(f"Hex20 pendulum, {args.nx} x 2 x 2 elements, {args.modes} modes, 1 s; whole "
          f"processes, CPU time (user + system); BLAS threads: "
          f"{args.blas_threads if args.blas_threads is not None else 'as the environment'}; "
          f"load average {os.getloadavg()[0]:.1f}")
    rows = []
    for k in range(args.runs):
        c_ours, r_ours = _process(ours, env)
        c_peer, r_peer = _process(peer, env)
        rows.append((c_ours, c_peer))
        print(f"  pair {k + 1}: ours {c_ours:6.3f} s   Exudyn {c_peer:6.3f} s   "
              f"ours/Exudyn {c_ours / c_peer:5.2f}")
    ratios = [a / b for a, b in rows]
    print(f"median: ours {statistics.median(a for a, _ in rows):.3f} s, Exudyn "
          f"{statistics.median(b for _, b in rows):.3f} s, ratio ours/Exudyn "
          f"{statistics.median(ratios):.2f} (min {min(ratios):.2f}, max {max(ratios):.2f}); "
          f"load average {os.getloadavg()[0]:.1f}")
    tip_ours, tip_peer = r_ours["tip"], r_peer["tip"]
    print(f"tip at t = 1 s: ours x = {tip_ours[0]:.8f}, z = {tip_ours[1]:.8f} m; Exudyn "
          f"x = {tip_peer[0]:.8f}, z = {tip_peer[2]:.8f} m")


if __name__ == "__main__":
    main()
