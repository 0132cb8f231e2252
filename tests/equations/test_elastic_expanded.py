"""The closed-form splice of elastic bodies (equations/elastic_expanded.py): its lazy sums."""

from __future__ import annotations

import numpy as np
import sympy as sp

from neweul_py.equations.elastic_expanded import Terms


def _lazy(values):
    out = np.empty(len(values), dtype=object)
    out[:] = [Terms([v]) for v in values]
    return out


def _value(e, point):
    e = e.expr() if isinstance(e, Terms) else sp.sympify(e)
    return float(e.subs(point))


def test_lazy_sums_equal_sympy_arithmetic():
    """Reference: the same products of float matrices (with zeros) and expressions done by
    sympy's Matrix arithmetic, evaluated at a random point — sums, differences, products of
    sums, negation, division by a number and products with zero agree to round-off."""
    rng = np.random.default_rng(4)
    x = sp.symbols("x0:5", real=True)
    exprs = [sp.sin(x[0]) * x[1], x[2] ** 2 + x[3], x[4], sp.cos(x[1]) - x[0], x[3] * x[4]]
    a = rng.standard_normal((4, 5))
    a[a < -0.5] = 0.0
    b = rng.standard_normal((5, 3))
    v = _lazy(exprs)
    got = (a @ np.outer(v, v) @ b)[:, :2] - (a @ v)[:, None] / 3.0 + 0.0 * v[0] - (-v[1])
    ref = (sp.Matrix(a) * (sp.Matrix(exprs) * sp.Matrix(exprs).T) * sp.Matrix(b))[:, :2] \
        - (sp.Matrix(a) * sp.Matrix(exprs)) * sp.ones(1, 2) / 3 + exprs[1] * sp.ones(4, 2)
    point = dict(zip(x, rng.standard_normal(5), strict=True))
    for i in range(4):
        for j in range(2):
            assert np.isclose(_value(got[i, j], point), _value(ref[i, j], point), rtol=1e-12,
                              atol=1e-12)
    assert (Terms([x[0]]) * 0.0) == 0.0 and (Terms([sp.S.Zero]) * Terms([x[1]])) == 0.0
    assert isinstance(Terms([x[0]]) * 2.0 + 1, Terms)
