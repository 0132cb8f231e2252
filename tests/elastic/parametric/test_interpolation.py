"""Parametric reduction by matrix interpolation (``docs/equations.md`` §4; Panzer, Mohring,
Eid & Lohmann 2010): ``neweul_py.elastic.bodies.parametric`` and ``neweul interpolate``.

The parametric FE model is the u–p piston–duct of Eq. (2) (``fe_builders.piston_duct``, 121
DOFs, damped piston) whose piston stiffness depends on the parameter,
``k_s(p) = 2·10⁵ (1 + p)`` N/m, ``p ∈ [0, 2]``: the piston resonance moves from 318 to 551 Hz
through the duct modes at 343 and 515 Hz, so the local modes veer, reorder and change sign
between samples — the case that needs common coordinates. The row scaling of u–p rows is
tested on it (with static correction) and on ``fe_builders.membrane_cavity`` (a light string
closing an air cavity in SI units, structural rows ~1e-6 of the pressure rows, as in the
middle ear), purely structural rows on a spring chain and a beam. The references are independent of
the code under test: the local two-sided modal models themselves (at the samples), models
reduced directly at parameter values between the samples, invariants computed from the FE
model with the transformed bases, and closed-form identities of the weights.
"""

from __future__ import annotations

import json
import re
from functools import cache
from itertools import pairwise

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sps
from beam_fe import beam
from body_arrays import explicit_arrays
from fe_builders import membrane_cavity, piston_duct, spring_chain

from neweul_py.cli import main
from neweul_py.elastic import (
    ParametricBody,
    ReducedBody,
    check_source,
    frf_reduced,
    interpolate,
    kind_row_scale,
    load_parametric_body,
    reduce_modal,
    stability,
)
from neweul_py.elastic.bodies.invariants import body_invariants
from neweul_py.elastic.io.body_files import (
    load_reduced_body,
    save_parametric_body,
    save_reduced_body,
)
from neweul_py.elastic.io.npz import json_to_uint8
from neweul_py.elastic.parametric.samples import coordinate_table
from neweul_py.elastic.reductors.invariants import attach_invariants, compute_invariants
from neweul_py.elastic.reductors.projection import build_reduced_body
from neweul_py.errors import DataError, SolverError

K0 = 2.0e5
MODES = 8
F = np.linspace(5.0, 700.0, 240)               # Hz, the band of the 8 retained modes
BETWEEN = (0.13, 0.37, 0.5 + 1 / 7, 0.81, 1.29, 1.66)   # not samples of any grid below


@cache
def fe_at(p: float, n_el: int = 120):
    return piston_duct(n_el, stiffness=K0 * (1 + p), damping=20.0)


@cache
def local(p: float, modes: int = MODES, two_sided: bool = True, n_el: int = 120,
          store: bool = True, keep_all: bool = False) -> ReducedBody:
    fe = fe_at(p, n_el)
    keep = fe.nodes[:, 0].astype(int) if keep_all else None
    return reduce_modal(fe, modes=modes, two_sided=two_sided, store_bases=store,
                        keep_nodes=keep)


def grid(k: int) -> np.ndarray:
    return np.linspace(0.0, 2.0, k)


def frf_error(a: ReducedBody, b: ReducedBody) -> float:
    """max over f of |H_a − H_b|, per input–output channel relative to max_f |H_b|."""
    Ha, Hb = frf_reduced(a, F), frf_reduced(b, F)
    return float((np.abs(Ha - Hb).max(axis=0) / np.abs(Hb).max(axis=0)).max())


def pencil(b: ReducedBody) -> np.ndarray:
    """Eigenvalues λ = ω² of (K, M), sorted by real part."""
    lam = sla.eigvals(b.K, b.M)
    return lam[np.argsort(lam.real)]


def eig_error(a: ReducedBody, b: ReducedBody) -> float:
    """Largest relative error of modes 2…6 (the zero mode has no relative scale)."""
    la, lb = pencil(a)[1:6], pencil(b)[1:6]
    return float(np.max(np.abs(la - lb) / np.abs(lb)))


def row_scale(pb: ParametricBody) -> np.ndarray:
    """The diagonal of S (ones for row_scaling 'none')."""
    return np.ones(pb.R.shape[0]) if pb.row_scale is None else pb.row_scale


# ------------------------------------------------------------------ at the samples
@pytest.mark.parametrize("scaling", ["none", "kind"])
def test_samples_are_reproduced_exactly(scaling):
    """At p_i the interpolated body is the transformed local model: same transfer function
    and same eigenvalues (to round-off); T_i = Rᵀ S V_i with the stored orthonormal R and
    row scaling S — for the plain and the kind-scaled rows alike."""
    s = grid(5)
    bodies = [local(p) for p in s]
    pb = interpolate(bodies, s, parameter="p", row_scaling=scaling)
    assert pb.basis == "full" and pb.order == MODES and pb.n_samples == 5
    assert pb.row_scaling == scaling
    np.testing.assert_allclose(pb.R.T @ pb.R, np.eye(MODES), atol=1e-13)
    S = row_scale(pb)
    for i, (p, b) in enumerate(zip(s, bodies, strict=True)):
        at = pb.at(p)
        assert np.array_equal(at.M, pb.M[i]) and np.array_equal(at.K, pb.K[i])
        assert not np.allclose(at.K, b.K)           # really other coordinates …
        assert frf_error(at, b) < 1e-10             # … but the same transfer function
        Tref = pb.R.T @ (S[:, None] * b.V)
        np.testing.assert_allclose(pb.T[i], Tref, rtol=0, atol=1e-14 * np.abs(Tref).max())
        np.testing.assert_allclose(pencil(at).real, np.sort(b.eigenvalues), rtol=1e-10,
                                   atol=1e-9 * b.eigenvalues.max())
        assert at.source["fingerprint"] == b.source["fingerprint"]
        assert at.parameters == {"p": p} and at.method == "interpolated"
        check_source(fe_at(p), at)                  # compare-frf accepts the sample's model
    with pytest.raises(DataError, match="different FE model"):
        check_source(fe_at(s[1]), pb.at(s[0]))
    between = pb.at(0.37)
    assert "fingerprint" not in between.source and between.source["n_dofs"] == 122
    assert len(between.source["sample_fingerprints"]) == 5
    check_source(fe_at(0.37), between)              # no fingerprint, the DOF map is checked


def test_transformation_is_a_state_space_equivalence():
    """Each local model's poles (damped, first-order form) and the eigenvalues of its
    undamped pencil are invariant under X̃ = L X T⁻¹ (K̃ − λM̃ = L (K − λM) T⁻¹), with
    T = Rᵀ S V and L = (Wᵀ S_W R)⁻¹ from the stored row scalings. The poles agree to
    round-off amplified by cond(T_i)·cond(L_i) (measured 3e-13 per unit for the plain and
    the kind-scaled rows alike; tolerance 1e-11 per unit); the closed duct's double pole at
    s = 0 (constant pressure, λ = 0) moves by √(round-off), so it is compared on that scale."""
    s = grid(3)
    bodies = [local(p) for p in s]
    pb = interpolate(bodies, s, parameter="p")
    assert pb.row_scaling == "kind" and pb.left_row_scale is not None
    S, SW = pb.row_scale[:, None], pb.left_row_scale[:, None]
    for i, b in enumerate(bodies):
        poles, ours = stability(b).poles, stability(pb.at(s[i])).poles
        assert ours.size == poles.size == 2 * MODES
        top = np.abs(poles).max()
        zero = np.abs(poles) < 1e-6 * top
        assert np.count_nonzero(zero) == 2 and np.all(np.abs(ours[np.abs(ours) < 1e-3 * top])
                                                      < 1e-6 * top)
        ours = ours[np.abs(ours) >= 1e-3 * top]
        dist = np.abs(ours[:, None] - poles[~zero][None, :])   # each pole has its twin
        amplification = np.linalg.cond(pb.T[i]) * np.linalg.cond(pb.L[i])
        assert max(dist.min(axis=0).max(), dist.min(axis=1).max()) < (
            1e-11 * amplification * top)
        np.testing.assert_allclose(pencil(pb.at(s[i]))[1:], pencil(b)[1:], rtol=1e-11)
        Tinv = np.linalg.inv(pb.T[i])
        np.testing.assert_allclose(pb.T[i], pb.R.T @ (S * b.V), rtol=1e-12)
        np.testing.assert_allclose(pb.L[i], np.linalg.inv((SW * b.W).T @ pb.R), rtol=1e-12)
        for key, ref in (("D", pb.L[i] @ b.D @ Tinv), ("B", pb.L[i] @ b.B),
                         ("C", b.C @ Tinv)):
            np.testing.assert_allclose(pb[key][i], ref, rtol=0,
                                       atol=1e-12 * np.abs(ref).max(), err_msg=key)


