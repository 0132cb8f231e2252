"""Progress reporting (neweul_py/progress.py) and the hooks of simulate and the FE FRF."""

from __future__ import annotations

import io
import warnings
from pathlib import Path

import numpy as np
from compiler import needs_c_compiler

from neweul_py.analysis import simulate
from neweul_py.cli import main
from neweul_py.progress import Tracker, report

GENERATED = Path(__file__).resolve().parents[1] / "generated"


def test_simulate_hook_reports_monotone_time_up_to_the_span():
    """Reference: the integration span itself (done runs from 0 to t_end − t_start, the last
    report is the full span) and the unchanged result without a hook."""
    calls: list[tuple[float, float]] = []
    res = simulate(GENERATED / "double_pendulum.py", 2.0, t_start=1.0,
                   progress=lambda d, t: calls.append((d, t)))
    done = np.array([c[0] for c in calls])
    assert all(t == 1.0 for _, t in calls) and calls[-1] == (1.0, 1.0)
    assert np.all(np.diff(done) >= 0) and 2 < len(calls) <= 202
    plain = simulate(GENERATED / "double_pendulum.py", 2.0, t_start=1.0)
    np.testing.assert_array_equal(res.table, plain.table)


def test_constrained_simulate_hook():
    """Reference: one report per output interval of the DAE integrator (n_out − 1)."""
    calls: list[tuple[float, float]] = []
    simulate(GENERATED / "slider_crank.py", 0.1, n_out=11,
             progress=lambda d, t: calls.append((d, t)))
    assert len(calls) == 10 and calls[-1] == (0.1, 0.1)


def test_tracker_bar_has_remaining_time_and_keeps_messages_on_their_own_lines():
    """Reference: tqdm's own bar format ('elapsed<remaining')."""
    buf = io.StringIO()
    with Tracker("run", unit="s", stream=buf, bar=True) as track:
        track(0.5, 2.0)
        track.say("a message")
        track(2.0, 2.0)
    text = buf.getvalue()
    assert "run:" in text and "<" in text and "  a message\n" in text


def test_tracker_off_a_terminal_prints_messages_only_and_quiet_nothing():
    """Reference: the documented behaviour (bars only on a terminal, --quiet silences)."""
    buf = io.StringIO()
    track = Tracker("run", stream=buf)
    report(track, "step 1/2", 1, 2)
    track(3.0, 4.0)
    assert buf.getvalue() == "  step 1/2\n"
    quiet = io.StringIO()
    report(Tracker("run", stream=quiet, quiet=True), "step", 1, 2)
    assert quiet.getvalue() == ""
    got: list[str] = []
    report(got.append, "plain hook", 1, 2)
    report(None, "nobody listens", 1, 2)
    assert got == ["plain hook"]


def test_cli_simulate_quiet_and_not_a_terminal_stay_silent(capsys):
    """Reference: an empty stderr (capsys is not a terminal; --quiet as well)."""
    for extra in ([], ["--quiet"]):
        assert main(["simulate", str(GENERATED / "pendulum.py"), "--t-end", "1", *extra]) == 0
        assert capsys.readouterr().err == ""


def _chain(tmp_path: Path, n: int = 8) -> Path:
    """An n-link spatial chain (recursive form: more than AUTO_CLOSED_MAX coordinates)."""
    import sys

    sys.path.insert(0, str(GENERATED.parent / "examples"))
    try:
        from make_chain import chain_description
    finally:
        sys.path.pop(0)
    path = tmp_path / "chain.yaml"
    path.write_text(chain_description(n, True))
    return path


def test_derivation_hook_counts_rise_per_stage_to_their_totals(tmp_path):
    """Reference: the model itself — 8 frames in the kinematics; 8 bodies, 16 mass-matrix
    columns (recursive form) and one closing step in the equations; the 13 blocks of the module
    (11, the poses and the parameter derivatives) — and the unchanged module without a hook
    (byte for byte)."""
    from neweul_py.api import generate
    from neweul_py.equations import clear_cache

    desc = _chain(tmp_path)
    clear_cache()  # the derivation is cached by model: a hit reports nothing
    calls: list[tuple[str, float, int]] = []
    hooked = generate(desc, tmp_path / "a", progress=lambda *a: calls.append(a))
    stages = list(dict.fromkeys(c[0] for c in calls))
    assert stages == ["kinematics", "equations", "code generation"]
    totals = {s: {c[2] for c in calls if c[0] == s} for s in stages}
    assert totals == {"kinematics": {8}, "equations": {8 + 16 + 1}, "code generation": {13}}
    for s in stages:
        done = [c[1] for c in calls if c[0] == s]
        assert np.all(np.diff(done) > 0) and done[-1] == totals[s].pop()
    whole = [c[1] for c in calls if c[0] == "code generation" and float(c[1]).is_integer()]
    assert whole == list(range(1, 14))  # every block, with fractions inside long ones
    clear_cache()
    plain = generate(desc, tmp_path / "b")
    assert hooked.read_bytes() == plain.read_bytes()


