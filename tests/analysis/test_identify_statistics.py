"""The statistics at a fit's optimum (analysis/identify_statistics.py).

Reference: the rule of docs/sensitivity.md §7 applied by hand to constructed end points — a
start whose cost equals the best one's and whose end point lies more than four standard errors
away makes that parameter undetermined; a start of higher cost, one that did not converge, or
one within the standard errors does not.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from neweul_py.analysis.identify_statistics import equal_cost_spread, fit_statistics

PROBLEM = SimpleNamespace(names=("a", "b"), log=(True, False),
                          values=lambda th: np.array([np.exp(th[0]), th[1]]))


def _run(a: float, b: float, cost: float, status: int = 1) -> dict:
    return {"theta": np.array([np.log(a), b]), "cost": cost, "status": status}


def test_equal_cost_elsewhere_is_undetermined() -> None:
    best = _run(2.0, 1.0, 0.5)
    errors = {"a": 0.02, "b": 0.01}                     # σ(ln a) = 0.01
    runs = [best, _run(3.0, 1.0 + 1e-3, 0.5 * (1 + 1e-9)),   # a far, b within 4 σ
            _run(9.0, 5.0, 0.6),                         # higher cost
            _run(9.0, 5.0, 0.5, status=0)]               # not converged
    why = equal_cost_spread(PROBLEM, best, runs, errors)
    assert set(why) == {"a"}
    assert "2 … 3" in why["a"]


def test_within_the_standard_errors_is_determined() -> None:
    best = _run(2.0, 1.0, 0.5)
    runs = [best, _run(2.0 * np.exp(0.03), 1.03, 0.5)]  # 3 σ in both
    assert equal_cost_spread(PROBLEM, best, runs, {"a": 0.02, "b": 0.01}) == {}


def test_the_variance_counts_the_residuals_given() -> None:
    """``s² = r·r/(m − k)``: with ``m`` given, the standard errors scale by
    ``√((rows − k)/(m − k))`` against all rows of ``J``."""
    rng = np.random.default_rng(1)
    J = rng.standard_normal((40, 2))
    r = rng.standard_normal(40)
    all_rows = fit_statistics(PROBLEM, np.zeros(2), r, J)[0]
    fewer = fit_statistics(PROBLEM, np.zeros(2), r, J, m=22)[0]
    assert np.isclose(fewer["b"] / all_rows["b"], np.sqrt(38 / 20), rtol=1e-12)
