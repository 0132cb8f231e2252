"""The benchmark scripts run: a small configuration of the fuzzing benchmark end to end.

Reference: the benchmark's own tally — every mutated input gives a result or one error of the
package's hierarchy, and no case hangs (``exceptions outside the hierarchy or hangs: 0``).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_fuzz_benchmark_runs_a_small_sample() -> None:
    """``benchmarks/bench_fuzz.py`` with a few cases of every kind ends with no exception
    outside the hierarchy (and runs at all: the benchmarks use the package's public API)."""
    out = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_fuzz.py"), "--descriptions", "10",
         "--generate", "1", "--data", "10", "--tables", "10", "--kills", "1"],
        capture_output=True, text=True, cwd=ROOT, env={**os.environ, "PYTHONHASHSEED": "0"},
    )
    assert out.returncode == 0, out.stderr[-2000:]
    assert "exceptions outside the hierarchy or hangs: 0" in out.stdout, out.stdout[-2000:]