def test_derivation_bars_on_a_terminal_only(tmp_path, capsys):
    """Reference: tqdm's bar labelled by stage on a (pretended) terminal; an empty stderr for
    `neweul generate` off a terminal (capsys) and with --quiet."""
    from neweul_py.api import generate
    from neweul_py.equations import clear_cache

    desc = _chain(tmp_path, 3)
    buf = io.StringIO()
    clear_cache()
    with Tracker(stream=buf, bar=True) as track:
        generate(desc, tmp_path / "a", progress=track)
    text = buf.getvalue()
    assert "kinematics:" in text and "equations:" in text and "code generation:" in text
    for extra in ([], ["--quiet"]):
        clear_cache()
        assert main(["generate", str(desc), "-o", str(tmp_path / "c"), *extra]) == 0
        assert capsys.readouterr().err == ""


@needs_c_compiler
def test_compiled_backend_reports_its_blocks(tmp_path):
    """Reference: the seven blocks of the C sources (codegen.writer.program_blocks)."""
    from neweul_py.api import generate
    from neweul_py.equations import clear_cache

    clear_cache()
    calls: list[tuple[str, float, int]] = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        generate(GENERATED.parent / "examples" / "pendulum.yaml", tmp_path, backend="c",
                 progress=lambda *a: calls.append(a))
    c_calls = [c for c in calls if c[0] == "C code"]
    assert [c[1] for c in c_calls if float(c[1]).is_integer()] == list(range(1, 8))
    assert {c[2] for c in c_calls} == {7}


def test_off_a_terminal_a_line_every_interval_with_the_stage_and_an_estimate():
    """Reference: a clock stepped by hand — no line within the first interval (short work is
    quiet), then one line per interval naming the stage, how far it is and the time left at
    the pace so far (10 of 40 steps in 20 s: 1:00 left); quiet prints nothing."""
    now = [0.0]
    buf = io.StringIO()
    track = Tracker(stream=buf, interval=5.0, clock=lambda: now[0])
    track("equations", 1, 40)
    now[0] = 4.0
    track("equations", 2, 40)
    assert buf.getvalue() == ""
    now[0] = 20.0
    track("equations", 10, 40)
    now[0] = 21.0
    track("equations", 11, 40)            # within the interval of the last line: nothing
    now[0] = 30.0
    track("code generation", 1, 4)        # a new stage: its own clock starts now
    now[0] = 36.0
    track("code generation", 2, 4)
    assert buf.getvalue().splitlines() == [
        "equations: 10/40 (25 %), 0:20 elapsed, about 1:00 left",
        "code generation: 1/4 (25 %), 0:00 elapsed, about 0:00 left",
        "code generation: 2/4 (50 %), 0:06 elapsed, about 0:06 left",
    ]
    quiet = io.StringIO()
    silent = Tracker(stream=quiet, quiet=True, interval=0.0, clock=lambda: now[0])
    silent("equations", 1, 2)
    silent(1.0, 2.0)
    assert quiet.getvalue() == ""
    timed = io.StringIO()
    Tracker("simulate", unit="s", stream=timed, interval=0.0)(2.5, 10.0)
    assert timed.getvalue().startswith("simulate: 2.5/10 s (25 %), 0:00 elapsed, about ")


def test_cli_derivation_in_a_log_reports_its_stages(tmp_path, capsys, monkeypatch):
    """`neweul generate` off a terminal (capsys) with the interval at zero: a line per report
    naming the stages of the derivation; `-q` silences them."""
    from neweul_py import progress
    from neweul_py.equations import clear_cache

    monkeypatch.setattr(progress, "LOG_INTERVAL", 0.0)
    desc = _chain(tmp_path, 3)
    clear_cache()
    assert main(["generate", str(desc), "-o", str(tmp_path / "a"), "--no-cache"]) == 0
    err = capsys.readouterr().err
    for stage in ("kinematics:", "equations:", "code generation:"):
        assert any(line.startswith(stage) and "elapsed" in line for line in err.splitlines())
    clear_cache()
    assert main(["generate", str(desc), "-o", str(tmp_path / "b"), "-q", "--no-cache"]) == 0
    assert capsys.readouterr().err == ""
