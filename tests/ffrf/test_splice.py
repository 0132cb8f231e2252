"""The splice of elastic bodies into a generated module's ``rhs`` (neweul_py/ffrf/splice.py).

Reference: equations.md §2 evaluated directly from the body's flat invariants, one key at a
time (``md = md⁰ + md¹ q``, ``J = J⁰ + J¹ q + Σ q_k q_l C2[k, l]``, ``Gr_k(q) = Gr⁰_k +
2 Σ_l q_l C2[l, k]``, ``Ct``, ``Cr``, ``Crv``, ``Oe`` affine in ``q``, ``h_ω`` of the body
module docstring), assembled as ``M = S_Wᵀ M_s S_V + Σ Bᵀ M_b B`` with ``B = [J_s S_V; E]``
and solved densely — none of the kernel's stacked forms (``T1``, ``P``, ``G``) nor its block
elimination. The Jacobian is compared with central differences of that reference.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from beam_fe import DOUBLE_PENDULUM, beam

from neweul_py.analysis import load_generated
from neweul_py.api import generate
from neweul_py.elastic.reductors.invariants import compute_invariants, stress_stiffening

BEAM = ("elastic_bodies:\n  beam: {{frame: link2, data: beam.npz, nodes: {{tip: {tip}}}, "
        "inertia: {inertia}}}")


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _affine(F: dict, key: str, q: np.ndarray) -> np.ndarray:
    """``X⁰ + Σ_l X¹[:, l, :] q_l`` (``X.m1`` absent: zero)."""
    out = np.array(F[key + ".m0"], dtype=float)
    if key + ".m1" in F:
        out = out + np.einsum("ilj,l->ij", F[key + ".m1"], q)
    return out


def _body(F: dict, q, qd, w, consistent: bool, stiff: bool):
    """``M_b(q)`` and ``h_ω`` of equations.md §2 from the flat invariants ``F``."""
    nq = q.size
    md = F["md.m0"][:, 0] + F["md.m1"][:, :, 0] @ q
    J = _affine(F, "J", q)
    Gr = [F["Gr.m0"][:, 3 * k:3 * k + 3] for k in range(nq)]
    if consistent:
        C2 = F["J.m2"]
        J = J + np.einsum("k,l,klab->ab", q, q, C2)
        Gr = [Gr[k] + 2.0 * np.einsum("l,lab->ab", q, C2[:, k]) for k in range(nq)]
    Ct, Cr, Crv, Oe = (_affine(F, k, q) for k in ("Ct", "Cr", "Crv", "Oe"))
    Mrr = np.zeros((6, 6))
    Mrr[:3, :3] = F["m"] * np.eye(3)
    Mrr[3:, :3] = _skew(md)
    Mrr[:3, 3:] = _skew(md).T
    Mrr[3:, 3:] = J
    if stiff:
        Mrr[3:, :3] += 0.5 * _skew(q @ (Ct - F["Ct.m0"]))
    Mb = np.block([[Mrr, np.vstack((F["md.m1"][:, :, 0], Crv.T))],
                   [np.hstack((Ct, Cr)), F["Me.m0"]]])
    wt = _skew(w)
    wq = np.array([w[0] ** 2, w[1] ** 2, w[2] ** 2, w[0] * w[1], w[1] * w[2], w[0] * w[2]])
    h = np.concatenate((wt @ wt @ md + 2.0 * wt @ (F["md.m1"][:, :, 0] @ qd),
                        wt @ J @ w + sum(Gr[k] @ w * qd[k] for k in range(nq)),
                        Oe @ wq + sum(F["Ge.m0"][:, 3 * k:3 * k + 3] @ w * qd[k]
                                      for k in range(nq))))
    return Mb, h


def _reference_rhs(mod, F: dict, x: np.ndarray, consistent: bool, stiff: bool) -> np.ndarray:
    """``[ẏ, M⁻¹ (q − k)]`` assembled directly (module docstring)."""
    S = mod.module._FFRF
    n, ns = S["n"], S["ns"]
    y, yd = x[:n], x[n:]
    SV, SW = S["SV"], S["SW"]
    p = mod.default_parameters()
    rig = S["rigid"]
    kin = rig["outputs"](0.0, np.concatenate((SV @ y, SV @ yd)), p)[S["nhidden"]:]
    M = SW.T @ rig["mass_matrix"](0.0, SV @ y, p) @ SV
    f = SW.T @ rig["force_vector"](0.0, SV @ y, SV @ yd, p)
    (b,) = S["bodies"]
    o, e = b["kin"], slice(b["first"], b["first"] + b["nq"])
    Js = kin[o:o + 6 * ns].reshape(6, ns)
    abar, alphabar, w, g = (kin[o + 6 * ns + 3 * i:o + 6 * ns + 3 * i + 3] for i in range(4))
    B = np.vstack((Js @ SV, np.eye(n)[e]))
    Mb, h = _body(F, y[e], yd[e], w, consistent, stiff)
    elastic = F["Ke.m0"] @ y[e] + F["De.m0"] @ yd[e] + F["ksigma.m0"][:, 0]
    load = Mb[:, :6] @ np.concatenate((abar - g, alphabar)) + h
    load[6:] += elastic
    M = M + B.T @ Mb @ B
    f = f - B.T @ load
    return np.concatenate((yd, np.linalg.solve(M, f)))


@pytest.fixture(scope="module")
def beam_data():
    b = beam(12, length=1.0, E=2.0e5)
    _lam, V = b.clamped_modes(30)
    kg = stress_stiffening(b.fe, lambda u: b.geometric_stiffness(b.axial_forces(u)),
                           support=np.arange(6))     # all cases: Ct¹ and Oe¹
    return b, V, kg


@pytest.mark.parametrize(("nq", "inertia"), [(6, "consistent"), (30, "consistent"),
                                             (30, "sid")])
def test_rhs_and_jacobian_equal_the_direct_assembly(tmp_path: Path, beam_data, nq: int,
                                                    inertia: str) -> None:
    """The module's ``rhs`` equals the direct assembly to round-off (dense solve for 6
    modes, the block elimination of the constant elastic block for 30), and its
    ``rhs_jacobian`` equals central differences of that reference (step 1e-6)."""
    b, V, kg = beam_data
    tip = int(b.fe.nodes[-1, 0])
    inv = compute_invariants(b.fe, V[:, :nq], nodes=[tip], geometric_stiffness=kg)
    F = inv.to_flat()
    np.savez(tmp_path / "beam.npz", **F)
    (tmp_path / "flex.yaml").write_text(DOUBLE_PENDULUM.format(
        name="flex", extra=BEAM.format(tip=tip, inertia=inertia), tip="beam.tip"))
    mod = load_generated(generate(tmp_path / "flex.yaml", tmp_path / "gen"))
    S = mod.module._FFRF
    assert (S["block"] is not None) == (nq >= 24)
    (body,) = S["bodies"]
    consistent, stiff = inertia == "consistent", body["consistent_stiffening"]
    assert stiff == consistent
    rng = np.random.default_rng(nq)
    p = mod.default_parameters()
    n = S["n"]
    for _ in range(3):
        x = np.concatenate((rng.normal(0, 0.4, 2), rng.normal(0, 0.02, n - 2),
                            rng.normal(0, 1.0, 2), rng.normal(0, 0.5, n - 2)))
        ref = _reference_rhs(mod, F, x, consistent, stiff)
        np.testing.assert_allclose(mod.rhs(0.0, x, p), ref, rtol=0,
                                   atol=1e-11 * np.max(np.abs(ref)))
        h = 1e-6
        fd = np.column_stack([(_reference_rhs(mod, F, x + h * d, consistent, stiff)
                               - _reference_rhs(mod, F, x - h * d, consistent, stiff)) / (2 * h)
                              for d in np.eye(2 * n)])
        np.testing.assert_allclose(mod.rhs_jacobian(0.0, x, p), fd, rtol=0,
                                   atol=1e-6 * np.max(np.abs(fd)))


def test_dense_solve_through_lapack_equals_numpy_and_falls_back() -> None:
    """Reference: ``numpy.linalg.solve`` (LAPACK gesv) — ``ffrf_dense_solve`` gives its
    solution through SciPy's ``dgesv`` for real systems (one and several right-hand sides),
    the same with ``gesv = None`` (NumPy only) and for complex right-hand sides, and raises
    its ``LinAlgError`` for a singular matrix."""
    from scipy.linalg.lapack import dgesv

    from neweul_py.ffrf.splice import ffrf_dense_solve

    rng = np.random.default_rng(5)
    M = rng.standard_normal((22, 22)) + 22 * np.eye(22)
    for f in (rng.standard_normal(22), rng.standard_normal((22, 3))):
        ref = np.linalg.solve(M, f)
        for gesv in (dgesv, None):
            np.testing.assert_allclose(ffrf_dense_solve({"gesv": gesv}, M, f), ref,
                                       rtol=1e-13, atol=1e-14)
    fc = rng.standard_normal(22) + 1j * rng.standard_normal(22)
    np.testing.assert_allclose(ffrf_dense_solve({"gesv": dgesv}, M, fc),
                               np.linalg.solve(M, fc), rtol=1e-13, atol=1e-14)
    with pytest.raises(np.linalg.LinAlgError):
        ffrf_dense_solve({"gesv": dgesv}, np.zeros((3, 3)), np.ones(3))


def test_parameter_derivatives_equal_central_differences(tmp_path: Path, beam_data) -> None:
    """``∂(q−k)/∂p``, ``∂(M a)/∂p`` and ``∂rhs/∂p`` of a module with an elastic body whose
    frame kinematics depend on parameters (``l`` moves its frame, ``g`` is in ``kin``)
    equal central differences of the module's own ``force_vector``, ``mass_matrix`` and
    ``rhs`` (step 1e-5 of each parameter; docs/sensitivity.md)."""
    b, V, kg = beam_data
    tip = int(b.fe.nodes[-1, 0])
    inv = compute_invariants(b.fe, V[:, :6], nodes=[tip], geometric_stiffness=kg)
    np.savez(tmp_path / "beam.npz", **inv.to_flat())
    (tmp_path / "flex.yaml").write_text(DOUBLE_PENDULUM.format(
        name="flex", extra=BEAM.format(tip=tip, inertia="consistent"), tip="beam.tip"))
    mod = load_generated(generate(tmp_path / "flex.yaml", tmp_path / "gen"))
    rng = np.random.default_rng(11)
    n = len(mod.COORDINATES)
    p = mod.default_parameters()
    x = np.concatenate((rng.normal(0, 0.4, 2), rng.normal(0, 0.02, n - 2),
                        rng.normal(0, 1.0, 2), rng.normal(0, 0.5, n - 2)))
    y, yd, a = x[:n], x[n:], rng.normal(size=n)

    def fd(f):
        cols = []
        for j in range(p.size):
            e = np.zeros_like(p)
            e[j] = 1e-5 * p[j]
            cols.append((f(p + e) - f(p - e)) / (2 * e[j]))
        return np.column_stack(cols)

    for got, ref in ((mod.force_parameter_jacobian(0.0, y, yd, p),
                      fd(lambda q: mod.force_vector(0.0, y, yd, q))),
                     (mod.mass_matrix_parameter_derivative(0.0, y, p, a),
                      fd(lambda q: mod.mass_matrix(0.0, y, q) @ a)),
                     (mod.rhs_parameter_jacobian(0.0, x, p), fd(lambda q: mod.rhs(0.0, x, q)))):
        assert np.any(got[:, list(mod.PARAMETERS).index("l")])   # through kin
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-7 * np.max(np.abs(ref)))
