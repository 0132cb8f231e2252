"""Parametric reduction with one global basis (``neweul_py.elastic.parametric.global_basis``),
``neweul interpolate --method global`` and ``neweul frf-body``.

Parametric FE model: ``fe_builders.membrane_cavity`` (a light string closing an air cavity,
u–p form of Eq. (2), SI units) with tension ``0.3 (1 + p)`` N, ``p ∈ [0, 0.4]``: its
resonances move by 18 % between the samples, so the nearest sample is far off between them.
References: the unreduced FE model at the evaluation point (direct sparse solves), the
projection of each sample's FE matrices computed here from the stored basis, and the
energy argument of the u–p form (stable for positive semi-definite damping).
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from fe_builders import membrane_cavity

from neweul_py.cli import main
from neweul_py.elastic import (
    ParametricBody,
    frf_reduced,
    interpolate,
    reduce_modal,
    stability,
    write_fe_model,
)
from neweul_py.elastic.io.body_files import load_parametric_body
from neweul_py.elastic.parametric.global_basis import energy_metric, global_parametric_body
from neweul_py.elastic.quality.measures import frf_full
from neweul_py.elastic.reductors.invariants import attach_invariants, compute_invariants
from neweul_py.errors import DataError

SAMPLES = (0.0, 0.2, 0.4)
MIDS = (0.1, 0.3)
F = np.linspace(50.0, 4000.0, 120)
IO = ("force", ["umbo", "probe"])


@cache
def fe_at(p: float):
    return membrane_cavity(0.3 * (1 + p))


@cache
def body_at(p: float):
    return reduce_modal(fe_at(p), modes=20, static_correction=True, store_bases=True)


@cache
def parametric() -> ParametricBody:
    return global_parametric_body([fe_at(p) for p in SAMPLES], [body_at(p) for p in SAMPLES],
                                  SAMPLES, parameter="p")


def _errors(body, p: float) -> tuple[np.ndarray, np.ndarray]:
    H = frf_full(fe_at(p), F, *IO, method="direct")[:, :, 0]
    e = np.abs(frf_reduced(body, F, *IO)[:, :, 0] - H) / np.abs(H)
    return np.median(e, axis=0), e.max(axis=0)


def test_between_samples_beats_nearest_and_local():
    """At the midpoints the global body is within 1e-4 (median and max, both outputs) of
    the unreduced FE model there, and better than both neighbouring samples and the
    local-basis interpolation (Panzer et al.)."""
    pb = parametric()
    local = interpolate([body_at(p) for p in SAMPLES], SAMPLES, parameter="p")
    for j, p in enumerate(MIDS):
        med, mx = _errors(pb.at(p), p)
        assert mx.max() < 1e-4
        for other in (body_at(SAMPLES[j]), body_at(SAMPLES[j + 1]), local.at(p)):
            omed, omx = _errors(other, p)
            assert np.all(med < omed) and np.all(mx < omx)


def test_samples_are_projections_and_stable():
    """At sample i the body holds exactly Vᵀ X(p_i) V (X = M, D, K), Vᵀ B, C V of that
    sample's FE model; Galerkin block-diagonal V (structural / pressure rows): every sample
    and every midpoint is stable."""
    pb = parametric()
    V = pb.R
    kinds = fe_at(0.0).dof_kind
    assert np.all((V[kinds == "p"] != 0).any(axis=0) != (V[kinds != "p"] != 0).any(axis=0))
    for p in SAMPLES:
        fe, b = fe_at(p), pb.at(p)
        for key, X in (("M", fe.M), ("D", fe.D), ("K", fe.K)):
            np.testing.assert_allclose(b[key], V.T @ (X @ V), rtol=0,
                                       atol=1e-12 * np.abs(b[key]).max())
        np.testing.assert_allclose(b.B, V.T @ fe.B(), rtol=1e-12, atol=0)
        assert stability(b).stable
    for p in MIDS:
        assert stability(pb.at(p)).stable


def test_energy_metric_is_positive_definite_in_joules():
    """uᵀK̄s u + pᵀM̄f p/ρ is symmetric and positive on a random vector (both blocks SPD)."""
    G = energy_metric([fe_at(p) for p in SAMPLES])
    x = np.random.default_rng(0).standard_normal(G.shape[0])
    assert x @ (G @ x) > 0
    assert abs(G - G.T).max() <= 1e-14 * abs(G).max()


def test_bad_samples_are_refused():
    """A sample FE model of another discretization and a value outside the samples: one
    clear error each, naming the model / the body, the value and the range."""
    other = membrane_cavity(0.3, n_x=20)
    with pytest.raises(DataError, match=r"FE model 2 \(membrane-cavity\) has another DOF map"):
        global_parametric_body([fe_at(0.0), other], [body_at(0.0), body_at(0.2)], [0.0, 0.2])
    with pytest.raises(DataError, match=r"'membrane-cavity': p = 0.5 is outside the sampled "
                                        r"range \[0.0, 0.4\]"):
        parametric().at(0.5)


def test_cli_interpolate_global_and_frf_body(tmp_path, capsys):
    """`reduce` per sample → `interpolate` (default --method global, FE models from the
    bodies' sources) → `frf-body --at` gives the FRF of ParametricBody.at; a reduced body
    works without --at; --at outside the range and on a reduced body are one-line errors."""
    paths = []
    for i, p in enumerate(SAMPLES):
        model = tmp_path / f"m{i}.npz"
        write_fe_model(fe_at(p), model)
        paths.append(str(tmp_path / f"b{i}.npz"))
        assert main(["reduce", str(model), "--modes", "20", "--static-correction",
                     "--store-bases", "-o", paths[-1]]) == 0
    out = tmp_path / "pb.npz"
    assert main(["interpolate", *paths, "--parameter", "p", "--values", "0,0.2,0.4",
                 "-o", str(out)]) == 0
    assert "global basis" in capsys.readouterr().out
    pb = load_parametric_body(out)
    csv = tmp_path / "frf.csv"
    assert main(["frf-body", str(out), "--at", "p=0.1", "--input", "force", "--response",
                 "umbo", "--response", "probe", "--f", "50:4000:120", "-o", str(csv)]) == 0
    table = np.genfromtxt(csv, delimiter=",", names=True)
    H = frf_reduced(pb.at(0.1), F, *IO)[:, :, 0]
    np.testing.assert_allclose(table["umbo_magnitude"], np.abs(H[:, 0]), rtol=1e-12)
    np.testing.assert_allclose(table["probe_real"], H[:, 1].real, rtol=1e-12)
    assert main(["frf-body", paths[0], "--input", "force", "--response", "umbo"]) == 0
    capsys.readouterr()
    for args, text in (([str(out), "--at", "p=1"], "p = 1.0 is outside the sampled range"),
                       ([paths[0], "--at", "p=0"], "--at applies to parametric bodies"),
                       ([str(out)], "give --at p=VALUE")):
        assert main(["frf-body", *args, "--input", "force", "--response", "umbo"]) == 1
        err = capsys.readouterr().err.strip().splitlines()[-1]
        assert err.startswith("neweul frf-body: error:") and text in err
    assert main(["interpolate", *paths, "--parameter", "p", "--weights", "1,1,1", "-o",
                 str(tmp_path / "x.npz")]) == 1
    assert "--weights applies to --method local only" in capsys.readouterr().err
    assert main(["interpolate", *paths, "--parameter", "p", "--basis", "kept", "--weights",
                 "1,1,1", "-o", str(tmp_path / "x.npz")]) == 1
    assert "--basis and --weights apply to --method local only" in capsys.readouterr().err


def test_cli_interpolate_finds_models_next_to_the_bodies(tmp_path, monkeypatch):
    """Bodies reduced in their own folder record their FE models by a relative name; run from
    another folder, `interpolate` finds them next to the bodies (docs/reduced-body-format.md;
    reference: the same interpolation run in the bodies' folder)."""
    d = tmp_path / "bodies"
    d.mkdir()
    monkeypatch.chdir(d)
    for i, p in enumerate(SAMPLES):
        write_fe_model(fe_at(p), d / f"m{i}.npz")
        assert main(["reduce", f"m{i}.npz", "--modes", "20", "--static-correction",
                     "--store-bases", "-o", f"b{i}.npz"]) == 0
    args = ["--parameter", "p", "--values", "0,0.2,0.4", "-o"]
    assert main(["interpolate", *[f"b{i}.npz" for i in range(3)], *args, "here.npz"]) == 0
    monkeypatch.chdir(tmp_path)
    assert main(["interpolate", *[f"bodies/b{i}.npz" for i in range(3)], *args,
                 "there.npz"]) == 0
    np.testing.assert_array_equal(load_parametric_body(tmp_path / "there.npz").K,
                                  load_parametric_body(d / "here.npz").K)


def test_invariants_follow_the_global_basis():
    """Bodies with invariants: every sample's invariants are those that compute_invariants
    gives for its FE model and the global basis (independent recomputation here), and the
    interpolated body carries them interpolated with the same weights as M, K."""
    bodies = [attach_invariants(body_at(p), fe_at(p)) for p in SAMPLES]
    pb = global_parametric_body([fe_at(p) for p in SAMPLES], bodies, SAMPLES, parameter="p")
    ids = [int(i) for i in pb.nodes[:, 0]]
    for p in SAMPLES:
        ref = compute_invariants(fe_at(p), pb.R, None, nodes=ids).to_flat()
        got = pb.at(p).invariants
        for name, a in ref.items():
            if np.asarray(a).dtype.kind == "f":
                np.testing.assert_allclose(got[name], a, rtol=1e-10,
                                           atol=1e-12 * (np.abs(a).max() or 1.0))
    w = pb.weights(0.1)
    mid = pb.at(0.1).invariants
    for name, a in pb.invariants.items():
        if a.dtype.kind == "f":
            np.testing.assert_allclose(mid[name], np.einsum("i,i...->...", w, a), rtol=1e-12,
                                       atol=1e-14 * (np.abs(a).max() or 1.0))


# ---------------------------------------------------------------- sample slopes (§4.2)
STEP = 1e-3


@cache
def fe_exp(p: float):
    """The string under the tension ``0.3 e^{2p}`` N: matrices not polynomial in ``p``."""
    return membrane_cavity(0.3 * float(np.exp(2.0 * p)))


@cache
def hermite_body() -> ParametricBody:
    fes = [fe_exp(p) for p in SAMPLES]
    bodies = [reduce_modal(fe, modes=20, static_correction=True, store_bases=True)
              for fe in fes]
    return global_parametric_body(
        fes, bodies, SAMPLES, parameter="p", interpolation="hermite",
        slope_models=([fe_exp(p - STEP) for p in SAMPLES], [fe_exp(p + STEP) for p in SAMPLES]),
        slope_step=STEP)


def test_sample_slopes_are_central_differences_of_the_projected_fe_matrices():
    """The slopes are ``Vᵀ(X(p+δ) − X(p−δ))V/(2δ)`` of the FE models next to each sample
    (computed here from the stored basis); Hermite weights then reproduce the projection of
    the FE matrices between samples better than the cubic spline through the values alone
    (reference: ``Vᵀ X(p) V`` of the FE model at the midpoint, equations.md §4.2)."""
    hb = hermite_body()
    assert hb.interpolation == "hermite" and hb.format_version == 4
    V = hb.R
    for i, p in enumerate(SAMPLES):
        for key in ("M", "D", "K"):
            ref = V.T @ ((getattr(fe_exp(p + STEP), key) - getattr(fe_exp(p - STEP), key))
                         @ V) / (2 * STEP)
            np.testing.assert_allclose(hb.slopes[key][i], ref, rtol=0,
                                       atol=1e-9 * np.abs(ref).max())
    for p in MIDS:
        ref = V.T @ (fe_exp(p).K @ V)
        herm = np.abs(hb.at(p).K - ref).max()
        cubic = np.abs(hb.at(p, "cubic").K - ref).max()
        assert herm < 0.2 * cubic, (p, herm, cubic)
        assert stability(hb.at(p)).stable


def test_bad_slope_models_are_refused():
    """A wrong count of slope models, a step that is not positive, a slope model on another
    mesh: one DataError each, naming what is wrong."""
    fes = [fe_exp(p) for p in SAMPLES]
    bodies = [body_at(p) for p in SAMPLES]
    side = [fe_exp(p) for p in SAMPLES]
    cases = [((side[:2], side), STEP, "one FE model on each side of each of the 3 samples"),
             ((side, side), 0.0, "positive number"),
             ((side, side), float("nan"), "positive number"),
             ((side, [*side[:2], membrane_cavity(0.3, n_x=20)]), STEP, "another DOF map")]
    for models, step, words in cases:
        with pytest.raises(DataError, match=words):
            global_parametric_body(fes, bodies, SAMPLES, parameter="p", slope_models=models,
                                   slope_step=step)


def test_cli_interpolate_with_slope_models(tmp_path, capsys):
    """``neweul interpolate --slope-models … --slope-step`` writes a Hermite body whose
    slopes are the central differences of the projected FE models given; wrong counts, a
    missing step,
    the local method or other weights are one-line errors and write nothing."""
    paths, slopes = [], []
    for i, p in enumerate(SAMPLES):
        model = tmp_path / f"m{i}.npz"
        write_fe_model(fe_exp(p), model)
        for sign, tag in ((-1, "minus"), (1, "plus")):
            slopes.append(str(tmp_path / f"m{i}{tag}.npz"))
            write_fe_model(fe_exp(p + sign * STEP), slopes[-1])
        paths.append(str(tmp_path / f"b{i}.npz"))
        assert main(["reduce", str(model), "--modes", "20", "--static-correction",
                     "--store-bases", "-o", paths[-1]]) == 0
    out = tmp_path / "pbh.npz"
    base = ["interpolate", *paths, "--parameter", "p", "--values", "0,0.2,0.4"]
    assert main([*base, "--slope-models", *slopes, "--slope-step", str(STEP),
                 "-o", str(out)]) == 0
    assert "slopes and curvatures (quintic Hermite)" in capsys.readouterr().out
    pb = load_parametric_body(out)
    assert pb.interpolation == "quintic-hermite"           # the default with slope models
    cubic = tmp_path / "pbc.npz"
    assert main([*base, "--slope-models", *slopes, "--slope-step", str(STEP),
                 "--interpolation", "hermite", "-o", str(cubic)]) == 0
    assert "slopes (Hermite)" in capsys.readouterr().out
    assert load_parametric_body(cubic).interpolation == "hermite"
    ref = pb.R.T @ ((fe_exp(0.2 + STEP).K - fe_exp(0.2 - STEP).K) @ pb.R) / (2 * STEP)
    # read from the file: in single precision (docs/reduced-body-format.md, version 9)
    np.testing.assert_allclose(pb.slopes["K"][1], ref, rtol=2.0**-24,
                               atol=1e-9 * np.abs(ref).max())
    bad = tmp_path / "bad.npz"
    for extra, words in ((["--slope-models", *slopes[:4], "--slope-step", "1e-3"],
                          "has 4 files for 3 bodies"),
                         (["--slope-models", *slopes], "go together"),
                         (["--slope-models", *slopes, "--slope-step", "1e-3", "--method",
                           "local"], "--method global only"),
                         (["--slope-models", *slopes, "--slope-step", "1e-3",
                           "--interpolation", "cubic"], "quintic-hermite), not"),
                         (["--interpolation", "hermite"], "needs the samples' slopes"),
                         (["--interpolation", "quintic-hermite", "--method", "local"],
                          "which --method global takes")):
        assert main([*base, *extra, "-o", str(bad)]) == 1
        err = capsys.readouterr().err.strip().splitlines()[-1]
        assert err.startswith("neweul interpolate: error:") and words in err, err
        assert not bad.exists()


def _static_samples():
    """The samples of :func:`fe_exp` carrying static states ``x_s(p) = sin(3p) a + p² b``
    (projected in the energy metric ``G``), and their slope models: ``(fes, bodies, x_s, G,
    (minus, plus))``."""
    from neweul_py.elastic.reductors.static_state import static_deflection

    rng = np.random.default_rng(7)
    fes = [fe_exp(p) for p in SAMPLES]
    n = fes[0].n_dofs
    a, b = rng.standard_normal(n) * 1e-6, rng.standard_normal(n) * 1e-6

    def x_s(p: float) -> np.ndarray:
        return np.sin(3 * p) * a + p**2 * b

    G = energy_metric(fes)
    bodies = [body_at(p) for p in SAMPLES]
    bodies = [bb.with_(static=static_deflection(bb, x_s(p), output_rows=fe.C(), metric=G))
              for bb, p, fe in zip(bodies, SAMPLES, fes, strict=True)]
    side = ([fe_exp(p - STEP) for p in SAMPLES], [fe_exp(p + STEP) for p in SAMPLES])
    return fes, bodies, x_s, G, side


def test_sample_slopes_of_static_states():
    """Samples that carry static states (``x_s(p) = sin(3p) a + p² b`` here) get the slopes
    of their projection on the global basis, of the node displacements and of the outputs
    from the slope models' static states: central differences of the same projections
    (reference: computed here from ``x_s(p ± δ)``); without those states the build is one
    DataError naming them."""
    fes, bodies, x_s, G, side = _static_samples()
    with pytest.raises(DataError, match="need the static states of the slope models"):
        global_parametric_body(fes, bodies, SAMPLES, parameter="p", slope_models=side,
                               slope_step=STEP)
    statics = ([{"x": x_s(p - STEP)} for p in SAMPLES], [{"x": x_s(p + STEP)} for p in SAMPLES])
    hb = global_parametric_body(fes, bodies, SAMPLES, parameter="p", slope_models=side,
                                slope_step=STEP, slope_statics=statics,
                                interpolation="hermite")
    V = hb.R
    proj = lambda x: np.linalg.solve(V.T @ (G @ V), V.T @ (G @ x))  # noqa: E731
    kept = hb.kept_dofs
    for i, p in enumerate(SAMPLES):
        dq = (proj(x_s(p + STEP)) - proj(x_s(p - STEP))) / (2 * STEP)
        np.testing.assert_allclose(hb.slopes["static/q"][i], dq, rtol=0,
                                   atol=1e-8 * np.abs(dq).max())
        du = (x_s(p + STEP) - x_s(p - STEP))[kept] / (2 * STEP)
        got = hb.slopes["static/node_u"][i].ravel()
        assert np.abs(got).max() > 0 and np.abs(got).max() <= np.abs(du).max() * (1 + 1e-9)
        dy = (fes[i].C() @ (x_s(p + STEP) - x_s(p - STEP))) / (2 * STEP)
        np.testing.assert_allclose(hb.slopes["static/outputs"][i], dy, rtol=2e-2,
                                   atol=1e-3 * np.abs(dy).max())
    assert not np.any(hb.slopes["static/residual"])


def test_sample_curvatures_are_second_differences_and_beat_the_slopes_alone():
    """With ``interpolation="quintic-hermite"`` the same slope models give the curvatures
    ``Vᵀ(X(p+δ) − 2X(p) + X(p−δ))V/δ²`` (computed here from the stored basis), the body
    records the step and the models' fingerprints, and the
    quintic Hermite weights reproduce the projection of the FE matrices between samples
    better than the cubic Hermite ones (reference: ``Vᵀ X(p) V`` of the FE model at the
    midpoint, equations.md §4.2; the tension ``0.3 e^{2p}`` is not polynomial in ``p``). A
    second difference loses ``ε/δ²`` to round-off, so the models sit ``δ = 0.02`` away (the
    slopes' 1e-3 would leave the curvatures round-off; O(δ²) = 4e-4 of them here)."""
    step = 0.02
    fes = [fe_exp(p) for p in SAMPLES]
    bodies = [reduce_modal(fe, modes=20, static_correction=True, store_bases=True)
              for fe in fes]
    side = ([fe_exp(p - step) for p in SAMPLES], [fe_exp(p + step) for p in SAMPLES])
    qb = global_parametric_body(fes, bodies, SAMPLES, parameter="p", slope_models=side,
                                slope_step=step, interpolation="quintic-hermite")
    hb = global_parametric_body(fes, bodies, SAMPLES, parameter="p", slope_models=side,
                                slope_step=step, interpolation="hermite")
    assert qb.interpolation == "quintic-hermite" and qb.format_version == 5
    assert qb.slope_step == step and [x["fingerprint"] for x in qb.slope_sources] == [
        fe.fingerprint for fe in (*side[0], *side[1])]         # where the slopes came from
    V = qb.R
    for i, p in enumerate(SAMPLES):
        ref = V.T @ ((fe_exp(p + step).K - 2 * fe_exp(p).K + fe_exp(p - step).K) @ V) / step**2
        np.testing.assert_allclose(qb.curvatures["K"][i], ref, rtol=0,
                                   atol=1e-9 * np.abs(ref).max())
    for p in MIDS:     # D: K's largest entries do not depend on p, their round-off would
        ref = V.T @ (fe_exp(p).D @ V)                               # hide the difference
        quintic = np.abs(qb.at(p).D - ref).max()
        cubic = np.abs(hb.at(p).D - ref).max()
        assert quintic < 0.2 * cubic, (p, quintic, cubic)       # here 0.08


def test_sample_curvatures_of_static_states_need_the_samples_own_states():
    """The static states' curvatures are the second differences of the projections of
    ``x_s(p ± δ)`` and ``x_s(p)`` alike (reference: computed here); without the samples'
    own FE states (``sample_statics``) the build is one DataError naming them — the
    samples' ``q`` is the projection of the local body's state, a second difference mixing
    the two definitions would be their difference over δ²."""
    fes, bodies, x_s, G, side = _static_samples()
    statics = ([{"x": x_s(p - STEP)} for p in SAMPLES], [{"x": x_s(p + STEP)} for p in SAMPLES])
    kw = dict(parameter="p", slope_models=side, slope_step=STEP, slope_statics=statics,
              interpolation="quintic-hermite")
    with pytest.raises(DataError, match="need the samples' own FE static states"):
        global_parametric_body(fes, bodies, SAMPLES, **kw)
    qb = global_parametric_body(fes, bodies, SAMPLES, sample_statics=[{"x": x_s(p)}
                                                                      for p in SAMPLES], **kw)
    V = qb.R
    proj = lambda x: np.linalg.solve(V.T @ (G @ V), V.T @ (G @ x))  # noqa: E731
    for i, p in enumerate(SAMPLES):
        d2q = (proj(x_s(p + STEP)) - 2 * proj(x_s(p)) + proj(x_s(p - STEP))) / STEP**2
        np.testing.assert_allclose(qb.curvatures["static/q"][i], d2q, rtol=0,
                                   atol=1e-5 * np.abs(d2q).max())
    assert not np.any(qb.curvatures["static/residual"])


def test_g_orthonormal_from_few_rows_equals_the_gram_eigen_decomposition() -> None:
    """With fewer nonzero rows than snapshots the basis comes from an SVD; reference: the
    eigen-decomposition of the Gram matrix ``XᵀGX`` of the unit-energy snapshots computed
    here — the same eigenvalues, the same span, ``QᵀGQ = I``."""
    from neweul_py.elastic.parametric.global_basis import g_orthonormal

    fe = membrane_cavity(0.3)
    G = energy_metric([fe])
    rng = np.random.default_rng(11)
    rows = np.flatnonzero(fe.dof_kind != "p")
    X = np.zeros((fe.n_dofs, 3 * rows.size))
    X[rows] = rng.standard_normal((rows.size, 8)) @ rng.standard_normal((8, X.shape[1]))
    Q, lam = g_orthonormal(X, G, 1e-10)
    Xu = X / np.sqrt(np.einsum("ij,ij->j", X, G @ X))
    ref = np.sort(np.linalg.eigvalsh(Xu.T @ (G @ Xu)))[::-1]
    assert Q.shape[1] == 8
    assert np.allclose(lam[:8], ref[:8], rtol=1e-10)
    assert np.abs(Q.T @ (G @ Q) - np.eye(8)).max() < 1e-10
    P = Q @ (Q.T @ (G @ Xu))                 # G-orthogonal projection of the snapshots
    assert np.abs(P - Xu).max() < 1e-8 * np.abs(Xu).max()


def test_g_orthonormal_of_many_columns_equals_the_one_stage_pod() -> None:
    """More columns than two chunks: the two-stage POD (chunks first) keeps the eigenvalues
    and the span of the one-stage POD computed here from the whole Gram matrix."""
    from neweul_py.elastic.parametric.global_basis import POD_CHUNK, g_orthonormal

    fe = membrane_cavity(0.3, n_x=48, n_z=24)
    G = energy_metric([fe])
    rng = np.random.default_rng(12)
    rows = np.flatnonzero(fe.dof_kind == "p")
    cols = 2 * POD_CHUNK + 37
    assert rows.size > cols
    X = np.zeros((fe.n_dofs, cols))
    X[rows] = (rng.standard_normal((rows.size, 40)) * np.logspace(0, -9, 40)) @ \
        rng.standard_normal((40, cols))
    Q, lam = g_orthonormal(X, G, 1e-12)
    Xu = X / np.sqrt(np.einsum("ij,ij->j", X, G @ X))
    ref, Z = np.linalg.eigh(Xu.T @ (G @ Xu))
    ref, Z = ref[::-1], Z[:, ::-1]
    k = Q.shape[1]
    assert k == int(np.sum(ref > 1e-12 * ref[0]))
    assert np.allclose(lam[:k], ref[:k], rtol=1e-6)
    Q_ref = Xu @ (Z[:, :k] / np.sqrt(ref[:k]))
    P, P_ref = (B @ (B.T @ (G @ Xu)) for B in (Q, Q_ref))
    assert np.abs(P - P_ref).max() < 1e-8 * np.abs(Xu).max()