# --------------------------------------------------------------- between the samples
def test_between_samples_converges_to_direct_reduction():
    """At parameter values that are no samples, the FRF and eigenvalues of the interpolated
    body approach those of a model reduced directly there as the samples are refined
    (measured with the default kind row scaling, linear: eigenvalues 7.6e-4, 1.9e-4,
    5.9e-5, 9.4e-6 and FRF 3.3e-2, 6.7e-3, 2.2e-3, 3.8e-4 for 3, 5, 9, 17 samples; cubic:
    7.4e-5, 3.3e-7, 2.1e-8, 9.3e-11 and 3.3e-3, 1.1e-5, 6.7e-7, 3.4e-9 — with the plain
    rows, row_scaling="none", linear 4.2e-2, 1.2e-2, 4.8e-3, 4.5e-4 and 1.5, 0.55, 0.15,
    1.8e-2, cubic 2.3e-2, 2.5e-3, 3.3e-4, 2.5e-6 and 2.0, 7.9e-2, 1.1e-2, 8.0e-5). The FRF
    error is max_f |H − H_direct| / max_f |H_direct| per channel, so a shifted resonance
    counts fully (hence > 1 with 3 plain samples)."""
    direct = {p: local(p) for p in BETWEEN}
    errors = {}
    for kind in ("linear", "cubic"):
        for k in (3, 5, 9, 17):
            s = grid(k)
            pb = interpolate([local(p) for p in s], s, parameter="p", interpolation=kind)
            at = {p: pb.at(p) for p in BETWEEN}
            errors[kind, k] = (max(eig_error(at[p], direct[p]) for p in BETWEEN),
                               max(frf_error(at[p], direct[p]) for p in BETWEEN))
    for kind in ("linear", "cubic"):
        ev = [errors[kind, k][0] for k in (3, 5, 9, 17)]
        assert all(a > b for a, b in pairwise(ev)), (kind, ev)
        fr = [errors[kind, k][1] for k in (5, 9, 17)]
        assert all(a > b for a, b in pairwise(fr)), (kind, fr)
    assert errors["linear", 17][0] < 1e-4 and errors["linear", 17][1] < 4e-3
    assert errors["cubic", 17][0] < 1e-8 and errors["cubic", 17][1] < 1e-6
    assert errors["cubic", 9][0] < errors["linear", 9][0] / 5


def test_weights():
    """Linear weights are hat functions (they reproduce linear functions of p), cubic ones
    the not-a-knot spline's cardinal functions (they reproduce cubics); both sum to one and
    are unit vectors at the samples."""
    s = np.array([0.0, 0.5, 1.2, 2.0, 3.5])
    pb = interpolate([local(p, modes=3, n_el=30) for p in s], s)
    np.testing.assert_array_equal(pb.weights(0.25), [0.5, 0.5, 0, 0, 0])
    for p in np.linspace(0, 3.5, 23):
        wl, wc = pb.weights(p), pb.weights(p, "cubic")
        assert np.count_nonzero(wl) <= 2 and np.all(wl >= 0)
        assert abs(wl.sum() - 1) < 1e-14 and abs(wc.sum() - 1) < 1e-13
        assert abs(wl @ (2 * s - 1) - (2 * p - 1)) < 1e-13
        assert abs(wc @ (s**3 - s**2) - (p**3 - p**2)) < 1e-11
    for i, p in enumerate(s):
        for kind in ("linear", "cubic"):
            assert np.array_equal(pb.weights(p, kind), np.eye(5)[i])


# ------------------------------------------------------------------------ Galerkin
def test_one_sided_data_gives_the_galerkin_formula():
    """W = V: L_i = T_i⁻ᵀ and X̃_i = T_i⁻ᵀ X_r,i T_i⁻¹; the general two-sided path
    L_i = (W_iᵀ R)⁻¹ on the same data gives the same matrices."""
    s = grid(3)
    bodies = [local(p, two_sided=False) for p in s]
    pb = interpolate(bodies, s, parameter="p")
    assert not pb.two_sided and not pb.at(0.7).two_sided
    as_two = [b.with_(settings={**b.settings, "two_sided": True}) for b in bodies]
    pb2 = interpolate(as_two, s, parameter="p")
    assert pb2.two_sided
    for i, b in enumerate(bodies):
        Ti = np.linalg.inv(pb.T[i])
        assert np.array_equal(pb.L[i], Ti.T)
        for key in ("M", "D", "K"):
            ref = Ti.T @ b[key] @ Ti
            scale = np.abs(ref).max()
            np.testing.assert_allclose(pb[key][i], ref, rtol=0, atol=1e-12 * scale)
            np.testing.assert_allclose(pb2[key][i], ref, rtol=0, atol=1e-9 * scale)
        np.testing.assert_allclose(pb.W_kept[i], pb.V_kept[i], rtol=1e-13, atol=0)


def test_galerkin_keeps_symmetric_models_symmetric():
    """A symmetric structure (spring chain with a grounding spring k_g(p) at its middle
    node): the one-sided local and interpolated mass and stiffness matrices stay symmetric
    positive definite in common coordinates."""
    chain = spring_chain(40, damping=1e-4)
    mid = np.zeros(40)
    mid[20] = 1.0

    def body(p: float) -> ReducedBody:
        fe = chain.with_(K=chain.K + sps.diags(3e4 * p * mid), name=f"chain-{p}")
        return reduce_modal(fe, modes=6, two_sided=False, store_bases=True)

    s = np.array([0.0, 1.0, 2.0])
    pb = interpolate([body(p) for p in s], s, parameter="kg")
    for X in (*pb.M, *pb.K, pb.at(0.4).M, pb.at(1.7, "cubic").K):
        np.testing.assert_allclose(X, X.T, rtol=0, atol=1e-12 * np.abs(X).max())
        assert np.linalg.eigvalsh(X).min() > 0


