"""Result files: CSV (header ``t, <coords>, d_<coords>, <outputs>``, units in a sidecar) and
NPZ (no pickles), written atomically; the protocol loader's checks; reading them with pandas and
NumPy without options; the notebook display."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from neweul_py.analysis.module import load_generated
from neweul_py.analysis.results import load_npz, read_units
from neweul_py.analysis.simulate import simulate
from neweul_py.errors import NeweulError

GENERATED = Path(__file__).resolve().parents[2] / "generated"


@pytest.fixture(scope="module")
def result():
    return simulate(load_generated(GENERATED / "pendulum.py"), 1.0, n_out=11)


def test_csv_format(result, tmp_path):
    """Reference: the documented format (header line of names, 17-digit numbers) and the
    units the pendulum's description declares."""
    path = result.to_csv(tmp_path / "out.csv")
    lines = path.read_text().splitlines()
    assert lines[0] == "t,phi,d_phi,x_bob,z_bob"
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    assert data.shape == (11, 5)
    np.testing.assert_array_equal(data, result.table)  # 17 digits: exact round trip
    assert read_units(path) == {"t": "s", "phi": "rad", "d_phi": "rad/s", "x_bob": "m",
                                "z_bob": "m"}
    assert json.loads((tmp_path / "out.units.json").read_text())["d_phi"] == "rad/s"


def test_csv_opens_in_pandas_and_numpy_without_options(result, tmp_path):
    """Reference: the readers themselves (pandas.read_csv, numpy.genfromtxt(names=True)) give
    the column names and the exact values of the result."""
    import pandas as pd
    path = result.to_csv(tmp_path / "out.csv")
    frame = pd.read_csv(path)
    assert list(frame.columns) == result.names
    np.testing.assert_array_equal(frame.to_numpy(), result.table)
    rec = np.genfromtxt(path, names=True, delimiter=",")
    assert rec.dtype.names == tuple(result.names)
    np.testing.assert_array_equal(rec["phi"], result.y[:, 0])


def test_to_dataframe_and_display(result):
    """Reference: the result's own arrays; the display stays short (head and tail only)."""
    frame = result.to_dataframe()
    np.testing.assert_array_equal(frame["d_phi"].to_numpy(), result.yd[:, 0])
    assert len(repr(result)) < 200 and "pendulum" in repr(result)
    long = simulate(load_generated(GENERATED / "pendulum.py"), 1.0, n_out=5000)
    assert len(long._repr_html_()) < 4000 and "<table>" in long._repr_html_()
    assert long._repr_markdown_().count("\n") < 20
    # the headers carry the units of the CSV sidecar (read_units)
    assert "<th>phi [rad]</th>" in long._repr_html_()
    assert "| t [s] | phi [rad] | d_phi [rad/s] |" in long._repr_markdown_()


def test_to_dataframe_without_pandas_is_one_clear_error(result, monkeypatch):
    """Reference: the documented error text naming the extra."""
    import builtins

    real_import = builtins.__import__

    def no_pandas(name, *args, **kwargs):
        if name == "pandas":
            raise ImportError("no pandas")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_pandas)
    with pytest.raises(NeweulError, match="pip install pandas"):
        result.to_dataframe()


def test_npz_round_trip_without_pickles(result, tmp_path):
    path = result.to_npz(tmp_path / "out.npz")
    with np.load(path, allow_pickle=False) as data:
        assert list(data["names"]) == ["t", "phi", "d_phi", "x_bob", "z_bob"]
        assert list(data["units"]) == ["s", "rad", "rad/s", "m", "m"]
    back = load_npz(path)
    np.testing.assert_array_equal(back.t, result.t)
    np.testing.assert_array_equal(back.y, result.y)
    np.testing.assert_array_equal(back.outputs, result.outputs)
    assert back.names == result.names
    assert back.parameters == result.parameters
    assert back.model_name == "pendulum"


def test_save_picks_format_and_rejects_others(result, tmp_path):
    assert result.save(tmp_path / "a.csv").read_text().startswith("t,phi")
    assert result.save(tmp_path / "a.npz").read_bytes()[:2] == b"PK"
    with pytest.raises(NeweulError, match=r"\.csv or \.npz"):
        result.save(tmp_path / "a.txt")


def test_failed_write_keeps_old_file(result, tmp_path, monkeypatch):
    path = result.to_csv(tmp_path / "out.csv")
    before = path.read_bytes()

    def boom(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", boom)
    with pytest.raises(OSError):
        result.to_npz(tmp_path / "out.csv")
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv", "out.units.json"]


def test_column_lookup(result):
    np.testing.assert_array_equal(result.column("d_phi"), result.yd[:, 0])
    with pytest.raises(NeweulError, match="no column 'psi'; columns are: t, phi"):
        result.column("psi")


def test_plot_writes_png(result, tmp_path):
    from neweul_py.analysis.plot import plot_result

    path = plot_result(result, tmp_path / "fig.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_without_matplotlib_is_a_clear_error(result, tmp_path, monkeypatch):
    import sys

    from neweul_py.analysis.plot import plot_result

    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "matplotlib.backends.backend_agg", None)
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)
    with pytest.raises(NeweulError, match=r"pip install 'neweul-py\[plot\]'"):
        plot_result(result, tmp_path / "fig.png")
    assert not (tmp_path / "fig.png").exists()


