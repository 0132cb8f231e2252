"""``neweul middle-ear tympanogram|absorbance|build``: bad input is one clear error line, before
any work and with nothing written (reference: the CLI's error contract, docs/cli.md)."""

from __future__ import annotations

import json

import pytest

from neweul_py.cli import main


@pytest.mark.parametrize(("argv", "named"), [
    (["tympanogram", "--f", "0"], "--f"),
    (["tympanogram", "--pressures", "100:-400:51"], "--pressures"),
    (["tympanogram", "-o", "t.txt"], "t.txt"),
    (["absorbance", "--dp", "nan"], "--dp"),
    (["absorbance", "--dp", "0", "--plot", "a.xyz"], "a.xyz"),
    (["build", "--jobs", "0"], "--jobs"),
])
def test_bad_options_fail_at_once(argv, named, tmp_path, capsys):
    """A non-positive probe frequency, a sweep without +200 daPa, an output that is not CSV,
    a non-finite Δp, a plot format matplotlib does not write, no build process: exit ≠ 0
    with an error line naming the option or file, before the (empty) build directory is
    read; nothing written."""
    (tmp_path / "build").mkdir()
    args = ["middle-ear", argv[0], "--dir", str(tmp_path / "build"), *argv[1:]]
    try:
        code = main(args)
    except SystemExit as exc:                      # argparse's own type errors
        code = exc.code
    assert code != 0
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert named in last and "build.json" not in last
    assert sorted(p.name for p in tmp_path.iterdir()) == ["build"]


def test_a_directory_without_a_build_is_named(tmp_path, capsys):
    """No ``build.json``: the error names the directory and says how to make a build."""
    assert main(["middle-ear", "tympanogram", "--dir", str(tmp_path)]) != 0
    assert "neweul middle-ear build" in capsys.readouterr().err


def test_a_sweep_beyond_the_build_is_refused(tmp_path, capsys):
    """A build over −1000 … +1000 Pa cannot give the default sweep down to −400 daPa
    (−4000 Pa): the body does not extrapolate."""
    (tmp_path / "build.json").write_text(json.dumps({"samples_Pa": [-1000.0, 0.0, 1000.0]}))
    assert main(["middle-ear", "tympanogram", "--dir", str(tmp_path)]) != 0
    assert "no extrapolation" in capsys.readouterr().err

