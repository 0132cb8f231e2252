"""Quality measures: FRFs, errors, eigenvalues, stability.

References: dense direct solves ``C (K + jωD − ω²M)⁻¹ B`` of the unreduced model; poles of
hand-made second-order systems with known stability.
"""

from __future__ import annotations

import numpy as np
import pytest
from fe_builders import piston_duct, random_up

from neweul_py.elastic import (
    ReducedBody,
    compare_eigenvalues,
    frf_full,
    frf_reduced,
    reduce_modal,
    stability,
)
from neweul_py.elastic.quality.measures import compare_frf


def _dense_frf(fe, f, inputs=None, outputs=None):
    B, C = fe.B(inputs), fe.C(outputs)
    D = fe.D.toarray() if fe.D is not None else 0.0
    return np.array([C @ np.linalg.solve(fe.K.toarray() + 1j * w * D - w**2 * fe.M.toarray(), B)
                     for w in 2 * np.pi * np.asarray(f)])


@pytest.mark.parametrize("extra_inputs", [False, True])  # both solve directions (B or Cᵀ)
def test_full_frf_matches_dense_solves(extra_inputs):
    fe = random_up(damping=1e-3)
    if extra_inputs:
        fe = fe.with_(inputs={**fe.inputs, "g": ((3, 2.0), (7, -1.0)), "h": ((11, 1.0),)})
    f = np.array([0.01, 0.05, 0.12])
    np.testing.assert_allclose(frf_full(fe, f), _dense_frf(fe, f), rtol=1e-10)


def test_reduced_frf_matches_a_loop_of_dense_solves():
    body = reduce_modal(piston_duct(60, damping=3.0), modes=8)
    f = np.linspace(10.0, 900.0, 7)
    ref = np.array([body.C @ np.linalg.solve(body.K + 2j * np.pi * x * body.D
                                             - (2 * np.pi * x) ** 2 * body.M, body.B)
                    for x in f])
    np.testing.assert_allclose(frf_reduced(body, f), ref, rtol=1e-12)
    one = frf_reduced(body, f, "force", "p_end")
    np.testing.assert_allclose(one[:, 0, 0], ref[:, 0, 0], rtol=1e-12)


def _body(M, D, K):
    r = M.shape[0]
    return ReducedBody(M=M, D=D, K=K, B=np.ones((r, 1)), C=np.ones((1, r)), input_names=("u",),
                       output_names=("y",), nodes=np.zeros((0, 4)), kept_dofs=[], dof_node=[],
                       dof_kind=[], V_kept=np.zeros((0, r)), W_kept=np.zeros((0, r)))


def test_stability_of_known_systems():
    eye = np.eye(2)
    assert stability(_body(eye, 0.1 * eye, np.diag([1.0, 4.0]))).stable  # damped
    assert stability(_body(eye, 0 * eye, np.diag([1.0, 4.0]))).stable  # undamped: marginal
    neg = stability(_body(eye, 0.1 * eye, np.diag([-1.0, 4.0])))  # divergent mode
    assert not neg.stable and neg.max_real_part == pytest.approx(
        -0.05 + np.sqrt(0.0025 + 1.0), rel=1e-12)
    # unsymmetric stiffness with complex λ = ω²: flutter-type instability
    assert not stability(_body(eye, 0 * eye, np.array([[1.0, 2.0], [-2.0, 1.0]]))).stable


def test_compare_eigenvalues_of_a_modal_reduction():
    fe = piston_duct()
    cmp = compare_eigenvalues(fe, reduce_modal(fe, modes=8))
    assert cmp["relative_error"][1:].max() < 1e-9
    assert cmp["frequency_full_hz"][1] == pytest.approx(114.71, rel=1e-3)


def test_compare_frf_csv(tmp_path):
    fe = piston_duct(60, damping=3.0)
    body = reduce_modal(fe, modes=20, static_correction=True)
    f = np.linspace(20.0, 300.0, 15)
    cmp = compare_frf(fe, body, f, "force", "p_end")
    assert cmp.max_relative_error < 1e-5
    cmp.to_csv(tmp_path / "c.csv")
    lines = (tmp_path / "c.csv").read_text().splitlines()
    assert lines[0] == "frequency_hz,full_magnitude,reduced_magnitude,relative_error,in_band"
    table = np.loadtxt(tmp_path / "c.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(table[:, 0], f)
    np.testing.assert_allclose(table[:, 1], np.abs(cmp.full))
