"""The snapshot global basis and its parametric body
(neweul_py/elastic/parametric/snapshot_basis.py).

References: the unreduced u–p piston–duct FE models (``fe_builders.piston_duct``, three
sound speeds, damped piston) solved directly; the entrywise interpolation property (the body
between samples is the projection of the interpolated FE matrices); the rigid mass of the
piston (the structure's only DOF).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from fe_builders import piston_duct

from neweul_py.elastic.bodies.invariants import Invariants
from neweul_py.elastic.parametric.snapshot_basis import (
    ProjectionCache,
    basis_parametric_body,
    check_same_mesh,
    snapshot_basis,
)
from neweul_py.elastic.quality.measures import second_order_poles
from neweul_py.errors import DataError

SPEEDS = (300.0, 343.0, 390.0)
F_SNAP = np.geomspace(20.0, 900.0, 8)


@pytest.fixture(scope="module")
def family():
    fes = [piston_duct(n_el=80, c=c, damping=3.0) for c in SPEEDS]
    loads = [fe.B("force") for fe in fes]
    V, energy = snapshot_basis(fes, loads, F_SNAP)
    body = basis_parametric_body(fes, V, SPEEDS, parameter="c", keep_nodes=[1],
                                 energy=energy)
    return fes, V, body


def _full(fe, f):
    b = fe.B("force")[:, 0].astype(complex)
    return np.array([spla.spsolve((fe.K + 2j * np.pi * fi * fe.D
                                   - (2 * np.pi * fi) ** 2 * fe.M).tocsc(), b)[0] for fi in f])


def _reduced(body, f):
    return np.array([(body.C[body.output_names.index("x_piston")] @ np.linalg.solve(
        body.K + 2j * np.pi * fi * body.D - (2 * np.pi * fi) ** 2 * body.M, body.B[:, 0]))
        for fi in f])


def test_the_basis_is_block_diagonal_and_energy_orthonormal(family) -> None:
    """Each column lives on the u rows or on the p rows only, and ``VᵀḠV = I``."""
    from neweul_py.elastic.parametric.global_basis import energy_metric

    fes, V, _ = family
    is_p = fes[0].dof_kind == "p"
    on_p, on_u = np.any(V[is_p] != 0, axis=0), np.any(V[~is_p] != 0, axis=0)
    assert not np.any(on_p & on_u)
    G = energy_metric(fes)
    assert np.allclose(V.T @ (G @ V), np.eye(V.shape[1]), atol=1e-8)


@pytest.mark.parametrize("i", [0, 1, 2])
def test_samples_match_the_full_models(family, i: int) -> None:
    """At every sample, 20–900 Hz: the piston response of the order-10 body against the full
    model (measured: median ≤ 7e-7, max ≤ 1.6e-3 near the antiresonances)."""
    fes, _V, body = family
    f = np.linspace(20.0, 900.0, 31)
    ref = _full(fes[i], f)
    err = np.abs(_reduced(body.at(SPEEDS[i]), f) - ref) / np.abs(ref)
    assert np.median(err) < 1e-5
    assert err.max() < 5e-3


@pytest.mark.parametrize("c", [310.0, 320.0, 370.0])
def test_between_samples_the_body_is_stable(family, c: float) -> None:
    """Between samples no right-half-plane pole (the block-diagonal Galerkin projection of
    the interpolated u–p matrices keeps the passive structure; global_basis.py)."""
    _fes, _V, body = family
    b = body.at(c)
    s = second_order_poles(b.M, b.D, b.K)
    assert s.real.max() <= 1e-9 * np.abs(s).max()


def test_a_cached_projection_is_the_direct_projection(family) -> None:
    """A model projected through a :class:`ProjectionCache` — against the first model
    projected, as its difference — equals ``Vᵀ X V`` computed densely (reference: the
    definition, round-off aside), is projected once, and is the sample that
    :func:`basis_parametric_body` then uses."""
    fes, V, _ = family
    cache = ProjectionCache()
    first = cache.body(fes[0], V, keep_nodes=[1])
    other = cache.body(fes[2], V, keep_nodes=[1])
    assert cache.base[0] is fes[0] and cache.body(fes[2], V, keep_nodes=[1]) is other
    for key in ("M", "K", "D"):
        direct = V.T @ getattr(fes[2], key).toarray() @ V
        np.testing.assert_allclose(other[key], direct, rtol=0,
                                   atol=1e-12 * np.abs(direct).max())
        np.testing.assert_allclose(first[key], V.T @ getattr(fes[0], key).toarray() @ V,
                                   rtol=0, atol=1e-12 * np.abs(direct).max())
    again = basis_parametric_body(fes, V, SPEEDS, parameter="c", keep_nodes=[1],
                                  projections=cache)
    np.testing.assert_array_equal(again.K[2], other.K)
    once = ProjectionCache()
    once.body(fes[0], V, keep_nodes=[1], remember=False)        # the base is always kept
    passing = once.body(fes[1], V, keep_nodes=[1], remember=False)
    assert set(once.bodies) == {fes[0].fingerprint}
    np.testing.assert_array_equal(passing.K, cache.body(fes[1], V, keep_nodes=[1]).K)


def test_fixed_frame_invariants(family) -> None:
    """The invariants hold the body's own M, K, D, the piston mass as the rigid mass, and
    zero frame couplings; they pass the schema check."""
    _fes, _V, body = family
    flat = {k: v[1] if v.dtype.kind == "f" else v[0] for k, v in body.invariants.items()}
    inv = Invariants.from_flat(flat)
    assert np.allclose(inv.Me.m0, body.M[1]) and np.allclose(inv.Ke.m0, body.K[1])
    assert inv.m == pytest.approx(0.05)
    assert not np.any(inv.Ct.m0) and not np.any(inv.Ge.m0)


def test_bad_input() -> None:
    """Non-positive snapshot frequencies, mismatched loads: one DataError each."""
    fe = piston_duct(n_el=10)
    with pytest.raises(DataError, match="positive"):
        snapshot_basis([fe], [fe.B("force")], [0.0, 10.0])
    with pytest.raises(DataError, match="load sets"):
        snapshot_basis([fe, fe], [fe.B("force")], [10.0])


def test_samples_on_different_meshes_are_one_error(family) -> None:
    """A sample with other nodes or DOFs than the first (another mesh): one DataError naming
    it, before anything is projected (reference: the two FE models' DOF counts)."""
    fes, V, _ = family
    other = piston_duct(n_el=60, c=SPEEDS[1], damping=3.0)
    with pytest.raises(DataError, match=r"sample at 343 .*other nodes or DOFs"):
        basis_parametric_body([fes[0], other, fes[2]], V, SPEEDS, parameter="c",
                              keep_nodes=[1])


def test_sample_slopes_with_static_states(family) -> None:
    """With the FE models at every sound speed ∓ 0.5 m/s and static states (a static
    displacement ``x_s(c) = (c/343)² a``), the body carries the central differences of the
    projected matrices and of the static coordinates — computed here from ``V`` and the
    energy metric of the samples — and Hermite weights; with quintic Hermite weights also
    the second differences with the samples (``x_s`` quadratic in ``c``: its curvature
    exact); bad slope input is one DataError."""
    from neweul_py.elastic.parametric.global_basis import energy_metric

    fes, V, _body = family
    step = 0.5
    near = [[piston_duct(n_el=80, c=c + sign * step, damping=3.0) for c in SPEEDS]
            for sign in (-1, 1)]
    a = np.random.default_rng(3).standard_normal(fes[0].n_dofs) * 1e-7
    x_s = lambda c: (c / 343.0) ** 2 * a  # noqa: E731
    static = [{"x": x_s(c)} for c in SPEEDS]
    side = tuple([{"x": x_s(c + sign * step)} for c in SPEEDS] for sign in (-1, 1))
    hb = basis_parametric_body(fes, V, SPEEDS, parameter="c", keep_nodes=[1], static=static,
                               slope_models=tuple(near), slope_step=step, slope_static=side,
                               interpolation="hermite")
    assert hb.interpolation == "hermite"
    G = energy_metric(fes)
    for i, c in enumerate(SPEEDS):
        dK = V.T @ ((near[1][i].K - near[0][i].K) @ V) / (2 * step)
        np.testing.assert_allclose(hb.slopes["K"][i], dK, rtol=0, atol=1e-9 * abs(dK).max())
        dq = V.T @ (G @ (x_s(c + step) - x_s(c - step))) / (2 * step)    # V is G-orthonormal
        np.testing.assert_allclose(hb.slopes["static/q"][i], dq, rtol=1e-6,
                                   atol=1e-9 * abs(dq).max())
    qb = basis_parametric_body(fes, V, SPEEDS, parameter="c", keep_nodes=[1], static=static,
                               slope_models=tuple(near), slope_step=step, slope_static=side)
    with pytest.raises(DataError, match="give Hermite weights"):
        basis_parametric_body(fes, V, SPEEDS, parameter="c", keep_nodes=[1], static=static,
                              slope_models=tuple(near), slope_step=step, slope_static=side,
                              interpolation="cubic")
    assert qb.interpolation == "quintic-hermite" and qb.format_version == 5
    for i, c in enumerate(SPEEDS):   # second differences of the same projections
        d2K = V.T @ ((near[1][i].K - 2 * fes[i].K + near[0][i].K) @ V) / step**2
        np.testing.assert_allclose(qb.curvatures["K"][i], d2K, rtol=0,
                                   atol=1e-6 * abs(d2K).max())
        d2q = V.T @ (G @ (x_s(c + step) - 2 * x_s(c) + x_s(c - step))) / step**2
        np.testing.assert_allclose(qb.curvatures["static/q"][i], d2q, rtol=1e-6,
                                   atol=1e-9 * abs(d2q).max())
    with pytest.raises(DataError, match="slope models go with a slope step"):
        basis_parametric_body(fes, V, SPEEDS, parameter="c", keep_nodes=[1], static=static,
                              slope_models=tuple(near), slope_step=step)
    with pytest.raises(DataError, match="positive number"):
        basis_parametric_body(fes, V, SPEEDS, parameter="c", keep_nodes=[1],
                              slope_models=tuple(near), slope_step=-1.0)
    with pytest.raises(DataError, match="one slope model on each side"):
        basis_parametric_body(fes, V, SPEEDS, parameter="c", keep_nodes=[1],
                              slope_models=(near[0][:2], near[1]), slope_step=step)


def test_snapshots_solved_in_worker_processes_are_the_same(family) -> None:
    """Two worker processes give the snapshots of the samples in the same order and the same
    numbers as one process (reference: the serial solves); a worker count below one is an
    error before any solve."""
    from neweul_py.elastic.parametric.snapshot_basis import frequency_snapshots

    fes = [*family[0], *family[0][:2]]     # five samples: more than the pool takes at once
    loads = [fe.B("force") for fe in fes]
    serial = list(frequency_snapshots(fes, loads, F_SNAP[:3]))
    parallel = list(frequency_snapshots(fes, loads, F_SNAP[:3], workers=2))
    assert len(parallel) == len(serial) == 3 * len(fes)
    for (x1, _, w1), (x2, _, w2) in zip(serial, parallel, strict=True):
        assert w1 == w2 and np.array_equal(x1, x2)
    with pytest.raises(DataError, match="workers"):
        frequency_snapshots(fes, loads, F_SNAP, workers=0)


class _Built(Sequence):
    """FE models made when indexed (as a build reads its working points from disk)."""

    def __init__(self, speeds):
        self.speeds, self.taken = list(speeds), []

    def __len__(self):
        return len(self.speeds)

    def __getitem__(self, i):
        c = self.speeds[i]
        self.taken.append(i)
        return piston_duct(n_el=80, c=c, damping=3.0)


def test_models_given_lazily_are_taken_when_used(family) -> None:
    """A lazy sequence of FE models gives the same basis and body as a list, each model is
    taken when its sample is solved or projected, and the mesh check walks it once
    (reference: the body of the list in the fixture)."""
    from neweul_py.elastic.parametric.snapshot_basis import frequency_snapshots

    fes, V, body = family
    lazy = _Built(SPEEDS)
    check_same_mesh(iter(lazy), SPEEDS)
    assert lazy.taken == [0, 1, 2]
    V2, _ = snapshot_basis(lazy, [fe.B("force") for fe in fes], F_SNAP)
    np.testing.assert_array_equal(V2, V)
    # the solves take a model when its sample is solved, in processes at most workers + 1
    # ahead of the snapshots handed out (a list made of the sequence would take all five)
    speeds = (300.0, 320.0, 343.0, 360.0, 390.0)
    for workers, ahead in ((1, 1), (2, 4)):
        lazy = _Built(speeds)
        snaps = frequency_snapshots(lazy, [fes[0].B("force")] * 5, F_SNAP[:2], workers=workers)
        next(snaps)
        assert lazy.taken == list(range(ahead))
        assert len(list(snaps)) == 2 * 5 - 1 and lazy.taken == [0, 1, 2, 3, 4]
    lazy = _Built(SPEEDS)
    b2 = basis_parametric_body(lazy, V, SPEEDS, parameter="c", keep_nodes=[1])
    np.testing.assert_allclose(b2.K, body.K, rtol=0, atol=1e-12 * np.abs(body.K).max())
    assert lazy.taken == [0, 1, 2, 0, 0, 1, 2]    # the mesh, its DOFs, each projection
    other = [fes[0], piston_duct(n_el=60, c=SPEEDS[1], damping=3.0), fes[2]]
    with pytest.raises(DataError, match=r"sample at 343 .*other nodes or DOFs"):
        check_same_mesh((fe for fe in other), SPEEDS)


def test_moment_snapshots_are_the_derivatives_of_the_response() -> None:
    """With ``moments=3`` the snapshots after each response are ``ω X′`` and ``ω² X″/2``
    (reference: central differences of ``X(ω) = A(ω)⁻¹F`` from direct sparse solves, and of
    the adjoint ``Aᵀ(ω)⁻¹c``); ``moments`` outside 1–3 is one DataError."""
    from neweul_py.elastic.parametric.snapshot_basis import frequency_snapshots

    fe = piston_duct(n_el=40, c=343.0, damping=3.0)
    F, c = fe.B("force"), fe.B("force") + 0.5
    f0, h = 300.0, 1e-3                     # Hz; the difference step in ω is 2π h

    def solve(f, rhs, transpose=False):
        w = 2 * np.pi * f
        A = (fe.K + 1j * w * fe.D - w * w * fe.M).tocsc()
        return spla.spsolve(A.T.tocsc() if transpose else A, rhs[:, 0].astype(complex))

    snaps = list(frequency_snapshots([fe], [F], [f0], adjoint=[c], moments=3))
    assert len(snaps) == 3 and all(w == 2 * np.pi * f0 for *_, w in snaps)
    w, dw = 2 * np.pi * f0, 2 * np.pi * h
    for transpose, k in ((False, 0), (True, 1)):
        x = [solve(f0 + s * h, F if not transpose else c, transpose) for s in (-1, 0, 1)]
        d1 = w * (x[2] - x[0]) / (2 * dw)
        d2 = w * w * (x[2] - 2 * x[1] + x[0]) / dw**2 / 2
        np.testing.assert_allclose(snaps[0][k][:, 0], x[1], rtol=1e-10, atol=0)
        np.testing.assert_allclose(snaps[1][k][:, 0], d1, rtol=0,
                                   atol=1e-6 * np.abs(d1).max())
        np.testing.assert_allclose(snaps[2][k][:, 0], d2, rtol=0,
                                   atol=1e-4 * np.abs(d2).max())
    with pytest.raises(DataError, match="moments"):
        frequency_snapshots([fe], [F], [f0], moments=4)


def test_a_basis_with_moments_matches_the_response_and_its_slope() -> None:
    """A Galerkin basis of the response and its first derivative at one frequency gives a
    reduced transfer function (piston force to the pressure at the far end: not collocated)
    equal to the full one there and of equal slope; without the derivative the slope is
    missed (Hermite interpolation, Baur et al. 2011, §3; reference: direct sparse solves of
    the full model, the slope by central differences)."""
    fe = piston_duct(n_el=80, c=343.0, damping=3.0)
    f0, h = 250.0, 1e-3
    b = fe.B("force")[:, 0]
    end = fe.n_dofs - 1

    def full(f):
        w = 2 * np.pi * f
        return spla.spsolve((fe.K + 1j * w * fe.D - w * w * fe.M).tocsc(),
                            b.astype(complex))[end]

    def reduced(V, f):
        Kr, Dr, Mr = (V.T @ (X @ V) for X in (fe.K, fe.D, fe.M))
        w = 2 * np.pi * f
        return V[end] @ np.linalg.solve(Kr + 1j * w * Dr - w * w * Mr, V.T @ b)

    ref = np.array([full(f) for f in (f0 - h, f0, f0 + h)])
    slope = (ref[2] - ref[0]) / (2 * h)
    for moments, slope_error in ((2, 1e-5), (1, None)):
        V, _ = snapshot_basis([fe], [fe.B("force")], [f0], rtol=1e-14, moments=moments)
        red = np.array([reduced(V, f) for f in (f0 - h, f0, f0 + h)])
        assert abs(red[1] - ref[1]) <= 1e-9 * abs(ref[1])
        error = abs((red[2] - red[0]) / (2 * h) - slope)
        if slope_error is None:
            assert error > 1e-3 * abs(slope)
        else:
            assert error <= slope_error * abs(slope)