# ---------------------------------------------------------------------- invariants
def test_invariants_are_transformed_consistently():
    """Step 6: the invariants of the interpolated body at a sample equal those computed from
    the FE model with the transformed bases V_i T_i⁻¹, W_i L_iᵀ; between samples they stay
    consistent with the interpolated matrices (Me = M, Ke = K, node Φ = the V_kept rows)."""
    s = grid(3)
    bodies = [attach_invariants(local(p, modes=4, n_el=40), fe_at(p, 40)) for p in s]
    pb = interpolate(bodies, s, parameter="p")
    ids = [int(i) for i in bodies[0].nodes[:, 0]]
    for i, p in enumerate(s):
        Tinv = np.linalg.inv(pb.T[i])
        ref = compute_invariants(fe_at(p, 40), bodies[i].V @ Tinv, bodies[i].W @ pb.L[i].T,
                                 nodes=ids).to_flat()
        got = pb.at(p).invariants
        assert list(got) == list(ref)
        for name, a in ref.items():
            if a.dtype.kind == "f":
                scale = max(np.abs(a).max(), 1e-300)
                np.testing.assert_allclose(got[name], a, rtol=0, atol=1e-9 * scale,
                                           err_msg=name)
            else:
                assert np.array_equal(got[name], a), name
    for p in (0.3, 1.45):
        at = pb.at(p)
        inv = body_invariants(at)
        np.testing.assert_allclose(inv.Me.m0, at.M, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(inv.Ke.m0, at.K, rtol=1e-12, atol=1e-9)
        row = int(np.flatnonzero((at.dof_node == 1) & (at.dof_kind == "ux"))[0])
        np.testing.assert_allclose(inv.node(1).phi.m0[0], at.V_kept[row], rtol=1e-12)
        np.testing.assert_allclose(inv.node(1).load_phi[0], at.W_kept[row], rtol=1e-12)


# ---------------------------------------------------------------------- row scaling
def _random_bases(kinds: np.ndarray, k: int = 3, r: int = 6, seed: int = 0) -> list:
    """Random bases whose rows have magnitudes 1e-7 (u), 1e-4 (r) and 1e2 (p)."""
    rng = np.random.default_rng(seed)
    mag = np.select([np.char.startswith(kinds, "u"), np.char.startswith(kinds, "r")],
                    [1e-7, 1e-4], 1e2)
    return [mag[:, None] * rng.normal(size=(kinds.size, r)) for _ in range(k)]


def test_kind_row_scale_balances_the_groups():
    """Reference: the RMS of each group's entries in the orthonormalized scaled bases
    (np.linalg.qr of S V_i, stacked) — equal for translations, rotations and pressure —
    and the invariances that make the result independent of units and basis vectors."""
    kinds = np.array((["ux", "uy", "uz", "rx", "ry", "rz"] * 9) + ["p"] * 40)
    Vs = _random_bases(kinds)
    S = kind_row_scale(Vs, kinds)
    Q = np.hstack([np.linalg.qr(S[:, None] * V)[0] for V in Vs])
    groups = {"t": np.char.startswith(kinds, "u"), "r": np.char.startswith(kinds, "r"),
              "p": kinds == "p"}
    rms = {g: np.sqrt(np.mean(Q[m] ** 2)) for g, m in groups.items()}
    np.testing.assert_allclose([rms["r"], rms["p"]], rms["t"], rtol=1e-8)
    assert np.all(S[groups["t"]] == 1.0)                   # first group: factor 1
    for m in groups.values():
        assert np.all(S[m] == S[m][0])                     # one factor per group
    # units: rows D⁻¹ (m → mm, rad → mrad, Pa → kPa) give S D; basis vectors V_i A_i
    d = np.select([groups["t"], groups["r"]], [1e3, 1e3], 1e-3)
    rng = np.random.default_rng(5)
    other = [V / d[:, None] @ rng.normal(size=(6, 6)) for V in Vs]
    S2 = kind_row_scale(other, kinds)
    np.testing.assert_allclose(S2 / d, S / S[0] * (S2[0] / d[0]), rtol=1e-9)
    # one group, or a group without entries: nothing to balance
    assert np.array_equal(kind_row_scale(Vs, np.full(kinds.size, "uz")), np.ones(kinds.size))
    zero_p = [np.where(groups["p"][:, None], 0.0, V) for V in Vs]
    assert np.all(kind_row_scale(zero_p, kinds)[groups["p"]] == 1.0)


@cache
def cavity_at(p: float):
    """Membrane tension 0.3 (1 + p) N: resonances 1.0–5.7 kHz at p = 0, +18 % at p = 0.4."""
    return membrane_cavity(0.3 * (1 + p))


@cache
def cavity_body(p: float, store: bool = True) -> ReducedBody:
    return reduce_modal(cavity_at(p), modes=20, static_correction=True, store_bases=store)


CAVITY_SAMPLES = (0.0, 0.2, 0.4)
CAVITY_BETWEEN = (0.1, 0.3)
FC = np.linspace(50.0, 4000.0, 200)


def median_error(a: ReducedBody, b: ReducedBody, output: str) -> float:
    """Median over FC of |H_a − H_b| / |H_b| for input 'force' and ``output``."""
    Ha, Hb = frf_reduced(a, FC, outputs=output), frf_reduced(b, FC, outputs=output)
    return float(np.median(np.abs(Ha - Hb) / np.abs(Hb)))


def in_pressure_unit(body: ReducedBody, fe, unit: float) -> ReducedBody:
    """The same reduction of the same physics with pressure DOFs in units of 1/unit Pa.

    p' = unit·p is the congruence x = D x', D = diag(1 (u), 1/unit (p)): the FE model
    D M D, D K D, D D D, inputs D B, outputs C D (Eq. (2) is kept, ρ unchanged) with bases
    D⁻¹ V, D⁻¹ W, projected from scratch (``build_reduced_body``). The eigensolver itself
    refuses such rescaled models (see the report), hence the projection of the known bases.
    """
    d = np.where(fe.dof_kind == "p", 1.0 / unit, 1.0)
    Dg = sps.diags(d)

    def table(t):
        return {k: tuple((i, w * d[i]) for i, w in v) for k, v in t.items()}

    fe_u = fe.with_(M=Dg @ fe.M @ Dg, K=Dg @ fe.K @ Dg, D=Dg @ fe.D @ Dg,
                    inputs=table(fe.inputs), outputs=table(fe.outputs))
    return build_reduced_body(fe_u, body.V / d[:, None], body.W / d[:, None], body.method,
                              body.settings, store_bases=True)


def test_kind_scaling_aligns_a_light_membrane_in_si_units():
    """A u–p model in SI units whose structural rows are ~1e-6 of the pressure rows in the
    unit-norm bases (membrane_cavity: a light string closing an air cavity, as the middle
    ear's TM): between the samples, against models reduced directly there, the structural
    output (umbo displacement) is far better with the kind scaling than with the plain
    rows (measured max over p of the median error: 3.0 % plain, 8e-5 kind, 1.3 % balanced
    without the pressure weight; probe pressure 2.7 % and 2e-6; the nearest sample alone
    18 %). The result does not depend on the unit of pressure (p in mPa or kPa: the same
    errors to 1e-11), the plain one does (3.0 %, 2.9 %, 1.4 % for Pa, mPa, kPa)."""
    s = np.array(CAVITY_SAMPLES)
    bodies = [cavity_body(p) for p in s]
    direct = {p: cavity_body(p, store=False) for p in CAVITY_BETWEEN}

    def errors(bb, scaling, output="umbo"):
        pb = interpolate(bb, s, parameter="tension", row_scaling=scaling)
        return max(median_error(pb.at(p), direct[p], output) for p in CAVITY_BETWEEN)

    plain, kind = errors(bodies, "none"), errors(bodies, "kind")
    nearest = max(median_error(cavity_body(s[np.argmin(abs(s - p))]), direct[p], "umbo")
                  for p in CAVITY_BETWEEN)
    assert plain > 0.02 and kind < 1e-3 and kind < plain / 50 and nearest > 0.1
    assert errors(bodies, "kind", "probe") < errors(bodies, "none", "probe") / 50
    assert interpolate(bodies, s).row_scaling == "kind"      # the default
    for unit in (1e3, 1e-3):
        other = [in_pressure_unit(b, cavity_at(p), unit) for p, b in zip(s, bodies,
                                                                         strict=True)]
        assert median_error(other[1], bodies[1], "umbo") < 1e-6   # the same local models
        assert errors(other, "kind") == pytest.approx(kind, rel=1e-4)
        if unit < 1:
            assert abs(errors(other, "none") - plain) > 0.3 * plain


def test_kind_scaling_of_the_piston_duct_with_static_correction():
    """One structural DOF (the piston) among 121 pressures, 8 modes + static correction:
    the plain common coordinates mix the piston's static vector with the duct modes and
    shift a resonance (max error ≈ 1 of the max-normalized FRF), the kind scaling aligns
    it (measured 1.3 plain, 4.9e-3 kind, 1.9 balanced without the pressure weight)."""
    s = grid(5)
    bodies = [reduce_modal(fe_at(p), modes=MODES, static_correction=True, store_bases=True)
              for p in s]
    direct = {p: reduce_modal(fe_at(p), modes=MODES, static_correction=True)
              for p in BETWEEN}
    err = {sc: max(frf_error(interpolate(bodies, s, row_scaling=sc).at(p), direct[p])
                   for p in BETWEEN) for sc in ("none", "kind")}
    assert err["none"] > 0.5 and err["kind"] < 1e-2


def test_structural_models_are_not_affected():
    """Translations only (spring chain): the kind scaling is S = I, bit for bit the plain
    result. A beam (translations and rotations; tension N(p) stiffens the bending modes):
    the balanced rotation factor keeps the quality of the plain rows (measured max FRF
    error between samples: plain 3.8e-3, kind 3.7e-3)."""
    chain = spring_chain(40, damping=1e-4)
    mid = np.zeros(40)
    mid[20] = 1.0
    bodies = [reduce_modal(chain.with_(K=chain.K + sps.diags(3e4 * p * mid), name=f"c{p}"),
                           modes=6, store_bases=True) for p in (0.0, 1.0, 2.0)]
    a = interpolate(bodies, [0.0, 1.0, 2.0], row_scaling="kind")
    b = interpolate(bodies, [0.0, 1.0, 2.0], row_scaling="none")
    assert a.row_scaling == "kind" and np.all(a.row_scale == 1.0)
    for key in ("M", "D", "K", "B", "C", "T", "L", "R"):
        assert np.array_equal(a[key], b[key]), key

    def beam_at(p: float):
        bm = beam(16)
        clamp = np.zeros(bm.n)
        clamp[:6] = 1e8
        K = bm.fe.K + sps.diags(clamp) + bm.geometric_stiffness(np.full(16, 20.0 * p))
        tip = bm.dof(16, 2)
        return bm.fe.with_(K=K, D=1e-4 * K, inputs={"f": ((tip, 1.0),)},
                           outputs={"w": ((tip, 1.0),), "ry": ((bm.dof(16, 4), 1.0),)},
                           name=f"beam-{p}")

    s = np.linspace(0.0, 1.0, 5)
    bodies = [reduce_modal(beam_at(p), modes=8, store_bases=True) for p in s]
    direct = {p: reduce_modal(beam_at(p), modes=8) for p in (0.1, 0.35, 0.6, 0.9)}
    pbs = {sc: interpolate(bodies, s, row_scaling=sc) for sc in ("none", "kind")}
    assert set(pbs["kind"].group_scales) == {"translation", "rotation"}
    err = {sc: max(frf_error(pb.at(p), direct[p]) for p in direct) for sc, pb in pbs.items()}
    assert err["kind"] < 1.2 * err["none"] and err["none"] < 0.1


def test_given_row_scaling_equals_scaled_bases():
    """An array S is the plain interpolation of the bodies with bases S V_i, S W_i (the
    reduced matrices are those of the bodies): the same transformed matrices and T, L."""
    s = grid(3)
    bodies = [local(p) for p in s]
    S = np.random.default_rng(3).uniform(0.1, 10.0, bodies[0].V.shape[0])
    given = interpolate(bodies, s, row_scaling=S)
    scaled = interpolate([b.with_(V=S[:, None] * b.V, W=S[:, None] * b.W) for b in bodies],
                         s, row_scaling="none")
    assert given.row_scaling == "given" and np.array_equal(given.row_scale, S)
    assert given.left_row_scale is None and given.pressure_weight is None
    for key in ("M", "D", "K", "B", "C", "T", "L", "R"):
        np.testing.assert_allclose(given[key], scaled[key], rtol=1e-12,
                                   atol=1e-12 * np.abs(scaled[key]).max(), err_msg=key)


def test_galerkin_data_uses_one_scaling():
    """One-sided data: S_W = S (none is stored), L_i = T_i⁻ᵀ; the two-sided path on the
    same data balances W_i = V_i to the same S_W = S and gives the same matrices."""
    s = grid(3)
    bodies = [local(p, two_sided=False) for p in s]
    pb = interpolate(bodies, s)
    assert pb.row_scaling == "kind" and pb.left_row_scale is None
    two = interpolate([b.with_(settings={**b.settings, "two_sided": True}) for b in bodies], s)
    np.testing.assert_allclose(two.left_row_scale, two.row_scale, rtol=1e-10)
    for key in ("M", "K"):
        np.testing.assert_allclose(two[key], pb[key], rtol=0,
                                   atol=1e-9 * np.abs(pb[key]).max(), err_msg=key)


def test_row_scaling_options():
    """Defaults and refusals: auto is kind with the DOF kinds of the rows (full bases with
    full_dof_kind, or the kept rows), none for bodies reduced before full_dof_kind existed;
    kind without kinds, bad arrays and pressure weights are errors."""
    s = grid(3)
    bodies = [local(p, modes=4, n_el=40) for p in s]
    assert interpolate(bodies, s).row_scaling == "kind"
    old = [b.with_(full_dof_kind=None) for b in bodies]
    assert interpolate(old, s).row_scaling == "none"
    with pytest.raises(DataError, match="needs the DOF kinds") as exc:
        interpolate(old, s, row_scaling="kind")
    assert exc.value.item == "full_dof_kind"
    kept = [local(p, modes=4, n_el=40, store=False, keep_all=True) for p in s]
    pk = interpolate(kept, s)
    assert pk.basis == "kept" and pk.row_scaling == "kind"
    assert pk.row_scale.shape == (kept[0].kept_dofs.size,)
    for bad, text in ((np.ones(5), "needs 42 finite positive"),
                      (-np.ones(42), "needs 42 finite positive"), ("size", "must be one of")):
        with pytest.raises(DataError, match=text):
            interpolate(bodies, s, row_scaling=bad)
    for pw in (0.0, -1.0, np.nan, "x"):
        with pytest.raises(DataError, match="positive number"):
            interpolate(bodies, s, pressure_weight=pw)
    kinds = bodies[1].full_dof_kind.copy()
    kinds[5] = "uz"                                 # not a kept DOF
    mixed = [bodies[0], bodies[1].with_(full_dof_kind=kinds)]
    with pytest.raises(DataError, match="full_dof_kind"):
        interpolate(mixed, s[:2])
    pb = interpolate(bodies, s, store_bases=True)
    assert np.array_equal(pb.at(0.3).full_dof_kind, bodies[0].full_dof_kind)
    with pytest.raises(DataError, match="'none' stores no row_scale"):
        pb.with_(row_scaling="none", pressure_weight=None)


# -------------------------------------------------------------------- kept rows only
def test_kept_rows_basis():
    """Bodies without full bases: with every node kept, basis='kept' gives the same common
    coordinates as the full bases (the rows are only permuted); with the default kept nodes
    (3 DOFs for 8 coordinates) it is a clear error, as is basis='full'."""
    s = grid(3)
    full = interpolate([local(p) for p in s], s, parameter="p")
    kept_bodies = [local(p, store=False, keep_all=True) for p in s]
    assert kept_bodies[0].V is None
    kept = interpolate(kept_bodies, s, parameter="p")
    assert kept.basis == "kept"
    for key in ("M", "D", "K", "B", "C", "T"):
        scale = np.abs(full[key]).max()
        np.testing.assert_allclose(kept[key], full[key], rtol=0, atol=1e-9 * scale,
                                   err_msg=key)
    few = [local(p, store=False) for p in s]
    with pytest.raises(DataError, match="3 kept DOFs cannot determine 8"):
        interpolate(few, s)
    with pytest.raises(DataError, match="store_bases"):
        interpolate(few, s, basis="full")
    with pytest.raises(DataError, match="store_bases"):
        interpolate(kept_bodies, s, store_bases=True)


# -------------------------------------------------------------------------- file
def _assert_same(a: ParametricBody, b: ParametricBody) -> None:
    for key in ("samples", "M", "D", "K", "B", "C", "nodes", "kept_dofs", "dof_node",
                "dof_kind", "V_kept", "W_kept", "T", "L", "R", "singular_values",
                "svd_weights", "V", "W", "row_scale", "left_row_scale", "full_dof_kind"):
        x, y = a[key], b[key]
        assert (x is None) == (y is None), key
        if x is not None:
            assert x.dtype == y.dtype and np.array_equal(x, y), key
    for key in ("parameter", "input_names", "output_names", "basis", "two_sided",
                "interpolation", "sample_sources", "sample_methods", "sample_settings",
                "row_scaling", "pressure_weight"):
        assert a[key] == b[key], key
    assert (a.invariants is None) == (b.invariants is None)
    if a.invariants is None:
        return
    assert list(a.invariants) == list(b.invariants)
    for k in a.invariants:
        assert a.invariants[k].dtype == b.invariants[k].dtype
        assert np.array_equal(a.invariants[k], b.invariants[k]), k


@pytest.fixture(scope="module")
def pbody():
    s = grid(3)
    bodies = [attach_invariants(local(p, modes=4, n_el=40), fe_at(p, 40)) for p in s]
    return interpolate(bodies, s, parameter="p", interpolation="cubic", store_bases=True,
                       weights=[1.0, 2.0, 1.0])


def test_file_round_trip_is_exact(pbody, tmp_path):
    path = tmp_path / "pb.npz"
    assert pbody.row_scaling == "kind" and pbody.left_row_scale is not None
    assert pbody.full_dof_kind is not None and pbody.pressure_weight == 1e-3
    save_parametric_body(pbody, path)
    back = load_parametric_body(path)
    _assert_same(pbody, back)
    for p in (0.0, 0.77, 2.0):
        a, b = pbody.at(p), back.at(p)
        for key in ("M", "D", "K", "B", "C", "V_kept", "W_kept", "V", "W", "full_dof_kind"):
            assert np.array_equal(a[key], b[key]), key
        assert a.settings == b.settings and a.source == b.source
        assert a.settings["row_scaling"] == "kind"
    with np.load(path, allow_pickle=False) as z:
        meta = json.loads(z["meta"].tobytes().decode())
        assert all(z[k].dtype != object for k in z.files)
    assert meta["format"] == "neweul-parametric-body" and meta["version"] == 9
    assert meta["parameter"] == "p" and meta["interpolation"] == "cubic"
    assert meta["row_scaling"] == "kind" and meta["pressure_weight"] == 1e-3


def test_version_1_files_still_load(tmp_path):
    """A version-1 file (written before the row scaling existed: no row_scaling in the
    metadata, no row_scale array) loads as row_scaling 'none' — its T_i = Rᵀ V_i — and is
    written back in the newest (compact) version, equal; a version-1 file with version-2
    arrays is refused."""
    s = grid(3)
    pb = interpolate([local(p, modes=4, n_el=40) for p in s], s, row_scaling="none")
    path = tmp_path / "v1.npz"
    save_parametric_body(pb, path)
    data = explicit_arrays(path)
    meta = json.loads(data["meta"].tobytes().decode())
    del meta["row_scaling"], meta["pressure_weight"], data["full_dof_kind"]
    np.savez(path, **{**data, "meta": json_to_uint8({**meta, "version": 1})})
    old = load_parametric_body(path)
    assert old.format_version == 1 and old.row_scaling == "none" and old.row_scale is None
    assert old.full_dof_kind is None
    for key in ("M", "K", "T", "L", "R"):
        assert np.array_equal(old[key], pb[key]), key
    np.testing.assert_allclose(old.T[1], old.R.T @ local(1.0, modes=4, n_el=40).V,
                               rtol=0, atol=1e-14)
    save_parametric_body(old, tmp_path / "again.npz")
    again = load_parametric_body(tmp_path / "again.npz")
    assert again.format_version == 9 and again.row_scaling == "none"
    for key in ("M", "K", "T", "L", "R"):
        assert np.array_equal(again[key], old[key]), key
    np.savez(path, **{**data, "row_scale": np.ones(pb.R.shape[0]),
                      "meta": json_to_uint8({**meta, "version": 1})})
    with pytest.raises(DataError, match="version-1 file holds no") as exc:
        load_parametric_body(path)
    assert exc.value.item == "row_scale"


def test_interrupted_write_keeps_the_old_file(pbody, tmp_path, monkeypatch):
    path = tmp_path / "pb.npz"
    save_parametric_body(pbody, path)
    before = path.read_bytes()

    def boom(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(np, "savez", boom)
    with pytest.raises(KeyboardInterrupt):
        save_parametric_body(pbody.with_(interpolation="linear"), path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["pb.npz"]


def test_bad_files_are_rejected(pbody, tmp_path):
    path = tmp_path / "pb.npz"
    save_parametric_body(pbody, path)
    with pytest.raises(DataError, match='"format" must be'):
        load_reduced_body(path)
    save_reduced_body(local(0.0, modes=4, n_el=40), tmp_path / "b.npz")
    with pytest.raises(DataError, match="load_reduced_body") as exc:
        load_parametric_body(tmp_path / "b.npz")
    assert exc.value.file == str(tmp_path / "b.npz")
    data = explicit_arrays(path)
    meta = json.loads(data["meta"].tobytes().decode())
    np.savez(path, **{**data, "meta": json_to_uint8({**meta, "version": 99})})
    with pytest.raises(DataError, match="unsupported version 99"):
        load_parametric_body(path)
    del data["T"]
    np.savez(path, **data)
    with pytest.raises(DataError, match="missing arrays") as exc:
        load_parametric_body(path)
    assert exc.value.item == "T"
    np.savez(path, **{**data, "T": np.zeros((3, 4, 4)), "samples": np.array([0.0, 2, 1])})
    with pytest.raises(DataError, match="strictly increasing") as exc:
        load_parametric_body(path)
    assert exc.value.file == str(path)


# -------------------------------------------------------------------- bad inputs
def test_outside_the_sampled_range_is_an_error():
    s = grid(3)
    pb = interpolate([local(p) for p in s], s, parameter="pressure")
    for p in (-1e-9, 2.0 + 1e-9, np.nan, np.inf):
        with pytest.raises(DataError, match="outside the sampled range") as exc:
            pb.at(p)
        assert exc.value.item == "pressure"
    with pytest.raises(DataError, match="unknown interpolation"):
        pb.at(1.0, "quadratic")
    with pytest.raises(DataError, match="must be a number"):
        pb.at("high")


def _renamed(b: ReducedBody) -> ReducedBody:
    return b.with_(output_names=("p_far", "x_piston"))


@pytest.mark.parametrize("make,samples,text", [
    (lambda: [local(0.0)], [0.0], "at least 2"),
    (lambda: [local(0.0), local(1.0), local(2.0)], [0.0, 2.0, 1.0], "strictly increasing"),
    (lambda: [local(0.0), local(1.0), local(2.0)], [0.0, 1.0, 1.0], "strictly increasing"),
    (lambda: [local(0.0), local(1.0)], [0.0, 1.0, 2.0], "3 sample values for 2 bodies"),
    (lambda: [local(0.0), local(1.0)], [0.0, np.nan], "finite"),
    (lambda: [local(0.0), local(1.0)], None, "record no value of 'p'"),
    (lambda: [local(0.0).with_(parameters={"p": 0.5}), local(1.0)], [0.0, 1.0],
     "records p = 0.5"),
    (lambda: [local(0.0), local(1.0, n_el=60)], [0.0, 1.0], "n_dofs 62 vs 122"),
    (lambda: [local(0.0), local(1.0, modes=6)], [0.0, 1.0], "order 6 vs 8"),
    (lambda: [local(0.0), local(1.0, two_sided=False)], [0.0, 1.0], "one-sided vs two"),
    (lambda: [local(0.0), _renamed(local(1.0))], [0.0, 1.0], "inputs/outputs"),
    (lambda: [local(0.0), local(1.0, keep_all=True)], [0.0, 1.0], "kept DOFs"),
    (lambda: [local(0.0), local(0.0)], [0.0, 1.0], "same FE model"),
])
def test_mismatched_bodies_and_samples_are_refused(make, samples, text):
    with pytest.raises(DataError, match=text):
        interpolate(make(), samples, parameter="p")


def test_bad_options_and_singular_transformations():
    s = [0.0, 1.0]
    bodies = [local(p) for p in s]
    for kw, text in (({"weights": [1.0, -1.0]}, "non-negative"),
                     ({"weights": [0.0, 0.0]}, "not all zero"),
                     ({"weights": [1.0]}, "need 2"),
                     ({"basis": "half"}, "basis"),
                     ({"interpolation": "spline"}, "interpolation")):
        with pytest.raises(DataError, match=text):
            interpolate(bodies, s, **kw)
    # a second sample whose basis is orthogonal to the first: with all SVD weight on the
    # first sample, T_2 = Rᵀ V_2 = 0 cannot be inverted
    V1 = bodies[0].V
    Q, _ = np.linalg.qr(np.hstack([V1, np.random.default_rng(1).normal(size=V1.shape)]))
    b2 = bodies[1].with_(V=Q[:, MODES:], W=Q[:, MODES:])
    with pytest.raises(SolverError, match=r"sample 2 .*T_i = Rᵀ S V_i is singular"):
        interpolate([bodies[0], b2], s, weights=[1.0, 0.0])
    with pytest.raises(DataError, match="strictly increasing"):
        interpolate(bodies, s).with_(samples=np.array([1.0, 0.0]))


# --------------------------------------------------------------------------- CLI
LOCAL = ("interpolate", "--method", "local")


def test_cli_interpolate(tmp_path, capsys):
    """`neweul interpolate --method local` writes what `interpolate` returns (bit for bit);
    sample values from --values or from the bodies' parameters; bad values are one-line
    errors."""
    s = grid(3)
    paths = []
    for i, p in enumerate(s):
        paths.append(str(tmp_path / f"b{i}.npz"))
        save_reduced_body(local(p).with_(parameters={"p": float(p)}), paths[-1])
    out = tmp_path / "pb.npz"
    assert main([*LOCAL, *paths, "--parameter", "p", "--values", "0,1,2", "-o",
                 str(out)]) == 0
    cap = capsys.readouterr()
    assert ("3 samples of p in [0, 2], order 8 (two-sided, local, full bases, row scaling kind"
            in cap.out)
    assert "reading" in cap.err and "common subspace" in cap.err
    ref = interpolate([load_reduced_body(p) for p in paths], s, parameter="p")
    _assert_same_core(load_parametric_body(out), ref)
    out2 = tmp_path / "pb2.npz"
    assert main([*LOCAL, *paths, "--parameter", "p", "--interpolation", "cubic",
                 "-o", str(out2)]) == 0
    assert load_parametric_body(out2).interpolation == "cubic"
    out3 = tmp_path / "pb3.npz"
    assert main([*LOCAL, *paths, "--parameter", "p", "--row-scaling", "none",
                 "-o", str(out3)]) == 0
    _assert_same_core(load_parametric_body(out3),
                      interpolate([load_reduced_body(p) for p in paths], s, parameter="p",
                                  row_scaling="none"))
    out4 = tmp_path / "pb4.npz"
    assert main([*LOCAL, *paths, "--parameter", "p", "--pressure-weight", "1",
                 "-o", str(out4)]) == 0
    assert load_parametric_body(out4).pressure_weight == 1.0
    capsys.readouterr()
    for values, text in (("0,1", "--values has 2 entries for 3 bodies"),
                         ("0,2,1", "strictly increasing"),
                         ("0,1.5,2", "records p = 1")):
        bad = tmp_path / "bad.npz"
        assert main([*LOCAL, *paths, "--parameter", "p", "--values", values, "-o",
                     str(bad)]) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert err[-1].startswith("neweul interpolate: error:") and text in err[-1]
        assert not bad.exists()


def _assert_same_core(a: ParametricBody, b: ParametricBody) -> None:
    for key in ("samples", "M", "D", "K", "B", "C", "T", "L", "R", "V_kept", "W_kept"):
        assert np.array_equal(a[key], b[key]), key
    assert a.row_scaling == b.row_scaling
    assert a.sample_sources == b.sample_sources


def _with_coordinate(pb: ParametricBody) -> ParametricBody:
    """``pbody`` weighted in ``ξ = σ² + σ`` (monotone, curved) on 41 knots."""
    knots = np.linspace(pb.samples[0], pb.samples[-1], 41)
    return pb.with_(interpolation="cubic", coordinate=np.vstack([knots, knots**2 + knots]),
                    coordinate_name="xi")


def test_interpolation_coordinate_weights_and_file(pbody, tmp_path):
    """A body weighted in a coordinate ``ξ(σ)`` (equations.md §4.1): its weights are those
    of :func:`neweul_py.ffrf.parametric.weight_polynomials` (the generated module's), within
    1e-6 of the composition ``S_i(ξ(σ))``, differ from the weights in σ, and survive the
    file (version 3, which an older reader refuses) bit for bit."""
    from scipy.interpolate import CubicSpline, PchipInterpolator

    pb = _with_coordinate(pbody)
    assert pb.format_version == 3
    knots, xi = pb.coordinate
    xi_of = PchipInterpolator(knots, xi)
    S = CubicSpline(xi_of(pb.samples), np.eye(pb.n_samples), bc_type="not-a-knot")
    for p in (0.13, 0.77, 1.6):
        w = pb.weights(p)
        np.testing.assert_allclose(w, S(xi_of(p)), atol=1e-6)
        assert np.abs(w - pbody.weights(p, "cubic")).max() > 1e-3
    assert pb.at(0.77).settings["coordinate"] == "xi"
    save_parametric_body(pb, tmp_path / "xi.npz")
    back = load_parametric_body(tmp_path / "xi.npz")
    assert back.coordinate_name == "xi" and np.array_equal(back.coordinate, pb.coordinate)
    assert np.array_equal(back.at(0.77).K, pb.at(0.77).K)
    data = explicit_arrays(tmp_path / "xi.npz")
    meta = json.loads(data["meta"].tobytes().decode())
    assert meta["version"] == 9 and meta["coordinate_name"] == "xi"
    np.savez(tmp_path / "old.npz", **{**data, "meta": json_to_uint8({**meta, "version": 2})})
    with pytest.raises(DataError, match="version-2 file holds no interpolation coordinate"):
        load_parametric_body(tmp_path / "old.npz")


def test_bad_interpolation_coordinates_are_refused(pbody):
    """A coordinate with linear weights, without a name, a name without a table, a table
    that misses a sample, and linear weights asked of a coordinate body: one DataError each,
    naming the field."""
    pb = _with_coordinate(pbody)
    knots, xi = pb.coordinate
    cases = [
        (dict(interpolation="linear", coordinate=pb.coordinate, coordinate_name="xi"),
         "cubic or Hermite weights", "coordinate"),
        (dict(interpolation="cubic", coordinate=pb.coordinate, coordinate_name=""),
         "needs a name", "coordinate_name"),
        (dict(interpolation="cubic", coordinate=None, coordinate_name="xi"),
         "without a coordinate table", "coordinate_name"),
    ]
    for kw, words, item in cases:
        with pytest.raises(DataError, match=words) as exc:
            pbody.with_(**kw)
        assert exc.value.item == item
    bad = np.vstack([np.delete(knots, 20), np.delete(xi, 20)])    # σ = 1 is a sample
    with pytest.raises(DataError, match="include every sample") as exc:
        pbody.with_(interpolation="cubic", coordinate=bad, coordinate_name="xi")
    assert exc.value.item == "coordinate"
    with pytest.raises(DataError, match="its weights are 'cubic'"):
        pb.weights(0.5, "linear")


def test_cli_interpolate_with_a_coordinate_curve(tmp_path, capsys):
    """`neweul interpolate --coordinate CURVE.csv:SIGMA:XI` writes the body with its cubic
    weights in XI (the table cut to the samples' range, equal to ``coordinate_table``); a
    curve without a sample, a missing column, a non-number, a bad spec and linear weights
    are one-line errors that write nothing."""
    s = grid(3)
    paths = []
    for i, p in enumerate(s):
        paths.append(str(tmp_path / f"b{i}.npz"))
        save_reduced_body(local(p).with_(parameters={"p": float(p)}), paths[-1])
    sig = np.linspace(-0.5, 2.5, 31)
    curve = tmp_path / "curve.csv"
    curve.write_text("p,xi\n" + "".join(f"{a:.17g},{a**3 + 2 * a:.17g}\n" for a in sig))
    out = tmp_path / "pb.npz"
    assert main([*LOCAL, *paths, "--parameter", "p", "--coordinate", f"{curve}:p:xi",
                 "-o", str(out)]) == 0
    assert "weights in xi" in capsys.readouterr().out
    pb = load_parametric_body(out)
    assert pb.interpolation == "cubic" and pb.coordinate_name == "xi"
    np.testing.assert_array_equal(pb.coordinate,
                                  coordinate_table(s, sig, sig**3 + 2 * sig, str(curve)))
    assert pb.coordinate[0, 0] == 0.0 and pb.coordinate[0, -1] == 2.0
    gap = tmp_path / "gap.csv"
    gap.write_text("p,xi\n0,0\n0.5,1\n2,5\n")
    nan = tmp_path / "nan.csv"
    nan.write_text("p,xi\n0,0\n1,nan\n2,5\n")
    twice = tmp_path / "twice.csv"
    twice.write_text("p,xi,xi\n0,0,0\n1,1,1\n2,5,5\n")
    wide = tmp_path / "wide.csv"
    wide.write_text("p,xi\n0,0\n1,1,7\n2,5\n")
    crowd = tmp_path / "crowd.csv"
    crowd.write_text("p,xi\n0,0\n1,1e-300\n2,1\n")
    bom = tmp_path / "bom.csv"                       # a spreadsheet's: BOM, spaces
    bom.write_bytes(b"\xef\xbb\xbfp, xi\n" + "".join(
        f"{a:.17g}, {a**3 + 2 * a:.17g}\n" for a in sig).encode())
    assert main([*LOCAL, *paths, "--parameter", "p", "--coordinate", f"{bom}:p:xi",
                 "-o", str(tmp_path / "bom.npz")]) == 0
    capsys.readouterr()
    for spec, extra, text in ((f"{gap}:p:xi", [], "sample 1 is not on the curve"),
                              (f"{twice}:p:xi", [], "names xi more than once"),
                              (f"{wide}:p:xi", [], "line 3: more fields"),
                              (f"{crowd}:p:xi", [], "crowd the samples"),
                              (f"{curve}:p:volume", [], "no column 'volume'"),
                              (f"{nan}:p:xi", [], "line 3: xi = 'nan' is not a finite"),
                              (f"{curve}:p", [], "must be CURVE.csv:SIGMA:XI"),
                              (f"{curve}:p:xi", ["--interpolation", "linear"],
                               "needs cubic weights")):
        bad = tmp_path / "bad.npz"
        assert main([*LOCAL, *paths, "--parameter", "p", "--coordinate", spec, *extra,
                     "-o", str(bad)]) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert err[-1].startswith("neweul interpolate: error:") and text in err[-1], err[-1]
        assert not bad.exists()


def test_coordinate_table_snaps_the_nearest_knot_and_drops_near_duplicates():
    """A curve with knots 1e-12 below and at a sample, or a sample 1e-7 off a grid point:
    the nearest knot becomes the sample and its near-duplicates go (not a "not increasing"
    error); a non-string coordinate name and a version-3 file without a coordinate are
    handled."""
    sig = np.array([-1.0, -1e-12, 0.0, 1.0, 2.0])
    t = coordinate_table([0.0, 1.0, 2.0], sig, sig**3 + 3 * sig)
    np.testing.assert_array_equal(t[0], [0.0, 1.0, 2.0])
    grid = np.linspace(-4000.0, 4000.0, 81)
    t = coordinate_table([-4000.0, 100.0000001, 4000.0], grid, grid)
    assert 100.0000001 in t[0] and 100.0 not in t[0] and t.shape == (2, 81)


def test_coordinate_name_must_be_text_and_version_3_means_a_coordinate(pbody):
    pb = _with_coordinate(pbody)
    with pytest.raises(DataError, match="must be a string") as exc:
        pb.with_(coordinate_name=42)
    assert exc.value.item == "coordinate_name"
    assert pb.with_(coordinate=None, coordinate_name="").format_version == 2


def _fd_slopes(pb: ParametricBody) -> dict:
    """Sample slopes of every stack (``numpy.gradient``; residual slopes zero)."""
    return {key: np.gradient(pb.stack(key), pb.samples, axis=0, edge_order=1)
            * (0.0 if key.endswith("residual") else 1.0) for key in pb.slope_keys()}


def test_sample_slopes_weights_and_file(pbody, tmp_path):
    """A body with sample slopes (Hermite weights, equations.md §4.2): ``2k`` weights that
    reproduce a cubic in the parameter from its values and slopes exactly (reference: the
    cubic itself), the sample bit for bit at a sample, ``at`` equal to ``Σ w_i X_i +
    Σ v_i X_i′`` computed here, and the file (version 4, which an older reader refuses)
    bit for bit."""
    hb = pbody.with_(interpolation="hermite", slopes=_fd_slopes(pbody))
    assert hb.format_version == 4
    s = hb.samples
    f, df = (lambda x: 2 * x**3 - x + 0.5), (lambda x: 6 * x**2 - 1)
    for p in (0.13, 0.77, 1.6 * s[-1] / 2):
        w = hb.weights(p)
        assert w.size == 2 * s.size and abs(w[:s.size].sum() - 1) < 1e-14
        assert abs(w @ np.r_[f(s), df(s)] - f(p)) < 1e-12
        k = s.size
        ref = np.einsum("i,i...->...", w[:k], hb.K) + np.einsum("i,i...->...", w[k:],
                                                                 hb.slopes["K"])
        np.testing.assert_allclose(hb.at(p).K, ref, rtol=1e-13, atol=0)
    assert np.array_equal(hb.at(s[1]).K, pbody.K[1])
    assert np.array_equal(hb.at(s[1], "cubic").K, pbody.K[1])
    save_parametric_body(hb, tmp_path / "h.npz")
    back = load_parametric_body(tmp_path / "h.npz")
    assert back.interpolation == "hermite" and sorted(back.slopes) == sorted(hb.slopes)
    assert np.array_equal(back.at(0.77).K, hb.at(0.77).K)
    assert np.array_equal(back.at(0.77).invariants["Me.m0"], hb.at(0.77).invariants["Me.m0"])
    data = explicit_arrays(tmp_path / "h.npz")
    meta = json.loads(data["meta"].tobytes().decode())
    assert meta["version"] == 9
    np.savez(tmp_path / "old.npz", **{**data, "meta": json_to_uint8({**meta, "version": 3})})
    with pytest.raises(DataError, match="version-3 file holds no sample slopes"):
        load_parametric_body(tmp_path / "old.npz")


def _fd_curvatures(pb: ParametricBody) -> dict:
    """Sample curvatures of every stack (``numpy.gradient`` twice; residual ones zero)."""
    return {key: np.gradient(np.gradient(pb.stack(key), pb.samples, axis=0, edge_order=1),
                             pb.samples, axis=0, edge_order=1)
            * (0.0 if key.endswith("residual") else 1.0) for key in pb.slope_keys()}


def test_sample_curvatures_weights_and_file(pbody, tmp_path):
    """A body with sample slopes and curvatures (quintic Hermite weights, equations.md
    §4.2): ``3k`` weights that reproduce a quintic in the parameter from its values, slopes
    and second derivatives exactly (reference: the quintic itself), ``at`` equal to
    ``Σ w_i X_i + Σ v_i X_i′ + Σ u_i X_i″`` computed here, the sample bit for bit at a
    sample, and the file (version 5, which a version-4 reader refuses) bit for bit; the
    cubic Hermite weights of the same body ignore the curvatures."""
    qb = pbody.with_(interpolation="quintic-hermite", slopes=_fd_slopes(pbody),
                     curvatures=_fd_curvatures(pbody))
    assert qb.format_version == 5
    s, k = qb.samples, qb.n_samples
    f = np.polynomial.Polynomial([0.5, -1.0, 0.0, 2.0, 0.3, -0.1])
    for p in (0.13, 0.77, 1.6 * s[-1] / 2):
        w = qb.weights(p)
        assert w.size == 3 * k and abs(w[:k].sum() - 1) < 1e-14
        assert abs(w @ np.r_[f(s), f.deriv(1)(s), f.deriv(2)(s)] - f(p)) < 1e-12
        ref = (np.einsum("i,i...->...", w[:k], qb.K)
               + np.einsum("i,i...->...", w[k:2 * k], qb.slopes["K"])
               + np.einsum("i,i...->...", w[2 * k:], qb.curvatures["K"]))
        np.testing.assert_allclose(qb.at(p).K, ref, rtol=1e-13, atol=0)
        assert qb.weights(p, "hermite").size == 2 * k
    assert np.array_equal(qb.at(s[1]).K, pbody.K[1])
    qb = qb.with_(slope_step=0.01, slope_sources=tuple(
        {"file": f"m{i}.npz", "fingerprint": f"{i:064x}"} for i in range(2 * k)))
    save_parametric_body(qb, tmp_path / "q.npz")
    back = load_parametric_body(tmp_path / "q.npz")
    assert back.interpolation == "quintic-hermite"
    assert back.slope_step == 0.01 and back.slope_sources == qb.slope_sources
    assert sorted(back.curvatures) == sorted(qb.curvatures)
    assert np.array_equal(back.at(0.77).K, qb.at(0.77).K)
    assert np.array_equal(back.at(0.77).invariants["Me.m0"], qb.at(0.77).invariants["Me.m0"])
    data = explicit_arrays(tmp_path / "q.npz")
    meta = json.loads(data["meta"].tobytes().decode())
    assert meta["version"] == 9
    np.savez(tmp_path / "old.npz", **{**data, "meta": json_to_uint8({**meta, "version": 4})})
    with pytest.raises(DataError, match="version-4 file holds no sample curvatures"):
        load_parametric_body(tmp_path / "old.npz")


def test_bad_sample_curvatures_are_refused(pbody):
    """Quintic Hermite weights without curvatures, curvatures without slopes or with cubic
    Hermite weights, a curvature lacking a stack or holding NaN: one DataError each naming
    the field as the file names it (``curvature/K``, ``interpolation``)."""
    slopes, curv = _fd_slopes(pbody), _fd_curvatures(pbody)
    cases = [(dict(interpolation="quintic-hermite", slopes=slopes), "with sample slopes",
              "interpolation"),
             (dict(interpolation="quintic-hermite", curvatures=curv), "without sample slopes",
              "interpolation"),
             (dict(interpolation="hermite", slopes=slopes, curvatures=curv),
              "'hermite' with sample slopes and curvatures", "interpolation"),
             (dict(interpolation="quintic-hermite", slopes=slopes,
                   curvatures={k: v for k, v in curv.items() if k != "K"}),
              r"missing \['curvature/K'\]", "curvature/K"),
             (dict(interpolation="quintic-hermite", slopes=slopes,
                   curvatures=dict(curv, K=np.full_like(curv["K"], np.nan))),
              "not a finite number", "curvature/K")]
    for kw, words, item in cases:
        with pytest.raises(DataError, match=words) as exc:
            pbody.with_(**kw)
        assert exc.value.item == item
    hb = pbody.with_(interpolation="hermite", slopes=slopes)
    with pytest.raises(DataError, match="holds no sample curvatures"):
        hb.weights(0.5, "quintic-hermite")
    for kw, item in ((dict(slope_step=20.0), "slope_step"),
                     (dict(slope_sources=({"file": "a"},) * 2 * pbody.n_samples),
                      "slope_sources")):
        with pytest.raises(DataError, match="without sample slopes") as exc:
            pbody.with_(**kw)                    # provenance of slopes the body lacks
        assert exc.value.item == item
    with pytest.raises(DataError, match="must be 6 mappings") as exc:
        hb.with_(slope_sources=({"file": "a"},))
    with pytest.raises(DataError, match="positive number"):
        hb.with_(slope_step=-1.0)


def test_bad_sample_slopes_are_refused(pbody, tmp_path):
    """Hermite weights without slopes, slopes lacking a stack or with an unknown one, of the
    wrong shape, or with NaN: one DataError each, naming the field as the file names it
    (``slope/K``, docs/reduced-body-format.md), in memory and read from a file."""
    good = _fd_slopes(pbody)
    nan = dict(good, K=np.full_like(good["K"], np.nan))
    cases = [(dict(interpolation="hermite"), "'hermite' with no sample slopes",
              "interpolation"),
             (dict(slopes={k: v for k, v in good.items() if k != "K"}),
              r"missing \['slope/K'\]", "slope/K"),
             (dict(slopes={**good, "X": good["K"]}), r"unknown \['slope/X'\]", "slope/X"),
             (dict(slopes=dict(good, K=good["K"][:2])), "must be real of shape", "slope/K"),
             (dict(slopes=nan), "not a finite number", "slope/K")]
    for kw, words, item in cases:
        with pytest.raises(DataError, match=words) as exc:
            pbody.with_(**{"interpolation": "hermite", **kw})
        assert exc.value.item == item
    path = tmp_path / "h.npz"
    save_parametric_body(pbody.with_(interpolation="hermite", slopes=good), path)
    data = explicit_arrays(path)
    np.savez(path, **{**data, "slope/K": data["slope/K"][:2]})
    with pytest.raises(DataError, match="must be real of shape") as exc:
        load_parametric_body(path)
    assert exc.value.item == "slope/K" and exc.value.file == str(path)
    with pytest.raises(DataError, match="no sample slopes: hermite weights need them"):
        pbody.weights(0.5, "hermite")


def _lossy(pb: ParametricBody, f_ref: np.ndarray) -> ParametricBody:
    """``pb`` with a hysteretic invariant ``Le.m0`` and the reference frequencies ``f_ref``
    of its samples (``loss.f_ref``)."""
    return pb.with_(invariants={**pb.invariants, "Le.m0": 0.01 * pb.K, "loss.f_ref": f_ref})


def test_loss_reference_frequency_is_carried_not_mixed(pbody):
    """``loss.f_ref`` is one value for all samples: ``at(p)`` returns it exactly (reference:
    the samples' 1000.0), where the cubic weights, which sum to one only to round-off, give
    1000.0000000000001 at some of these p (so mixing it would fail here)."""
    lb = _lossy(pbody, np.full(pbody.n_samples, 1000.0))
    ps = np.linspace(*pbody.range, 201)
    assert any(lb.weights(p) @ lb.invariants["loss.f_ref"] != 1000.0 for p in ps)
    assert all(float(lb.at(p).invariants["loss.f_ref"]) == 1000.0 for p in ps)
    hb = lb.with_(interpolation="hermite", slopes=_fd_slopes(lb))
    assert float(hb.at(0.77).invariants["loss.f_ref"]) == 1000.0


def test_samples_with_different_loss_reference_frequencies_name_the_sample(pbody):
    """A stack of ``loss.f_ref`` that is not one value, or a nonzero slope of it: one
    DataError naming the sample (and both values) or the slope (reference: the samples
    given, 1000 and 1000.0000000000001 Hz in sample 3)."""
    f = np.full(pbody.n_samples, 1000.0)
    f[2] = np.nextafter(1000.0, 2000.0)
    with pytest.raises(DataError, match=r"sample 3 differs from sample 1 \(1000\.0000000000001"
                       r" vs 1000\.0\)") as exc:
        _lossy(pbody, f)
    assert exc.value.item == "invariants.loss.f_ref"
    lb = _lossy(pbody, np.full(pbody.n_samples, 1000.0))
    slopes = _fd_slopes(lb)
    slopes["invariants/loss.f_ref"] = np.ones(pbody.n_samples)
    with pytest.raises(DataError, match="slope of a value common to all samples is zero") as exc:
        lb.with_(interpolation="hermite", slopes=slopes)
    assert exc.value.item == "slope/invariants/loss.f_ref"


def test_slopes_and_hermite_weights_come_together_in_a_file(pbody, tmp_path):
    """docs/reduced-body-format.md: ``slope/*`` is present exactly with ``interpolation =
    "hermite"``. A version-4 file whose slopes come with cubic weights (read before, its
    slopes ignored), a Hermite file without its slopes, and such a body in memory: one
    DataError naming the file and ``interpolation`` (reference: the rule of the format, the
    one ``generate`` applies, "Hermite weights and sample slopes come together")."""
    hb = pbody.with_(interpolation="hermite", slopes=_fd_slopes(pbody))
    save_parametric_body(hb, tmp_path / "h.npz")
    data = explicit_arrays(tmp_path / "h.npz")
    meta = json.loads(data["meta"].tobytes().decode())
    np.savez(tmp_path / "cubic.npz", **{**data, "meta": json_to_uint8(
        {**meta, "interpolation": "cubic"})})
    np.savez(tmp_path / "bare.npz", **{k: v for k, v in data.items()
                                       if not k.startswith("slope/")})
    for name, words in (("cubic.npz", "interpolation 'cubic' with sample slopes (slope/*)"),
                        ("bare.npz", "interpolation 'hermite' with no sample slopes")):
        with pytest.raises(DataError, match=re.escape(words)) as exc:
            load_parametric_body(tmp_path / name)
        assert exc.value.file == str(tmp_path / name) and exc.value.item == "interpolation"
        assert "Hermite weights and their data come together" in str(exc.value)
    with pytest.raises(DataError, match="come together") as exc:
        pbody.with_(slopes=_fd_slopes(pbody))
    assert exc.value.item == "interpolation"
