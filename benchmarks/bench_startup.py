#!/usr/bin/env python3
"""Start-up of a cached ``neweul simulate`` against the import of what it needs.

Measured in one run, alternating, each in a fresh process:

* ours: ``neweul simulate examples/pendulum.yaml --t-end 1`` with the generated module in the
  cache (a private temporary cache, filled by one run first): start the interpreter, read and
  verify the description and the cached module, integrate 1 s, print the final state;
* peer: ``python -c "import numpy, scipy.integrate"`` — the floor any SciPy integration pays.

Prints the median wall time of each over ``--repeat`` runs and the ratio ours / peer (goal
≤ 1.5), then the import time of the biggest packages of the cached run (``python -X
importtime``), which says where the difference goes.

Usage::

    python benchmarks/bench_startup.py [--repeat 15]

Nothing here asserts a time: the script prints figures and the ratio.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DESCRIPTION = ROOT / "examples" / "pendulum.yaml"


def _wall(argv: list[str], env: dict[str, str]) -> float:
    t0 = time.perf_counter()
    subprocess.run(argv, env=env, check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def _importtime(argv: list[str], env: dict[str, str], top: int = 12) -> list[tuple[int, str]]:
    """The ``top`` largest cumulative import times [µs] of top-level packages."""
    out = subprocess.run([argv[0], "-X", "importtime", *argv[1:]], env=env, check=True,
                         capture_output=True, text=True).stderr
    rows = []
    for line in out.splitlines():
        if not line.startswith("import time:") or "|" not in line:
            continue
        _, cumulative, name = line.split("|")
        if not name.startswith("  ") and cumulative.strip().isdigit():   # top level
            rows.append((int(cumulative), name.strip()))
    return sorted(rows, reverse=True)[:top]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=15, help="runs of each (default 15)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NEWEUL_CACHE": cache, "PYTHONPATH": str(ROOT)}
        ours = [sys.executable, "-m", "neweul_py.cli", "simulate", str(DESCRIPTION),
                "--t-end", "1"]
        peer = [sys.executable, "-c", "import numpy, scipy.integrate"]
        _wall(ours, env)                        # fills the cache (derives once)
        _wall(peer, env)                        # warms the file cache
        t_ours, t_peer = [], []
        for _ in range(args.repeat):
            t_peer.append(_wall(peer, env))
            t_ours.append(_wall(ours, env))
        m_ours, m_peer = statistics.median(t_ours), statistics.median(t_peer)
        print(f"cached `neweul simulate {DESCRIPTION.relative_to(ROOT)} --t-end 1` against "
              f"`python -c \"import numpy, scipy.integrate\"`, median of {args.repeat} runs "
              "each, alternating:")
        print(f"  ours {m_ours:.3f} s (min {min(t_ours):.3f}), peer {m_peer:.3f} s "
              f"(min {min(t_peer):.3f}): ratio {m_ours / m_peer:.2f} (goal <= 1.5)")
        print("largest top-level imports of the cached run [ms, cumulative]:")
        for us, name in _importtime(ours, env):
            print(f"  {us / 1000:8.1f}  {name}")


if __name__ == "__main__":
    main()
