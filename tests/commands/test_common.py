"""Shared pieces of the sub-commands (``neweul_py/commands/common.py``): an output file that
is one of the command's inputs is refused before any work.

References: the files made here (the same path spelled differently, a symbolic link, a hard
link, another file) and the one-line error contract of the command line; the input files'
bytes are compared before and after.
"""

from __future__ import annotations

import os

import pytest

from neweul_py.cli import main
from neweul_py.commands.common import refuse_overwrite
from neweul_py.errors import NeweulError


def test_an_output_naming_an_input_is_refused(tmp_path):
    """The same file as a relative path with ``..``, through a symbolic link and through a
    hard link: one NeweulError naming the option, the input and its file; another file, or
    no output, passes."""
    body = tmp_path / "body.npz"
    body.write_bytes(b"input")
    (tmp_path / "sub").mkdir()
    os.symlink(body, tmp_path / "link.npz")
    os.link(body, tmp_path / "hard.npz")
    for out in (str(body), str(tmp_path / "sub" / ".." / "body.npz"),
                str(tmp_path / "link.npz"), str(tmp_path / "hard.npz")):
        with pytest.raises(NeweulError) as exc:
            refuse_overwrite(out, {"BODY": [str(tmp_path / "other.npz"), str(body)]})
        assert str(exc.value) == (f"-o/--output {out} is the input BODY {body}: writing it "
                                  "would overwrite that input (write to another file)")
    refuse_overwrite(str(tmp_path / "new.npz"), {"BODY": [str(body)], "--models": None})
    refuse_overwrite(None, {"BODY": [str(body)]})


@pytest.mark.parametrize(("args", "name"), [
    (["interpolate", "b0.npz", "b1.npz", "--parameter", "p", "--method", "local",
      "-o", "b1.npz"], "BODY b1.npz"),
    (["interpolate", "b0.npz", "b1.npz", "--parameter", "p", "--slope-models", "s0.npz",
      "s1.npz", "s2.npz", "s3.npz", "--slope-step", "1", "-o", "s2.npz"],
     "--slope-models s2.npz"),
    (["interpolate", "b0.npz", "b1.npz", "--parameter", "p", "--models", "fe0.npz",
      "fe1.npz", "-o", "./fe0.npz"], "--models fe0.npz"),
    (["reduce", "fe0.npz", "--modes", "4", "-o", "fe0.npz"], "MODEL fe0.npz"),
    (["compare", "b0.csv", "b1.csv", "-o", "b1.csv"], "REFERENCE b1.csv"),
])
def test_commands_refuse_to_overwrite_an_input(tmp_path, monkeypatch, capsys, args, name):
    """``neweul interpolate -o`` one of its BODY, ``--slope-models`` or ``--models`` files,
    ``neweul reduce -o`` its MODEL, ``neweul compare -o`` its REFERENCE: exit 1, one error
    line naming ``-o/--output`` and the input, and every input unchanged (it was silently
    overwritten, or read and then overwritten)."""
    monkeypatch.chdir(tmp_path)
    files = {os.path.normpath(a) for a in args if a.endswith((".npz", ".csv"))}
    for f in files:
        (tmp_path / f).write_bytes(f"input {f}".encode())
    assert main(args) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0, err
    out = args[args.index("-o") + 1]
    assert err.endswith(f"-o/--output {out} is the input {name}: writing it would overwrite "
                        "that input (write to another file)"), err
    for f in files:
        assert (tmp_path / f).read_bytes() == f"input {f}".encode()


def test_sweep_refuses_to_overwrite_its_cases(tmp_path, monkeypatch, capsys):
    """``neweul sweep -o CASES.csv --cases CASES.csv``: one error line naming ``-o/--out``
    and ``--cases``, the cases file unchanged (reference: its bytes)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "cases.csv").write_text("m\n1\n")
    assert main(["sweep", "model.yaml", "--cases", "cases.csv", "-o", "cases.csv"]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "-o/--out cases.csv is the input --cases cases.csv" in err
    assert (tmp_path / "cases.csv").read_text() == "m\n1\n"


def test_interpolate_refuses_to_overwrite_a_recorded_fe_model(tmp_path, monkeypatch, capsys):
    """``neweul interpolate`` (global basis) reads the FE model each body records as its
    source; ``-o`` that model is one error line naming it and the body, and the model file
    is unchanged (reference: its bytes)."""
    monkeypatch.chdir(tmp_path)
    for i, e in enumerate(("1", "2")):
        assert main(["fem", "beam", "--elements", "4", "--E", e, "-o", f"fe{i}.npz"]) == 0
        assert main(["reduce", f"fe{i}.npz", "--modes", "3", "--store-bases", "-o",
                     f"b{i}.npz"]) == 0
    capsys.readouterr()
    before = (tmp_path / "fe0.npz").read_bytes()
    assert main(["interpolate", "b0.npz", "b1.npz", "--parameter", "E", "--values", "1,2",
                 "-o", "fe0.npz"]) == 1
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "-o/--output fe0.npz is the input FE model (recorded by b0.npz)" in err, err
    assert (tmp_path / "fe0.npz").read_bytes() == before
