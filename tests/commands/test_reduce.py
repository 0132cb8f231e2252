"""``neweul reduce`` and ``neweul compare-frf``: thin over the Python API."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
import scipy.linalg as sla
from fe_builders import piston_duct

from neweul_py.cli import main
from neweul_py.elastic import (
    compare_frf,
    read_fe_model,
    reduce_modal,
    write_fe_model,
)
from neweul_py.elastic.io.body_files import load_reduced_body
from neweul_py.errors import DataError


def test_reduce_and_compare(tmp_path, capsys):
    fe = piston_duct(60, damping=3.0)
    model = tmp_path / "pd.json"
    write_fe_model(fe, model)
    body_path = tmp_path / "b.npz"
    assert main(["reduce", str(model), "--modes", "12", "--static-correction",
                 "-o", str(body_path)]) == 0
    out = capsys.readouterr()
    assert "order 14" in out.out and "stable" in out.out and "factorizing" in out.err
    body = load_reduced_body(body_path)
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
    assert load_reduced_body(tmp_path / "k.npz").settings["two_sided"] is False
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


@pytest.mark.parametrize("options,text", [
    (["--method", "krylov", "--points", "100", "--modes", "5"],
     "--modes applies to --method modal"),
    (["--method", "krylov", "--points", "100", "--band", "0:300"], "--band applies"),
    (["--method", "krylov", "--points", "100", "--shift", "-1"], "--shift applies"),
    (["--modes", "5", "--points", "100,200"], "--points applies to --method krylov"),
    (["--band", "0:300", "--points", "100", "--order", "2"], "--points and --order apply"),
    (["--method", "krylov"], "needs --points"),
])
def test_contradictory_options_are_refused(tmp_path, capsys, options, text):
    """Options the chosen method would ignore are one-line errors; nothing is written."""
    model = tmp_path / "pd.npz"
    write_fe_model(piston_duct(20), model)
    out = tmp_path / "x.npz"
    assert main(["reduce", str(model), *options, "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and text in err[0]
    assert not out.exists()


def test_compare_frf_refuses_a_body_of_another_model(tmp_path, capsys):
    """A body reduced from the 202-DOF model against the 62-DOF one, or from an undamped
    model against the damped one of the same size: refused, naming the body file."""
    for name, fe in (("pd.json", piston_duct(200)), ("pd60.json", piston_duct(60)),
                     ("pd60d.json", piston_duct(60, damping=1.0))):
        write_fe_model(fe, tmp_path / name)
    for model, body in (("pd.json", "b202.npz"), ("pd60.json", "b62.npz")):
        assert main(["reduce", str(tmp_path / model), "--modes", "6", "-o",
                     str(tmp_path / body)]) == 0
    capsys.readouterr()
    args = ["--input", "force", "--output", "p_end", "--f", "10:100:5"]
    for model, body, text in (("pd60.json", "b202.npz", "202 DOFs"),
                              ("pd60d.json", "b62.npz", "different FE model")):
        assert main(["compare-frf", str(tmp_path / model), str(tmp_path / body), *args]) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and text in err[0] and body in err[0]
    assert main(["compare-frf", str(tmp_path / "pd60.json"), str(tmp_path / "b62.npz"),
                 *args]) == 0
    with pytest.raises(DataError, match="62"):  # the Python API checks as well
        compare_frf(read_fe_model(tmp_path / "pd60.json"),
                    load_reduced_body(tmp_path / "b202.npz"), [10.0], "force", "p_end")


def test_band_from_zero_hz_reports_the_zero_mode(tmp_path, capsys):
    """`--band 0:300` of the closed-cavity piston duct keeps the constant-pressure mode
    (dense eigenvalues of the 202-DOF pencil: 0, 114.7 and 262.4 Hz in the band)."""
    fe = piston_duct()
    model = tmp_path / "pd.json"
    write_fe_model(fe, model)
    assert main(["reduce", str(model), "--band", "0:300", "-o", str(tmp_path / "b.npz")]) == 0
    out = capsys.readouterr().out
    assert "order 3 from 202 DOFs" in out
    lo, hi = (float(x) for x in out.split("[Hz]: ")[1].split(" … "))
    lam = np.sort(sla.eigvals(fe.K.toarray(), fe.M.toarray()).real)
    assert lo < 1e-3 and abs(hi - np.sqrt(lam[2]) / (2 * np.pi)) < 1e-3


def test_krylov_order_beyond_the_dofs_is_refused(tmp_path, capsys):
    """``krylov --order 1e6`` looped past an exhausted basis: the CLI caps
    --order (docs/limits.md) and refuses more Krylov vectors than the model has DOFs.
    Reference: dim span{P_0 … P_{q−1}} ≤ n for an n-DOF model."""
    model = tmp_path / "pd.npz"
    write_fe_model(piston_duct(20), model)
    assert main(["reduce", str(model), "--method", "krylov", "--points", "100,200",
                 "--order", "30", "-o", str(tmp_path / "k.npz")]) == 1
    err = capsys.readouterr().err
    assert "asks for 60 Krylov vectors" in err.splitlines()[-1]  # after the progress lines
    assert not (tmp_path / "k.npz").exists()