# ---------------------------------------------------------------------------- loader
def test_loader_rejects_non_modules(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("COORDINATES = ['x']\n")
    with pytest.raises(NeweulError, match="not a generated module"):
        load_generated(bad)
    with pytest.raises(NeweulError, match="cannot read"):
        load_generated(tmp_path / "missing.py")
    broken = tmp_path / "broken.py"
    broken.write_text("raise RuntimeError('boom')\n")
    with pytest.raises(NeweulError, match="importing the generated module failed"):
        load_generated(broken)


def test_loader_rejects_other_protocol_versions(tmp_path):
    text = (GENERATED / "pendulum.py").read_text()
    future = tmp_path / "future.py"
    future.write_text(text.replace("PROTOCOL_VERSION = 1", "PROTOCOL_VERSION = 99"))
    with pytest.raises(NeweulError, match="protocol version 99 is not supported"):
        load_generated(future)


def test_loader_returns_fresh_module_after_regeneration(tmp_path):
    path = tmp_path / "pendulum.py"
    text = (GENERATED / "pendulum.py").read_text()
    path.write_text(text)
    first = load_generated(path)
    path.write_text(text.replace("'l': 0.5", "'l': 0.25"))
    second = load_generated(path)
    assert first.PARAMETERS["l"] == 0.5
    assert second.PARAMETERS["l"] == 0.25


def test_every_result_csv_has_the_same_names_in_pandas_and_genfromtxt(tmp_path):
    """Reference: the readers themselves — the names pandas reads equal those genfromtxt keeps
    (no mangled characters) for modes, frequency responses and equilibria; the display of each
    result is one short line."""
    import pandas as pd

    from neweul_py.analysis import equilibrium, frequency_response, linearize, modes

    mod = load_generated(GENERATED / "middle_ear_chain.py")
    lin = linearize(mod)
    results = [modes(lin), frequency_response(lin, [100.0, 1000.0]), equilibrium(mod)]
    for k, res in enumerate(results):
        path = res.save(tmp_path / f"r{k}.csv")
        names = list(pd.read_csv(path).columns)
        rec = np.genfromtxt(path, names=True, delimiter=",", dtype=None, encoding="utf-8")
        assert list(rec.dtype.names) == names
        assert list(res.to_dataframe().columns)[: len(names)][:2] == names[:2]
        assert len(repr(res)) < 200 and "\n" not in repr(res)


def _readers():
    from neweul_py.analysis.compare_io import read_table
    from neweul_py.analysis.frf import FrequencyResponse
    from neweul_py.analysis.linearize import LinearModel
    from neweul_py.analysis.modes import ModalResult
    from neweul_py.analysis.sweep import SweepResult

    return {"results": load_npz, "modes": ModalResult.load, "frf": FrequencyResponse.load,
            "linear model": LinearModel.load, "sweep table": SweepResult.load,
            "compare": read_table}


@pytest.fixture(scope="module")
def special_files(tmp_path_factory):
    """A FIFO, a link to /dev/zero, a directory and a zip bomb (a few hundred kB that
    declare 80 MiB of zeros), each named ``*.npz``; and an ``.npz`` without the arrays."""
    import io
    import zipfile

    d = tmp_path_factory.mktemp("special")
    os.mkfifo(d / "fifo.npz")
    (d / "zero.npz").symlink_to("/dev/zero")
    (d / "dir.npz").mkdir()
    header = io.BytesIO()
    n = 80 * 2**20 // 8
    np.lib.format.write_array_header_1_0(
        header, {"descr": "<f8", "fortran_order": False, "shape": (n,)})
    with zipfile.ZipFile(d / "bomb.npz", "w", zipfile.ZIP_DEFLATED) as zf:
        for name in ("t", "y", "names", "H", "frequency_hz", "eigenvalues", "columns", "M0"):
            zf.writestr(f"{name}.npy", header.getvalue() + bytes(8 * n))
    np.savez(d / "empty.npz", other=np.zeros(1))
    return d


@pytest.mark.parametrize("kind", ["fifo", "zero", "dir", "bomb", "empty"])
@pytest.mark.parametrize("reader", ["results", "modes", "frf", "linear model", "sweep table",
                                    "compare"])
def test_every_result_reader_checks_its_file_first(special_files, reader, kind):
    """Reference: POSIX file types and the zip directory. Every reader of a result file
    refuses a FIFO (without blocking), a device, a directory and a zip bomb before reading
    or inflating anything, and a file without its arrays — one DataError naming the file."""
    from neweul_py.errors import DataError

    path = special_files / f"{kind}.npz"
    with pytest.raises(DataError) as exc:
        _readers()[reader](path)
    assert str(path) in str(exc.value)
    expected = {"fifo": "FIFO", "zero": "character device", "dir": "directory",
                "bomb": "compression ratio", "empty": ""}[kind]
    assert expected in str(exc.value)
