"""``neweul export FILE --fmu OUT.fmu``: the FMU written, and one clear error, before any
derivation and with nothing half-written, for each input that cannot be exported.

References: the FMI standard's validator as FMPy implements it (``fmpy.validation``) for what
is written; for the refusals, the rules of docs/fmu-export.md (a path not ending in ``.fmu``,
an input without a numeric default, no C compiler), checked with a derivation that fails the
test if it is reached.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from neweul_py import api
from neweul_py.cli import main

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"


@pytest.fixture
def no_derivation(monkeypatch):
    """Fail the test if the description reaches the derivation."""
    def derive(*args, **kwargs):
        raise AssertionError("the export derived equations before refusing")

    monkeypatch.setattr(api, "_cached_source", derive)


def _listing(d: Path) -> list[str]:
    return sorted(p.name for p in d.iterdir())


def test_export_writes_a_valid_fmu_with_the_chosen_states(tmp_path, capsys, monkeypatch):
    """``--kind cs --independent phi2``: a co-simulation-only FMU whose states are the
    coupler angle and its rate (the crank and rocker angles follow the constraints)."""
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "fb.fmu"
    assert main(["export", str(EXAMPLES / "four_bar.yaml"), "--fmu", str(out), "--kind", "cs",
                 "--independent", "phi2", "-q"]) == 0
    assert capsys.readouterr().out.strip() == str(out)
    assert validate_fmu(str(out)) == []
    md = read_model_description(str(out))
    assert md.modelExchange is None and md.coSimulation is not None
    assert [d.variable.name for d in md.derivatives] == ["der(phi2)", "der(d_phi2)"]


@pytest.mark.parametrize(("words", "message"), [
    (["--fmu", "{d}/model.zip"], "model.zip: an FMU is written to a file ending in .fmu"),
    (["--fmu", "{d}"], "an FMU is written to a file ending in .fmu"),
])
def test_a_path_that_is_not_an_fmu_is_refused(tmp_path, capsys, no_derivation, words, message):
    words = [w.format(d=tmp_path) for w in words]
    before = _listing(tmp_path)
    assert main(["export", str(EXAMPLES / "double_pendulum.yaml"), *words]) == 1
    assert message in capsys.readouterr().err
    assert _listing(tmp_path) == before


def test_an_input_without_a_numeric_default_is_refused(tmp_path, capsys, no_derivation):
    """The cart pendulum's force ``F0*sin(Omega*t)``: the error names the file, the key and
    what to do; an FMU already there stays as it was."""
    out = tmp_path / "cp.fmu"
    out.write_bytes(b"an earlier FMU")
    assert main(["export", str(EXAMPLES / "cart_pendulum.yaml"), "--fmu", str(out)]) == 1
    err = capsys.readouterr().err
    assert "cart_pendulum.yaml: inputs.F:" in err
    assert "no numeric default" in err and "F0*sin(Omega*t)" in err
    assert out.read_bytes() == b"an earlier FMU"
    assert _listing(tmp_path) == ["cp.fmu"]


def test_a_missing_compiler_is_refused(tmp_path, capsys, no_derivation, monkeypatch):
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    monkeypatch.setenv("PATH", str(tmp_path))
    assert main(["export", str(EXAMPLES / "double_pendulum.yaml"), "--fmu",
                 str(tmp_path / "dp.fmu")]) == 1
    assert "no C compiler found" in capsys.readouterr().err
    assert _listing(tmp_path) == []


def test_a_failing_compiler_leaves_nothing_half_written(tmp_path, capsys, monkeypatch):
    """A compiler that fails: one error line, the earlier FMU untouched, no temporary file
    left next to it."""
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))
    cc = tmp_path / "bin" / "cc"
    cc.parent.mkdir()
    cc.write_text("#!/bin/sh\necho 'error: no space left' >&2\nexit 1\n")
    cc.chmod(cc.stat().st_mode | stat.S_IXUSR)
    monkeypatch.setenv("CC", str(cc))
    out = tmp_path / "out" / "dp.fmu"
    out.parent.mkdir()
    out.write_bytes(b"an earlier FMU")
    assert main(["export", str(EXAMPLES / "double_pendulum.yaml"), "--fmu", str(out),
                 "-q"]) == 1
    assert "the C compiler" in capsys.readouterr().err
    assert out.read_bytes() == b"an earlier FMU"
    assert os.listdir(out.parent) == ["dp.fmu"]


def test_kinds_agree():
    """The CLI's ``--kind`` choices (kept without importing the symbolic layers) are the
    API's and codegen's."""
    from neweul_py.codegen.fmu_model import KINDS
    from neweul_py.commands.export import FMU_KINDS

    assert FMU_KINDS == api.FMU_KINDS == tuple(KINDS)
