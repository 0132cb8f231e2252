#!/usr/bin/env python3
"""Scale of the middle-ear EMBS: build time, memory, data size, module size and start-up.

Runs ``neweul middle-ear build --dir DIR --refine L`` as a child process and reports, from the
operating system's accounting of that process (``resource.getrusage(RUSAGE_CHILDREN)``), its
CPU time (with that of its worker processes, ``--jobs``) and peak memory (of the largest
process; with ``--jobs`` also the peak of the sum over the build and its workers, sampled
from ``/proc`` every 0.2 s); then the size of the build directory and of its parts, the size of
the generated module (and of its data file), and the time a fresh interpreter takes to import
the module and evaluate its first right-hand side. Each figure is printed next to its target
and as a ratio to it::

    python benchmarks/bench_middle_ear_scale.py --dir me_r1 --refine 1
    python benchmarks/bench_middle_ear_scale.py --dir me_r2 --refine 2 --jobs 2

``--keep`` reuses a finished build in DIR (only the sizes and the start-up are measured).
Targets (of the refine-1 flagship): build ≤ 90 s CPU, data directory ≤ 60 MB, module ≤ 2 MB,
import and first ``rhs`` < 1 s; refine 2: ≤ 10 min CPU and ≤ 4 GB.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import threading
import time
from pathlib import Path

#: Targets per refinement: CPU seconds and peak memory [GB] of the build.
TARGETS = {0: (90.0, 4.0), 1: (90.0, 4.0), 2: (600.0, 4.0), 3: (None, 16.0)}

STARTUP = """
import json, sys, time
t0 = time.perf_counter()
from neweul_py.analysis import load_generated
mod = load_generated(sys.argv[1])
p = mod.default_parameters()
x = mod.INITIAL_STATE
mod.rhs(0.0, x, p)
print(json.dumps({"seconds": time.perf_counter() - t0}))
"""


def _tree_rss(pid: int) -> int:
    """Resident bytes of process ``pid`` and its descendants (Linux ``/proc``; 0 elsewhere)."""
    total, todo = 0, [pid]
    while todo:
        p = todo.pop()
        try:
            with open(f"/proc/{p}/statm") as fh:
                total += int(fh.read().split()[1]) * resource.getpagesize()
            with open(f"/proc/{p}/task/{p}/children") as fh:
                todo += [int(c) for c in fh.read().split()]
        except (OSError, ValueError):
            continue
    return total


def _run_sampled(cmd: list[str]) -> tuple[subprocess.CompletedProcess, int]:
    """Run ``cmd``; its result and the peak of the summed resident memory of its tree."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    peak = [0]

    def sample() -> None:
        while proc.poll() is None:
            peak[0] = max(peak[0], _tree_rss(proc.pid))
            time.sleep(0.2)

    watcher = threading.Thread(target=sample, daemon=True)
    watcher.start()
    out, err = proc.communicate()
    watcher.join()
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err), peak[0]


def _size(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file()) if path.is_dir() \
        else (path.stat().st_size if path.exists() else 0)


def _row(name: str, value: float, unit: str, target: float | None) -> str:
    ratio = f"{value / target:6.2f}" if target else "     -"
    goal = f"{target:g} {unit}" if target else "-"
    return f"{name:<34} {value:>10.2f} {unit:<3} target {goal:<10} ratio {ratio}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", type=Path, required=True, help="the build directory")
    ap.add_argument("--refine", type=int, default=1)
    ap.add_argument("--keep", action="store_true", help="measure an existing build")
    ap.add_argument("--no-generate", action="store_true", help="build without the module")
    ap.add_argument("--pressures", default=None, help="working points (START:STOP:N)")
    ap.add_argument("--jobs", type=int, default=1, help="processes of the snapshot solves")
    args = ap.parse_args()
    cpu_target, mem_target = TARGETS.get(args.refine, (None, None))
    rows = []
    if not args.keep:
        cmd = [sys.executable, "-m", "neweul_py.cli", "middle-ear", "build", "--dir",
               str(args.dir), "--refine", str(args.refine), "-q"]
        cmd += ["--no-generate"] if args.no_generate else []
        cmd += [f"--pressures={args.pressures}"] if args.pressures else []
        cmd += ["--jobs", str(args.jobs)]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        wall = time.perf_counter()
        done, tree_peak = _run_sampled(cmd)
        wall = time.perf_counter() - wall
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if done.returncode:
            sys.exit(f"build failed: {done.stderr.strip().splitlines()[-1:]}")
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        rows += [_row("build CPU time", cpu, "s", cpu_target),
                 _row("build wall time", wall, "s", None),
                 _row("build peak memory", after.ru_maxrss / 1e6, "GB", mem_target),
                 _row("  summed over its processes", tree_peak / 1e9, "GB", mem_target)]
    record = json.loads((args.dir / "build.json").read_text())
    rows.append(_row("data directory", _size(args.dir) / 1e6, "MB",
                     60.0 if args.refine == 1 else None))
    for prefix in ("fem_refine", "fem_slopes"):       # each round of a sweep: one figure
        rounds = sorted(args.dir.glob(prefix + "*"))
        if rounds:
            rows.append(_row(f"  {prefix}*/ ({len(rounds)})",
                             sum(_size(p) for p in rounds) / 1e6, "MB", None))
    for part in ("fem", "embs", "generated"):
        if (args.dir / part).exists():
            rows.append(_row(f"  {part}/", _size(args.dir / part) / 1e6, "MB", None))
    if record.get("module"):
        module = args.dir / record["module"]
        rows.append(_row("generated module", module.stat().st_size / 1e6, "MB", 2.0))
        data = [p for p in module.parent.iterdir() if p.stem.startswith(module.stem)
                and p.suffix in (".npz", ".npy", ".bin")]
        if data:
            rows.append(_row("  its data file(s)", sum(p.stat().st_size for p in data) / 1e6,
                             "MB", None))
        out = subprocess.run([sys.executable, "-c", STARTUP, str(module)],
                             capture_output=True, text=True, check=True)
        rows.append(_row("import + first rhs", json.loads(out.stdout)["seconds"], "s", 1.0))
    print(f"middle-ear build, refine {args.refine}: order {record['order']}, "
          f"{len(record['samples_Pa'])} working points")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
