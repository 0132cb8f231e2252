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


def test_runs_into_two_directories_of_one_parent_fill_at_the_same_time(tmp_path):
    """Two outputs side by side in one parent (a refine-1 and a refine-2 build): the second is
    written while the first is still filling. Reference: the first run's ``fill`` waits for
    the second run to end — with one lock on the parent for the whole run it would wait
    forever (here: until the event's timeout, and the second run would not have ended)."""
    import threading

    second_done = threading.Event()
    seen = {}

    def slow(tmp):
        (tmp / "data.txt").write_text("first")
        seen["second ended while the first filled"] = second_done.wait(timeout=60)
        return {"tag": "first"}

    first = threading.Thread(target=write_directory_atomically, args=(tmp_path / "a", slow))
    first.start()
    while not any(p.name.startswith(".a.") for p in tmp_path.iterdir()):
        threading.Event().wait(0.01)
    write_directory_atomically(tmp_path / "b", _fill("second"))
    second_done.set()
    first.join()
    assert seen == {"second ended while the first filled": True}
    assert _tag(tmp_path / "a") == "first" and _tag(tmp_path / "b") == "second"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "b"]


def test_cleaning_keeps_the_temporary_directory_of_a_live_run(tmp_path):
    """A second run into the same directory cleans the temporaries of killed runs, not the one
    a live run is filling. Reference: the live run still ends with its own complete output."""
    import threading

    started, proceed = threading.Event(), threading.Event()

    def live(tmp):
        (tmp / "data.txt").write_text("live")
        started.set()
        proceed.wait(timeout=60)
        assert (tmp / "data.txt").read_text() == "live"
        return {"tag": "live"}

    out = tmp_path / "sweep"
    (tmp_path / ".sweep.killed.tmp").mkdir()          # a killed run's leftover
    errors = []

    def run():
        try:
            write_directory_atomically(out, live)
        except BaseException as exc:
            errors.append(exc)

    thread = threading.Thread(target=run)
    thread.start()
    started.wait(timeout=60)
    write_directory_atomically(out, _fill("other"))
    assert not (tmp_path / ".sweep.killed.tmp").exists()
    proceed.set()
    thread.join()
    assert errors == [] and _tag(out) == "live"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep"]


def test_an_output_inside_a_run_being_filled(tmp_path):
    """An FE sweep written inside a build's temporary directory: the inner run locks what the
    outer run holds. Reference: both complete, the inner output inside the outer one (a run
    that waited for its own lock would never end; the thread is given a minute)."""
    import threading

    def outer(tmp):
        write_directory_atomically(tmp / "fem", _fill("inner"))
        return {"tag": "outer"}

    out = tmp_path / "build"
    thread = threading.Thread(target=write_directory_atomically, args=(out, outer), daemon=True)
    thread.start()
    thread.join(timeout=60)
    assert not thread.is_alive()
    assert _tag(out) == "outer" and _tag(out / "fem") == "inner"
    assert sorted(p.name for p in out.iterdir()) == ["fem", MANIFEST]
