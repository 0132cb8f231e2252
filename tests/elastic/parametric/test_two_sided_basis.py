"""The two-sided (balanced POD) global basis and its parametric body
(neweul_py/elastic/parametric/two_sided_basis.py).

References: the unreduced u–p FE models (``fe_builders.piston_duct``, three sound speeds,
damped piston; ``fe_builders.membrane_cavity``, three tensions) solved directly, and their
zero mode (the constant pressure of the closed cavity: ``λ = 0`` of the FE pencil, from the
two-sided modal reduction of the FE model itself).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from fe_builders import membrane_cavity, piston_duct

from neweul_py.elastic.parametric.snapshot_basis import basis_parametric_body
from neweul_py.elastic.parametric.two_sided_basis import (
    balanced_snapshot_basis,
    zero_mode_pairs,
)
from neweul_py.elastic.quality.measures import right_half_plane_poles
from neweul_py.errors import DataError

SPEEDS = (300.0, 343.0, 390.0)
F_SNAP = np.geomspace(20.0, 900.0, 8)
TENSIONS = (80.0, 100.0, 125.0)


@pytest.fixture(scope="module")
def family():
    fes = [piston_duct(n_el=80, c=c, damping=3.0) for c in SPEEDS]
    basis = balanced_snapshot_basis(fes, [fe.B("force") for fe in fes],
                                    [fe.C().T for fe in fes], F_SNAP,
                                    pairs=[zero_mode_pairs(fe) for fe in fes])
    body = basis_parametric_body(fes, basis.V, SPEEDS, parameter="c", keep_nodes=[1],
                                 W=basis.W)
    return fes, basis, body


def _full(fe, f):
    b = fe.B("force")[:, 0].astype(complex)
    return np.array([spla.spsolve((fe.K + 2j * np.pi * fi * fe.D
                                   - (2 * np.pi * fi) ** 2 * fe.M).tocsc(), b)[0] for fi in f])


def _reduced(body, f):
    return np.array([(body.C[body.output_names.index("x_piston")] @ np.linalg.solve(
        body.K + 2j * np.pi * fi * body.D - (2 * np.pi * fi) ** 2 * body.M, body.B[:, 0]))
        for fi in f])


def test_the_pair_is_mass_biorthonormal_and_two_sided(family) -> None:
    """``Wᵀ M̄ V = I`` (M̄ the mean mass matrix) and ``W`` is not ``V``: the left basis leaves
    the span of the right one; the body records and is two-sided."""
    fes, basis, body = family
    M = sum(fe.M for fe in fes) / len(fes)
    assert np.allclose(basis.W.T @ (M @ basis.V), np.eye(basis.order), atol=1e-8)
    Q = np.linalg.qr(basis.V)[0]
    assert np.linalg.norm(basis.W - Q @ (Q.T @ basis.W)) > 1e-3 * np.linalg.norm(basis.W)
    assert body.two_sided and not np.array_equal(body.V_kept, body.W_kept)
    assert all(s["two_sided"] for s in body.sample_settings)


@pytest.mark.parametrize("i", [0, 1, 2])
def test_samples_match_the_full_models(family, i: int) -> None:
    """At every sample, 20–900 Hz: the piston response against the full model solved
    directly (order 11; measured: median ≤ 1e-8, max ≤ 9e-5 at an antiresonance)."""
    fes, _basis, body = family
    f = np.linspace(20.0, 900.0, 31)
    ref = _full(fes[i], f)
    err = np.abs(_reduced(body.at(SPEEDS[i]), f) - ref) / np.abs(ref)
    assert np.median(err) < 1e-6
    assert err.max() < 5e-4


def test_the_zero_mode_of_a_closed_cavity_is_kept() -> None:
    """The membrane over a closed cavity has ``λ = 0`` (constant pressure); the snapshots
    alone (200 Hz–8 kHz) lose it, the zero pairs keep it to round-off at every sample and
    between samples, with no pole in the right half plane."""
    fes = [membrane_cavity(t) for t in TENSIONS]
    args = ([fe.B("force") for fe in fes], [fe.C().T for fe in fes],
            np.geomspace(200.0, 8000.0, 8))
    pairs = [zero_mode_pairs(fe) for fe in fes]
    assert [p[0].shape[1] for p in pairs] == [1, 1, 1]
    for with_pairs in (False, True):
        b = balanced_snapshot_basis(fes, *args, pairs=pairs if with_pairs else ())
        pb = basis_parametric_body(fes, b.V, TENSIONS, parameter="T", W=b.W)
        for t in (80.0, 90.0, 100.0, 125.0):
            r = pb.at(t)
            lam = np.abs(np.linalg.eigvals(np.linalg.solve(r.M, r.K)))
            assert (lam.min() < 1e-12 * lam.max()) == with_pairs
            assert right_half_plane_poles(r.M, r.D, r.K).size == 0


def test_bad_input_is_one_data_error(family) -> None:
    """Output sets not one per model, pairs of unequal width, a left basis of another
    shape: one :class:`DataError` each."""
    fes, basis, _body = family
    loads, outs = [fe.B("force") for fe in fes], [fe.C().T for fe in fes]
    with pytest.raises(DataError, match="output sets"):
        balanced_snapshot_basis(fes, loads, outs[:2], F_SNAP)
    V0, W0 = zero_mode_pairs(fes[0])
    with pytest.raises(DataError, match="right and"):
        balanced_snapshot_basis(fes, loads, outs, F_SNAP, pairs=[(V0, W0[:, :0])])
    with pytest.raises(DataError, match="left basis"):
        basis_parametric_body(fes, basis.V, SPEEDS, W=basis.W[:, :-1])
