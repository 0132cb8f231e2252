"""The static state a reduced or parametric body carries (``static/*``, docs/equations-
middle-ear.md §5): what it holds, its file round trip, its mixing, and the static problem of
the body tied to a rigid part.

References: the closed-form static state of the piston-duct model (spring-loaded piston,
``u_s = F/k``, pressures 0), every array back bit for bit after a file round trip, and the
scalar static equilibrium of piston + tie spring + nonlinear restoring force solved by
``scipy.optimize.brentq`` (an independent root finder on the closed-form equations).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from body_arrays import explicit_arrays
from fe_builders import piston_duct
from scipy.optimize import brentq

from neweul_py.elastic import ReducedBody
from neweul_py.elastic.bodies.parametric import ParametricBody
from neweul_py.elastic.bodies.static import StaticDeflection
from neweul_py.elastic.io.body_files import (
    load_parametric_body,
    load_reduced_body,
    save_parametric_body,
    save_reduced_body,
)
from neweul_py.elastic.parametric.local_interpolation import interpolate
from neweul_py.elastic.quality.static_equilibrium import rigid_map, tied_static_equilibrium
from neweul_py.elastic.reductors.projection import build_reduced_body
from neweul_py.elastic.reductors.static_state import metric_gram, static_deflection
from neweul_py.errors import DataError

F_STATIC = 3.0          # N, the static load on the piston


def galerkin(fe) -> ReducedBody:
    """The piston duct on the basis [piston; the first five rigid-wall duct modes cos(jπx)]
    (Galerkin), which spans every static state ``[u; p = 0]``."""
    V = np.zeros((fe.n_dofs, 6))
    V[0, 0] = 1.0
    x = fe.nodes[:, 1]
    for j in range(5):
        V[1:, j + 1] = np.cos(j * np.pi * x)
    return build_reduced_body(fe, V, V, "galerkin", {"two_sided": False}, store_bases=True)


def piston_body(k: float = 2.0e5, force: float = F_STATIC) -> ReducedBody:
    """The piston duct (:func:`galerkin`) carrying the static state of the piston under
    ``force`` (the duct's static pressure is the reference: p = 0)."""
    fe = piston_duct(40, stiffness=k, damping=2.0)
    body = galerkin(fe)
    x = np.zeros(fe.n_dofs)
    x[0] = force / k
    st = static_deflection(body, x, output_rows=fe.C(), node_force={1: [force, 0.0, 0.0]})
    return body.with_(static=st)


def test_static_state_holds_the_closed_form_piston_deflection():
    """``u_s = F/k`` at the piston node, its output ``x_piston`` and ``V q_s = x_s`` (the basis
    spans it)."""
    k = 2.0e5
    b = piston_body(k)
    st = b.static
    assert st.node_u[0, 0] == F_STATIC / k and np.all(st.node_u[0, 1:] == 0)
    assert st.outputs[list(b.output_names).index("x_piston")] == pytest.approx(F_STATIC / k,
                                                                              rel=1e-14)
    assert st.residual < 1e-10
    assert (b.V @ st.q)[0] == pytest.approx(F_STATIC / k, rel=1e-10)
    assert np.array_equal(st.node_force[0], [F_STATIC, 0.0, 0.0])


def test_metric_projection_is_the_weighted_least_squares_state():
    """With an energy metric Ḡ, ``q`` minimizes ‖x − Vq‖_Ḡ (reference: least squares on
    ``LᵀV``, ``LᵀX`` with the Cholesky factor ``Ḡ = L Lᵀ``), and the Gram matrices given
    once (:func:`metric_gram`, for many states on one basis) change no bit."""
    import scipy.sparse as sps

    fe = piston_duct(40, stiffness=2.0e5, damping=2.0)
    body = galerkin(fe)
    rng = np.random.default_rng(3)
    x = rng.standard_normal(fe.n_dofs)
    n = fe.n_dofs
    G = sps.csr_matrix(sps.diags(rng.uniform(1.0, 3.0, n))
                       + 0.4 * sps.diags([np.ones(n - 1), np.ones(n - 1)], [-1, 1]))
    L = np.linalg.cholesky(G.toarray())
    ref = np.linalg.lstsq(L.T @ body.V, L.T @ x, rcond=None)[0]
    st = static_deflection(body, x, metric=G)
    np.testing.assert_allclose(st.q, ref, rtol=1e-8, atol=1e-12 * np.abs(ref).max())
    once = static_deflection(body, x, metric=G, gram=metric_gram(G, body.V))
    assert np.array_equal(once.q, st.q) and once.residual == st.residual


def test_reduced_body_file_round_trip_is_bit_for_bit(tmp_path):
    """Every ``static/*`` array comes back identical (values and dtype)."""
    b = piston_body()
    save_reduced_body(b, tmp_path / "b.npz")
    back = load_reduced_body(tmp_path / "b.npz").static
    for key in ("q", "node_u", "node_force", "outputs", "residual"):
        assert back[key].dtype == b.static[key].dtype
        assert np.array_equal(back[key], b.static[key]), key


def test_parametric_body_mixes_the_static_state_with_its_weights(tmp_path):
    """Interpolated bodies: at a sample the sample's static state bit for bit (and its
    ``q̃ = T q`` maps back to ``x_s`` through the stored bases); between samples ``Σ w_i X_i``
    with the body's own weights; file round trip exact."""
    ks = [1.5e5, 2.0e5, 2.5e5]
    bodies = [piston_body(k) for k in ks]
    pb = interpolate(bodies, [0.0, 1.0, 2.0], parameter="p", store_bases=True,
                     row_scaling="none")
    assert pb.static is not None and pb.static.q.shape == (3, pb.order)
    for i, k in enumerate(ks):
        at = pb.at(float(i))
        assert np.array_equal(at.static.node_u, bodies[i].static.node_u)
        assert (at.V @ at.static.q)[0] == pytest.approx(F_STATIC / k, rel=1e-8)
    w = pb.weights(0.4)
    mid = pb.at(0.4).static
    want = sum(wi * b.static.node_u for wi, b in zip(w, bodies, strict=True))
    np.testing.assert_allclose(mid.node_u, want, rtol=1e-15)
    save_parametric_body(pb, tmp_path / "pb.npz")
    back = load_parametric_body(tmp_path / "pb.npz").static
    for key in ("q", "node_u", "node_force", "outputs", "residual"):
        assert np.array_equal(back[key], pb.static[key]), key


def test_samples_with_and_without_a_static_state_are_one_error():
    """Mixed samples would give a body whose static state is undefined in between."""
    a, b = piston_body(1.5e5), piston_body(2.5e5)
    with pytest.raises(DataError, match="some samples carry a static state"):
        interpolate([a, b.with_(static=None)], [0.0, 1.0], parameter="p", row_scaling="none")


def test_bad_static_groups_are_one_error_naming_the_array(tmp_path):
    """Wrong shapes, NaN, a force at a node the body does not keep, an incomplete group in a
    file: one DataError each, naming ``static.<key>`` (and the file)."""
    b = piston_body()
    st = b.static
    with pytest.raises(DataError, match=r"static\.q"):
        b.with_(static=StaticDeflection(st.q[:-1], st.node_u, st.node_force, st.outputs,
                                        st.residual))
    with pytest.raises(DataError, match=r"static\.node_u"):
        StaticDeflection(st.q, st.node_u * np.nan, st.node_force, st.outputs, st.residual)
    with pytest.raises(DataError, match="not one of the body's kept nodes"):
        static_deflection(b, np.zeros(b.V.shape[0]), node_force={999: [1.0, 0, 0]})
    with pytest.raises(DataError, match="static"):
        b.with_(static={"q": st.q})
    save_reduced_body(b, tmp_path / "b.npz")
    arrays = explicit_arrays(tmp_path / "b.npz")
    del arrays["static/residual"]
    np.savez(tmp_path / "cut.npz", **arrays)
    with pytest.raises(DataError, match="static/residual") as err:
        load_reduced_body(tmp_path / "cut.npz")
    assert "cut.npz" in str(err.value)


def test_rigid_map_is_translation_plus_small_rotation():
    """``u = t + θ × r`` against ``numpy.cross``."""
    nodes = np.array([[1, 0.0, 0.0, 0.0], [7, 1.0, 2.0, -0.5]])
    T = rigid_map(nodes, np.array([7, 1]), np.array([0.1, 0.0, 0.3]))
    t, th = np.array([1e-3, -2e-3, 5e-4]), np.array([0.01, -0.02, 0.03])
    u = T @ np.r_[t, th]
    for j, x in enumerate((nodes[1, 1:], nodes[0, 1:])):
        np.testing.assert_allclose(u[3 * j:3 * j + 3], t + np.cross(th, x - [0.1, 0.0, 0.3]),
                                   rtol=1e-14)


@pytest.mark.parametrize("change", [1.0, 3.0])
def test_tied_static_problem_against_the_scalar_equilibrium(change):
    """Piston (stiffness k, static load P) tied by a spring k_t to a rigid part with the
    restoring force ``F_c(y) = a y + c y³``. The body carries the static state of the
    restoring force with ``c`` (``u_s``, ``f_s = −k_t (u_s − y_s)``); solved with ``change·c``
    the reduced static problem must give the closed-form equilibrium of that chain,
    ``k u = P − k_t (u − y)``, ``k_t (u − y) = F_c(y)`` (brentq)."""
    k, kt, a, c, P = 2.0e5, 5.0e4, 1.0e4, 4.0e15, 30.0

    def equilibrium(cc):
        def g(y):
            u = (P + kt * y) / (k + kt)
            return kt * (u - y) - (a * y + cc * y**3)
        y = brentq(g, 0.0, P / a)
        return (P + kt * y) / (k + kt), y

    u_s, y_s = equilibrium(c)
    fe = piston_duct(40, stiffness=k, damping=2.0)
    body = galerkin(fe)
    x = np.zeros(fe.n_dofs)
    x[0] = u_s
    body = body.with_(static=static_deflection(body, x, output_rows=fe.C(),
                                               node_force={1: [-kt * (u_s - y_s), 0, 0]}))
    cc = change * c

    def restoring(y):
        F, K = np.array(y) * 1e3, np.eye(6) * 1e3      # the other directions: held
        F[0], K[0, 0] = a * y[0] + cc * y[0] ** 3, a + 3 * cc * y[0] ** 2
        return F, K

    sol = tied_static_equilibrium(body, np.array([1]), kt, restoring, np.zeros(3))
    u, y = equilibrium(cc)
    assert sol["node_u"][0, 0] == pytest.approx(u, rel=1e-9)
    assert sol["y"][0] == pytest.approx(y, rel=1e-9)
    out = list(body.output_names).index("x_piston")
    assert sol["outputs"][out] == pytest.approx(u, rel=1e-9)
    if change == 1.0:
        assert np.abs(sol["q"]).max() < 1e-10 * np.abs(body.static.q).max()


def test_tied_static_problem_refuses_a_body_without_static_state():
    """No static state, or a tied node the body does not keep: one DataError."""
    b = piston_body()
    with pytest.raises(DataError, match="no static state"):
        tied_static_equilibrium(b.with_(static=None), np.array([1]), 1.0,
                                lambda y: (y, np.eye(6)), np.zeros(3))
    with pytest.raises(DataError, match="not kept nodes"):
        tied_static_equilibrium(b, np.array([5]), 1.0, lambda y: (y, np.eye(6)),
                                np.zeros(3))


def test_parametric_body_rejects_a_static_state_of_the_wrong_stack():
    """A single working point's state on a parametric body: one DataError."""
    bodies = [piston_body(k) for k in (1.5e5, 2.5e5)]
    pb = interpolate(bodies, [0.0, 1.0], parameter="p", row_scaling="none")
    with pytest.raises(DataError, match=r"static\.q"):
        ParametricBody(**{f.name: getattr(pb, f.name) for f in
                          pb.__dataclass_fields__.values() if f.name != "static"},
                       static=bodies[0].static)


def test_global_interpolation_carries_the_static_state():
    """``neweul interpolate --method global`` (global_parametric_body): every sample's static
    state in the global coordinates; at a sample ``V q = x_s`` (closed form ``u_s = F/k``, the
    global basis spans the local ones), node arrays and outputs unchanged."""
    from neweul_py.elastic.parametric.global_basis import global_parametric_body

    ks = [1.5e5, 2.0e5, 2.5e5]
    fes = [piston_duct(40, stiffness=k, damping=2.0) for k in ks]
    bodies = [piston_body(k) for k in ks]
    pb = global_parametric_body(fes, bodies, [0.0, 1.0, 2.0], parameter="p")
    for i, k in enumerate(ks):
        st = pb.at(float(i)).static
        assert (pb.R @ st.q)[0] == pytest.approx(F_STATIC / k, rel=1e-8)
        assert np.array_equal(st.node_u, bodies[i].static.node_u)
        assert np.array_equal(st.outputs, bodies[i].static.outputs)
        assert st.residual < 1e-8


def test_node_positions_of_the_nonlinear_state():
    """``X + u_s + Φ q`` at the node frames: the piston node at ``x = F/k`` in the static
    state, moved by the piston row of ``V`` for a motion ``q`` (reference: the closed form and
    the body's own basis rows)."""
    from neweul_py.elastic.bodies.static import node_positions

    k = 2.0e5
    b = piston_body(k)
    x0 = b.nodes[0, 1]
    assert node_positions(b)[0, 0] == x0 + F_STATIC / k
    q = np.linspace(0.1, 0.6, b.order) * 1e-6
    assert node_positions(b, q)[0, 0] == pytest.approx(x0 + F_STATIC / k + b.V[0] @ q,
                                                       rel=1e-14)
    assert node_positions(b.with_(static=None))[0, 0] == x0


def test_mixed_residual_is_the_bound_of_the_samples_mixed():
    """Cubic weights over three samples are negative between samples 2 and 3 (at p = 1.5 the
    first sample's weight is (p − 1)(p − 2)/2 = −0.125), so the weighted sum of residuals
    0.3, 0.01, 0.01 would be −0.026 (and the body refused as "a relative residual is never
    negative"). Reference: the residual of a mixed state is max r_i over the samples with a
    nonzero weight — 0.3 for cubic weights, 0.01 for linear ones at p = 1.5 (samples 2 and
    3 only); the other arrays are still Σ w_i X_i."""
    residuals = [0.3, 0.01, 0.01]
    bodies = [piston_body(k) for k in (1.5e5, 2.0e5, 2.5e5)]
    bodies = [b.with_(static=dataclasses.replace(b.static, residual=np.array(r)))
              for b, r in zip(bodies, residuals, strict=True)]
    pb = interpolate(bodies, [0.0, 1.0, 2.0], parameter="p", interpolation="cubic",
                     row_scaling="none")
    w = pb.weights(1.5)
    assert w[0] == pytest.approx(-0.125) and w @ residuals < 0
    cubic = pb.at(1.5).static
    assert cubic.residual == 0.3
    np.testing.assert_allclose(cubic.node_u, np.einsum("i,i...->...", w, pb.static.node_u),
                               rtol=1e-15)
    assert pb.at(1.5, "linear").static.residual == 0.01
    assert pb.at(1.0).static.residual == 0.01
    assert pb.static.mixed(w).residual == 0.3
