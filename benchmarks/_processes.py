"""Whole processes for the benchmarks: CPU time (user + system) of a child process, from the
operating system's accounting (``resource.getrusage(RUSAGE_CHILDREN)`` around it)."""

from __future__ import annotations

import resource
import subprocess
import sys


def children_cpu() -> float:
    """CPU seconds (user + system) of all finished child processes so far."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def timed_process(cmd: list[str], env: dict[str, str] | None = None) -> tuple[float, str]:
    """Run ``cmd`` to its end; its CPU seconds and its standard output. A failed process
    stops the benchmark with its standard error."""
    c0 = children_cpu()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    cpu = children_cpu() - c0
    if proc.returncode != 0:
        sys.stderr.write(proc.stdout + proc.stderr)
        raise SystemExit(f"{' '.join(cmd)} failed")
    return cpu, proc.stdout
