"""Parametric reduction with one global basis (``neweul_py.elastic.global_basis``),
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
from neweul_py.elastic.global_basis import energy_metric, global_parametric_body
from neweul_py.elastic.invariants import attach_invariants, compute_invariants
from neweul_py.elastic.quality import frf_full
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
                                        r"range \[0, 0.4\]"):
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
    pb = ParametricBody.load(out)
    csv = tmp_path / "frf.csv"
    assert main(["frf-body", str(out), "--at", "p=0.1", "--input", "force", "--response",
                 "umbo", "--response", "probe", "--f", "50:4000:120", "-o", str(csv)]) == 0
    table = np.genfromtxt(csv, delimiter=",", names=True)
    H = frf_reduced(pb.at(0.1), F, *IO)[:, :, 0]
    np.testing.assert_allclose(table["umbo_magnitude"], np.abs(H[:, 0]), rtol=1e-12)
    np.testing.assert_allclose(table["probe_real"], H[:, 1].real, rtol=1e-12)
    assert main(["frf-body", paths[0], "--input", "force", "--response", "umbo"]) == 0
    capsys.readouterr()
    for args, text in (([str(out), "--at", "p=1"], "p = 1 is outside the sampled range"),
                       ([paths[0], "--at", "p=0"], "--at applies to parametric bodies"),
                       ([str(out)], "give --at p=VALUE")):
        assert main(["frf-body", *args, "--input", "force", "--response", "umbo"]) == 1
        err = capsys.readouterr().err.strip().splitlines()[-1]
        assert err.startswith("neweul frf-body: error:") and text in err
    assert main(["interpolate", *paths, "--parameter", "p", "--weights", "1,1,1", "-o",
                 str(tmp_path / "x.npz")]) == 1
    assert "apply to --method local only" in capsys.readouterr().err


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
