"""``neweul interpolate --slope-models`` on working points of ``neweul fem middle-ear``
(docs/equations.md §4.2), whose reduced bodies carry static states.

References: the static states the FE sweep writes next to every sample (``static_x`` of the
working-point files, central differences computed here) and the one-line error contract of
the command line.
"""

from __future__ import annotations

import numpy as np

from neweul_py.cli import main
from neweul_py.elastic.io.body_files import load_parametric_body, load_reduced_body
from neweul_py.elastic.io.fe_files import load_fe_arrays
from neweul_py.elastic.io.working_point import read_static

STEP = 20.0
SAMPLES = (-1000, 0, 1000)


def _name(p: float) -> str:
    return f"model_dp{int(p):+06d}.npz"


def test_slopes_of_working_points_with_static_states(tmp_path, capsys):
    """Three refine-0 working points, reduced with their static states, and the working
    points ∓ 20 Pa: the Hermite body's static node-displacement slopes are the central
    differences of the files' static states at the kept nodes, and the quintic Hermite
    body's curvatures their second differences with the samples' own files; a slope model
    without a static state, or the slope models of a sample swapped (their static_dp says
    so), is one error line naming it, and nothing is written."""
    fem, near = tmp_path / "fem", tmp_path / "near"
    assert main(["fem", "middle-ear", "--pressures=-1000,0,1000", "--refine", "0", "-q",
                 "-o", str(fem)]) == 0
    assert main(["fem", "middle-ear", "--refine", "0", "-q", "-o", str(near),
                 "--pressures=" + ",".join(f"{p + s * STEP:g}" for p in SAMPLES
                                           for s in (-1, 1))]) == 0
    bodies = []
    for p in SAMPLES:
        bodies.append(str(tmp_path / f"b{p}.npz"))
        assert main(["reduce", str(fem / _name(p)), "--modes", "12", "--static-correction",
                     "--store-bases", "-o", bodies[-1]]) == 0
    slopes = [str(near / _name(p + s * STEP)) for p in SAMPLES for s in (-1, 1)]
    out = tmp_path / "tm.npz"
    base = ["interpolate", *bodies, "--parameter", "dp", "--values", "-1000,0,1000"]
    assert main([*base, "--slope-models", *slopes, "--slope-step", "20", "--interpolation",
                 "hermite", "-o", str(out)]) == 0
    capsys.readouterr()
    pb = load_parametric_body(out)
    assert pb.interpolation == "hermite" and "static/node_u" in pb.slopes
    body = load_reduced_body(bodies[1])
    rows = {int(n): i for i, n in enumerate(body.nodes[:, 0])}
    for i, p in enumerate(SAMPLES):
        lo, hi = (read_static(near / _name(p + s * STEP)) for s in (-1, 1))
        ids = [int(n) for n in lo["node_id"]]
        du = (hi["u"] - lo["u"]) / (2 * STEP)
        for nid, r in list(rows.items())[:20]:
            if nid in ids:
                np.testing.assert_allclose(pb.slopes["static/node_u"][i][r], du[ids.index(nid)],
                                           rtol=1e-6, atol=1e-9 * np.abs(du).max())
    quint = tmp_path / "tmq.npz"
    assert main([*base, "--slope-models", *slopes, "--slope-step", "20",      # the default
                 "-o", str(quint)]) == 0
    assert "curvatures (quintic Hermite)" in capsys.readouterr().out
    qb = load_parametric_body(quint)
    assert qb.interpolation == "quintic-hermite" and qb.format_version == 5
    for i, p in enumerate(SAMPLES):          # the samples' own states: their files' static_u
        lo, mid, hi = (read_static(d / _name(p + s * STEP))
                       for d, s in ((near, -1), (fem, 0), (near, 1)))
        ids = [int(n) for n in mid["node_id"]]
        d2u = (hi["u"] - 2 * mid["u"] + lo["u"]) / STEP**2
        for nid, r in list(rows.items())[:20]:
            if nid in ids:
                np.testing.assert_allclose(qb.curvatures["static/node_u"][i][r],
                                           d2u[ids.index(nid)], rtol=1e-5,
                                           atol=1e-8 * np.abs(d2u).max())
    swapped = [slopes[1], slopes[0], *slopes[2:]]
    bad = tmp_path / "bad.npz"
    assert main([*base, "--slope-models", *swapped, "--slope-step", "20", "-o", str(bad)]) == 1
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "working point at -980" in err and "wants -1020 here" in err and not bad.exists()
    bare = tmp_path / "bare.npz"
    arrays = load_fe_arrays(slopes[0])  # the complete model of a (delta) sweep file
    np.savez(bare, **{k: v for k, v in arrays.items() if not k.startswith("static_")})
    assert main([*base, "--slope-models", str(bare), *slopes[1:], "--slope-step", "20",
                 "-o", str(bad)]) == 1
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("neweul interpolate: error:") and "bare.npz" in err
    assert "this slope model has none" in err and not bad.exists()
