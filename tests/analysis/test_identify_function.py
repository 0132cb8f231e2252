"""Identification through a residual function (analysis/identify_function.py).

References: closed forms — a linear least-squares problem, whose optimum and covariance are
``(AᵀA)⁻¹Aᵀy`` and ``(AᵀA)⁻¹`` for residuals in units of their standard deviations; a log
parameter whose residual is ``(ln p − ln p₀)/σ`` (standard error ``p₀ σ``); two parameters of
which only the product enters, which must be reported undetermined, not as numbers.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from neweul_py.analysis import Bound, identify_function
from neweul_py.errors import NeweulError, SolverError

A = np.array([[1.0, 0.0], [1.0, 1.0], [1.0, 2.0], [1.0, 3.0], [2.0, -1.0]])
Y = np.array([0.9, 3.2, 4.8, 7.1, -0.2])
SIGMA = np.array([0.1, 0.2, 0.1, 0.3, 0.2])


def _linear(values):
    theta = np.array([values["a"], values["b"]])
    return (A @ theta - Y) / SIGMA


def test_linear_problem_gives_the_normal_equations_and_their_covariance():
    """Optimum and standard errors against the weighted normal equations (closed form)."""
    fit = identify_function(_linear, [Bound("a", -10, 10, 0.0), Bound("b", -10, 10, 0.0)],
                            step=1e-3, tolerance=1e-12)
    Aw = A / SIGMA[:, None]
    theta = np.linalg.solve(Aw.T @ Aw, Aw.T @ (Y / SIGMA))
    cov = np.linalg.inv(Aw.T @ Aw)
    assert fit.task == "function" and fit.converged
    assert fit.parameters["a"] == pytest.approx(theta[0], abs=1e-8)
    assert fit.parameters["b"] == pytest.approx(theta[1], abs=1e-8)
    assert fit.standard_errors["a"] == pytest.approx(np.sqrt(cov[0, 0]), rel=1e-6)
    assert fit.standard_errors["b"] == pytest.approx(np.sqrt(cov[1, 1]), rel=1e-6)
    rho = cov[0, 1] / np.sqrt(cov[0, 0] * cov[1, 1])
    assert fit.correlation["a"]["b"] == pytest.approx(rho, rel=1e-6)
    assert fit.scale == {"a": "linear", "b": "linear"}


def test_estimated_variance_scales_the_errors_by_the_residual_rms():
    """``known_variance=False``: ``s² = Σr²/(m − k)`` multiplies the covariance."""
    known = identify_function(_linear, ["a=-10:10:0", "b=-10:10:0"], step=1e-3,
                              tolerance=1e-12)
    est = identify_function(_linear, ["a=-10:10:0", "b=-10:10:0"], step=1e-3,
                            tolerance=1e-12, known_variance=False)
    s = np.sqrt(2 * known.cost / (A.shape[0] - 2))
    assert est.standard_errors["a"] == pytest.approx(s * known.standard_errors["a"], rel=1e-6)


def test_log_parameter_error_is_its_value_times_the_log_sd():
    """Residuals ``(ln p − ln 3)/0.05`` and ``(ln q − ln 7)/0.1``: ``p = 3 ± 0.15``,
    ``q = 7 ± 0.7`` (first order)."""
    def res(v):
        return np.array([(np.log(v["p"]) - np.log(3.0)) / 0.05,
                         (np.log(v["q"]) - np.log(7.0)) / 0.1, 0.0])

    fit = identify_function(res, ["p=0.1:100", "q=0.1:100"], labels=["p", "q", "zero"],
                            step=1e-4, tolerance=1e-12)
    assert fit.scale == {"p": "log", "q": "log"}
    assert fit.parameters["p"] == pytest.approx(3.0, rel=1e-8)
    assert fit.standard_errors["p"] == pytest.approx(0.15, rel=1e-4)
    assert fit.standard_errors["q"] == pytest.approx(0.7, rel=1e-4)
    assert fit.curve["labels"] == ["p", "q", "zero"]


def test_a_product_alone_leaves_both_factors_undetermined(tmp_path):
    """Only ``a·b`` enters: both are reported undetermined (no value, no error); the JSON
    says so with nulls and the residual plot is written."""
    def res(v):
        return np.array([(v["a"] * v["b"] - 6.0) / 0.1, (v["a"] * v["b"] - 6.2) / 0.1, 0.3])

    fit = identify_function(res, ["a=0.5:10:1.5", "b=0.5:10:2"], step=1e-4)
    assert fit.parameters == {"a": None, "b": None}
    assert fit.standard_errors == {"a": None, "b": None}
    assert "only a combination" in fit.undetermined["a"]
    assert fit.end_point["a"] * fit.end_point["b"] == pytest.approx(6.1, rel=1e-4)
    data = json.loads(fit.to_json(tmp_path / "fit.json").read_text())
    assert data["parameters"]["a"] is None and data["task"] == "function"
    assert fit.plot(tmp_path / "fit.png").stat().st_size > 0


@pytest.mark.parametrize("bounds, fun, error, match", [
    (["a=2:1"], lambda v: np.ones(3), NeweulError, "LO"),
    (["a=1:2:3"], lambda v: np.ones(3), NeweulError, "outside"),
    (["a=1:2", "a=1:3"], lambda v: np.ones(3), NeweulError, "twice"),
    (["a=1:2", "b=1:2"], lambda v: np.ones(2), NeweulError, "cannot determine"),
    (["a=1:2"], lambda v: np.array([1.0, np.nan]), SolverError, "finite"),
])
def test_bad_input_is_one_clear_error(bounds, fun, error, match):
    """Bounds, duplicates, too few or non-finite residuals: one error naming the cause."""
    with pytest.raises(error, match=match):
        identify_function(fun, bounds)


def test_a_loosely_bound_log_parameter_is_undetermined():
    """``(ln q − ln 7)/3``: σ(ln q) = 3 > 1 — reported undetermined with its factor
    (e³ ≈ 20.1), while ``p`` (σ(ln p) = 0.05) keeps its value; ``max_log_sd=None`` gives
    ``q = 7 ± 21`` (first order)."""
    def res(v):
        return np.array([(np.log(v["p"]) - np.log(3.0)) / 0.05,
                         (np.log(v["q"]) - np.log(7.0)) / 3.0, 0.0])

    fit = identify_function(res, ["p=0.1:100", "q=0.01:1000"], step=1e-4, tolerance=1e-12)
    assert fit.parameters["q"] is None and "20.1" in fit.undetermined["q"]
    assert fit.parameters["p"] == pytest.approx(3.0, rel=1e-8)
    assert fit.correlation["p"]["q"] is None
    loose = identify_function(res, ["p=0.1:100", "q=0.01:1000"], step=1e-4, tolerance=1e-12,
                              max_log_sd=None)
    assert loose.standard_errors["q"] == pytest.approx(21.0, rel=1e-4)
