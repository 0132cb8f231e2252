#!/usr/bin/env python3
"""Storage of a build's FE sweeps: complete files against one base plus delta files.

Rewrites the FE sweep directories ``fem*`` of a middle-ear build (``neweul middle-ear build``)
into a temporary directory as the sweep writes them now (``docs/fe-file-format.md``): one
complete working point (the one nearest Δp = 0 of ``fem``), every other working point of every
sweep a delta file of it. Checks that every model, static state and loss group reads back bit
for bit equal to the original, and prints the size of the sweep directories and the time of
one ``read_fe_model`` (a complete file and a delta file) before and after, with the ratios::

    python benchmarks/bench_fe_storage.py --build me_r1

The build directory is only read.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def _size(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def _same_model(a, b) -> bool:
    """Bit-for-bit equality of two FE models (matrices, maps, inputs and outputs)."""
    for key in ("M", "K", "D", "G"):
        x, y = getattr(a, key), getattr(b, key)
        if (x is None) != (y is None):
            return False
        if x is not None and not (x.shape == y.shape and x.data.tobytes() == y.data.tobytes()
                                  and np.array_equal(x.indices, y.indices)
                                  and np.array_equal(x.indptr, y.indptr)):
            return False
    return (a.nodes.tobytes() == b.nodes.tobytes()
            and np.array_equal(a.dof_node, b.dof_node)
            and np.array_equal(a.dof_kind, b.dof_kind)
            and a.inputs == b.inputs and a.outputs == b.outputs
            and a.loss_reference_frequency == b.loss_reference_frequency)


def _same_groups(a: dict | None, b: dict | None) -> bool:
    if a is None or b is None:
        return a is b
    return a.keys() == b.keys() and all(
        a[k].dtype == b[k].dtype and a[k].tobytes() == b[k].tobytes() for k in a)


def _read_time(path: Path, repeat: int = 7) -> float:
    """The shortest of ``repeat`` reads (the least disturbed by other jobs) [s]."""
    from neweul_py.elastic.io.fe_files import read_fe_model

    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        read_fe_model(path)
        best = min(best, time.perf_counter() - t0)
    return best


def rewrite(build: Path, out: Path) -> list[tuple[Path, Path]]:
    """Rewrite the sweeps ``build/fem*`` into ``out`` (module docstring); the pairs
    (original, rewritten) of the working-point files."""
    from neweul_py.elastic.io.fe_files import read_fe_model
    from neweul_py.elastic.io.working_point import read_loss, read_static, write_working_point

    dirs = sorted(d for d in build.glob("fem*") if (d / "sweep.json").is_file())
    if not dirs or dirs[0].name != "fem":
        raise SystemExit(f"{build}: no FE sweep directory 'fem'")
    pairs = []
    base = None
    for d in dirs:
        sweep = json.loads((d / "sweep.json").read_text())
        points = sorted(sweep["working_points"], key=lambda wp: abs(wp["dp_Pa"]))
        (out / d.name).mkdir(parents=True)
        for other in d.iterdir():
            if not other.name.startswith("model_dp"):
                shutil.copy2(other, out / d.name / other.name)
        for wp in points:
            src, dst = d / wp["file"], out / d.name / wp["file"]
            loss = read_loss(src)
            write_working_point(read_fe_model(src), dst, *(loss or (None, None)),
                                read_static(src), base)
            base = base or dst
            pairs.append((src, dst))
    return pairs


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--build", required=True, type=Path, help="a build directory (only read)")
    args = ap.parse_args()
    from neweul_py.elastic.io.fe_files import read_fe_model
    from neweul_py.elastic.io.working_point import read_loss, read_static

    with tempfile.TemporaryDirectory(prefix="fe_storage.") as tmp:
        out = Path(tmp)
        t0 = time.process_time()
        pairs = rewrite(args.build, out)
        cpu = time.process_time() - t0
        bad = [str(s) for s, d in pairs
               if not (_same_model(read_fe_model(s), read_fe_model(d))
                       and _same_groups(read_static(s), read_static(d))
                       and _same_groups(*(x and {"G": x[0].data} for x in
                                          (read_loss(s), read_loss(d)))))]
        before = sum(_size(d) for d in args.build.glob("fem*") if d.is_dir())
        after = sum(_size(d) for d in out.glob("fem*"))
        base, delta = pairs[0], pairs[-1]
        times = [_read_time(p) for p in (base[0], base[1], delta[0], delta[1])]
    print(f"working points: {len(pairs)} in {len({s.parent for s, _ in pairs})} sweeps; "
          f"rewritten in {cpu:.1f} s CPU; bit-for-bit equal: "
          f"{'all' if not bad else 'NOT ' + ', '.join(bad)}")
    print(f"FE sweep directories: {before / 1e6:8.1f} MB before, {after / 1e6:8.1f} MB after "
          f"(ratio {after / before:.3f})")
    print(f"read_fe_model, complete file {base[0].name}: {times[0] * 1e3:6.1f} ms before, "
          f"{times[1] * 1e3:6.1f} ms after (ratio {times[1] / times[0]:.2f})")
    print(f"read_fe_model, delta file {delta[0].parent.name}/{delta[0].name}: "
          f"{times[2] * 1e3:6.1f} ms before, {times[3] * 1e3:6.1f} ms after "
          f"(ratio {times[3] / times[2]:.2f})")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
