"""Atomic directory outputs of ``neweul fem middle-ear -o DIR``
(neweul_py/middle_ear/output.py).

References: the POSIX/Linux rename semantics (``renameat2(RENAME_EXCHANGE)`` swaps two paths
in one step), kills that once left no DIR (between two renames) or hidden
``.tmp``/``.old`` directories, and repeated identical runs (same bytes).
"""

from __future__ import annotations

import json

import pytest

from neweul_py.errors import DataError
from neweul_py.middle_ear import output
from neweul_py.middle_ear.output import MANIFEST, write_directory_atomically, write_static_csv


def _fill(tag: str):
    def fill(tmp):
        (tmp / "data.txt").write_text(tag)
        return {"tag": tag}
    return fill


def _tag(out) -> str:
    return json.loads((out / MANIFEST).read_text())["tag"]


@pytest.mark.parametrize("exchange", [True, False])
def test_replaces_the_old_output_and_leaves_nothing_behind(tmp_path, monkeypatch, exchange):
    if not exchange:
        monkeypatch.setattr(output, "_exchange", lambda a, b: False)
    out = tmp_path / "sweep"
    write_directory_atomically(out, _fill("old"))
    write_directory_atomically(out, _fill("new"))
    assert _tag(out) == "new" and (out / "data.txt").read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep"]


def test_a_failure_keeps_the_old_output(tmp_path):
    out = tmp_path / "sweep"
    write_directory_atomically(out, _fill("old"))

    def boom(tmp):
        (tmp / "partial").write_text("x")
        raise KeyboardInterrupt  # as a kill would interrupt the work

    with pytest.raises(KeyboardInterrupt):
        write_directory_atomically(out, boom)
    assert _tag(out) == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep"]


def test_a_kill_between_the_fallback_renames_is_healed(tmp_path):
    """State after a SIGKILL between ``DIR → .DIR.x.old`` and ``.DIR.y.tmp → DIR``: no DIR.
    The next run renames the old output back first (and would keep it if it failed too),
    and removes the stale temporary directory."""
    out = tmp_path / "sweep"
    write_directory_atomically(out, _fill("old"))
    out.rename(tmp_path / ".sweep.abc.old")
    (tmp_path / ".sweep.def.tmp").mkdir()
    ((tmp_path / ".sweep.def.tmp") / "half.npz").write_bytes(b"x" * 100)

    def fail(tmp):
        raise DataError("load step diverged")

    with pytest.raises(DataError):
        write_directory_atomically(out, fail)
    assert _tag(out) == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep"]


def test_stale_temporaries_of_killed_runs_are_removed(tmp_path):
    out = tmp_path / "sweep"
    for name in (".sweep.1.tmp", ".sweep.2.old", ".other.3.tmp"):
        (tmp_path / name).mkdir()
    write_directory_atomically(out, _fill("new"))
    assert sorted(p.name for p in tmp_path.iterdir()) == [".other.3.tmp", "sweep"]


def test_other_data_is_never_replaced(tmp_path):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "thesis.tex").write_text("x")
    with pytest.raises(DataError, match="not overwriting"):
        write_directory_atomically(out, _fill("new"))
    assert (out / "thesis.tex").read_text() == "x"


def test_static_csv_is_deterministic(tmp_path):
    """Results that differ in their last bits (the iterative eigensolver's noise) give the
    same file; 12 significant digits are kept."""
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    write_static_csv([{"dp_Pa": -1000.0, "f_Hz": 2318.3219570760934, "n": 4}], a)
    write_static_csv([{"dp_Pa": -1000.0, "f_Hz": 2318.321957076093, "n": 4}], b)
    assert a.read_bytes() == b.read_bytes()
    assert a.read_text().splitlines()[1] == "-1000.0,2318.32195708,4"
