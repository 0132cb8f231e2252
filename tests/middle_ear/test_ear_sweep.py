"""The static curve of the pressure sweep (``neweul_py.middle_ear.sweep``): the static states on a
finer grid than the working points, the table of an interpolation coordinate
(docs/equations.md §4.1).

References: the sweep's own static states at the working points (``static.csv``, solved
separately, so equal to the Newton tolerance) and the monotonicity of the TM's volume
displacement in the static pressure (a stable static state: ``dV/dΔp > 0``).
"""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from neweul_py.cli import main
from neweul_py.errors import ModelError
from neweul_py.middle_ear.sweep import curve_pressures


def _rows(path) -> list[dict[str, float]]:
    with open(path, newline="") as fh:
        return [{k: float(v) for k, v in r.items()} for r in csv.DictReader(fh)]


def test_curve_pressures_hold_the_grid_and_the_working_points():
    """Every ``step`` Pa between the extreme working points, the working points included."""
    assert curve_pressures([-1000.0, 0.0, 1000.0], 250.0) == list(
        np.arange(-1000.0, 1001.0, 250.0))
    got = curve_pressures([-950.0, 130.0, 900.0], 500.0)
    assert got == [-950.0, -500.0, 0.0, 130.0, 500.0, 900.0]
    for step in (0.0, -1.0, float("nan")):
        with pytest.raises(ModelError, match="positive number"):
            curve_pressures([0.0, 1.0], step)
    with pytest.raises(ModelError, match="more than 10001 points"):
        curve_pressures([-4000.0, 4000.0], 0.5)


def test_sweep_writes_the_static_curve(tmp_path):
    """``neweul fem middle-ear --static-curve 250`` writes ``static_curve.csv`` with the
    static.csv columns every 250 Pa; at the working points it agrees with static.csv
    (1e-8 of the largest volume), the volume grows with Δp, and sweep.json names the file."""
    out = tmp_path / "sweep"
    assert main(["fem", "middle-ear", "--pressures", "-1000:1000:3", "--refine", "0",
                 "--static-curve", "250", "-q", "-o", str(out)]) == 0
    curve, points = _rows(out / "static_curve.csv"), _rows(out / "static.csv")
    dp = np.array([r["dp_Pa"] for r in curve])
    vol = np.array([r["volume_displacement_m3"] for r in curve])
    np.testing.assert_array_equal(dp, np.arange(-1000.0, 1001.0, 250.0))
    assert list(curve[0]) == list(points[0]) and np.all(np.diff(vol) > 0)
    for r in points:
        j = int(np.flatnonzero(dp == r["dp_Pa"])[0])
        assert abs(vol[j] - r["volume_displacement_m3"]) <= 1e-8 * np.abs(vol).max()
    assert "static_curve" in json.loads((out / "sweep.json").read_text())


def _meta(path) -> dict:
    with np.load(path) as z:
        return json.loads(z["meta"].tobytes())


def test_sweep_files_are_deltas_of_one_base_and_read_back_exactly(tmp_path):
    """The working point nearest 0 Pa is stored complete, the others as delta files of it (a
    fraction of its size), and a second sweep given that base stores every point against it
    (``../fem/…``). Reference: the models, loss matrices and static groups the sweep computed
    in memory — every file reads back bit for bit equal to them."""
    from neweul_py.elastic.io.fe_files import read_fe_model
    from neweul_py.elastic.io.working_point import read_loss, read_static
    from neweul_py.middle_ear.sweep import pressure_sweep

    def same(a, b) -> bool:
        return (a.shape == b.shape and a.data.tobytes() == b.data.tobytes()
                and np.array_equal(a.indices, b.indices) and np.array_equal(a.indptr, b.indptr))

    fem, more = tmp_path / "fem", tmp_path / "fem_slopes"
    first = pressure_sweep([-1000.0, 0.0, 1000.0], refine=0, out_dir=str(fem))
    base = fem / "model_dp+00000.npz"
    assert json.loads((fem / "sweep.json").read_text())["fe_base"] == base.name
    second = pressure_sweep([-20.0, 20.0], refine=0, out_dir=str(more), base=base)
    assert json.loads((more / "sweep.json").read_text())["fe_base"] == "../fem/" + base.name
    for res, d in ((first, fem), (second, more)):
        for s, fe, g, grp in zip(res.states, res.models, res.damping, res.static_groups,
                                 strict=True):
            path = d / f"model_dp{s.load:+06.0f}.npz"
            record = _meta(path).get("base")
            assert (record is None) == (path == base)
            if record is not None:
                assert (d / record["file"]).resolve() == base.resolve()
                assert path.stat().st_size < 0.25 * base.stat().st_size
            got = read_fe_model(path)
            assert all(same(getattr(got, k), getattr(fe, k)) for k in ("M", "K", "D"))
            assert same(got.G, g) and same(read_loss(path)[0], g)
            assert got.nodes.tobytes() == fe.nodes.tobytes()
            assert got.outputs == fe.outputs and got.inputs == fe.inputs
            st = read_static(path)
            assert all(np.asarray(v).tobytes() == st[k].tobytes() for k, v in grp.items())
