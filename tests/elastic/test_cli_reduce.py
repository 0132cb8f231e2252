"""``neweul reduce`` and ``neweul compare-frf`` (issue 3 item 5): thin over the Python API."""

from __future__ import annotations

import importlib.util

import numpy as np
from fe_builders import piston_duct

from neweul_py.cli import main
from neweul_py.elastic import ReducedBody, reduce_modal, write_fe_model


def test_reduce_and_compare(tmp_path, capsys):
    fe = piston_duct(60, damping=3.0)
    model = tmp_path / "pd.json"
    write_fe_model(fe, model)
    body_path = tmp_path / "b.npz"
    assert main(["reduce", str(model), "--modes", "12", "--static-correction",
                 "-o", str(body_path)]) == 0
    out = capsys.readouterr()
    assert "order 14" in out.out and "stable" in out.out and "factorizing" in out.err
    body = ReducedBody.load(body_path)
    ref = reduce_modal(fe, modes=12, static_correction=True)
    np.testing.assert_allclose(body.eigenvalues, ref.eigenvalues, rtol=1e-12)
    csv = tmp_path / "c.csv"
    args = ["compare-frf", str(model), str(body_path), "--input", "force", "--output",
            "p_end", "--f", "10:400:20", "-o", str(csv)]
    assert main(args) == 0
    assert "max relative error" in capsys.readouterr().out
    assert csv.read_text().startswith("frequency_hz,full_magnitude,reduced_magnitude,")
    png = tmp_path / "f.png"
    if importlib.util.find_spec("matplotlib") is not None:
        assert main([*args, "--plot", str(png)]) == 0
        assert png.stat().st_size > 0
    else:  # the plot extra is not installed: one clear line, exit 1
        assert main([*args, "--plot", str(png)]) == 1
        assert "pip install 'neweul-py[plot]'" in capsys.readouterr().err


def test_krylov_one_sided_and_band(tmp_path, capsys):
    model = tmp_path / "pd.npz"
    write_fe_model(piston_duct(60), model)
    assert main(["reduce", str(model), "--method", "krylov", "--points", "100,400",
                 "--order", "2", "--one-sided", "-o", str(tmp_path / "k.npz")]) == 0
    assert ReducedBody.load(tmp_path / "k.npz").settings["two_sided"] is False
    assert main(["reduce", str(model), "--band", "100:500", "-o", str(tmp_path / "m.npz")]) == 0
    capsys.readouterr()


def test_errors_are_one_line_naming_the_file(tmp_path, capsys):
    model = tmp_path / "pd.json"
    write_fe_model(piston_duct(30), model)
    assert main(["reduce", str(model), "--band", "1:20", "-o", str(tmp_path / "x.npz")]) == 1
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("neweul reduce: error:") and "pd.json" in err and "band" in err
    assert not (tmp_path / "x.npz").exists()
    assert main(["reduce", str(tmp_path / "none.json"), "--modes", "3", "-o",
                 str(tmp_path / "x.npz")]) == 1
    assert "none.json" in capsys.readouterr().err
