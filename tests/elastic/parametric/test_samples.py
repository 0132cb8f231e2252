"""The derivatives of a parametric body's samples keep the samples' structure
(neweul_py/elastic/parametric/samples.py, ``structured_derivatives``).

Reference: the exact derivative of a symmetric family ``X(σ) = A + σ S + σ² T`` (``S``, ``T``
symmetric) and of ``D = c G``, against central differences whose round-off breaks both.
"""

from __future__ import annotations

import numpy as np

from neweul_py.elastic.parametric.samples import (
    central_curvatures,
    central_slopes,
    structured_derivatives,
)


def test_central_differences_keep_symmetry_and_proportionality() -> None:
    """Symmetric blocks give symmetric slopes and curvatures, ``D = c G`` gives ``c`` times
    the slopes of ``G``; an unsymmetric block is left alone; the result is closer to the
    exact derivative than the differences were."""
    rng = np.random.default_rng(2)
    n, k, h, c = 5, 3, 1e-3, 1.0 / (2 * np.pi * 1000.0)
    sym = lambda a: a + a.T                               # noqa: E731
    A, S, T = sym(rng.standard_normal((n, n))), sym(rng.standard_normal((n, n))), \
        sym(rng.standard_normal((n, n)))
    A[0, 1] += 1.0                                        # one unsymmetric pair
    sigma = np.array([0.0, 0.5, 1.0])

    def family(s: np.ndarray, noise: float) -> dict[str, np.ndarray]:
        G = np.stack([A + x * S + x * x * T for x in s])
        G = G + noise * rng.standard_normal(G.shape)      # round-off of the FE models
        return {"G": G, "D": c * G + noise * c * rng.standard_normal(G.shape)}

    minus, centre, plus = family(sigma - h, 1e-13), family(sigma, 0.0), family(sigma + h, 1e-13)
    keys = ("G", "D")
    slopes = central_slopes(minus.get, plus.get, h, keys)
    curv = central_curvatures(minus.get, centre.get, plus.get, h, keys)
    exact_s = np.stack([S + 2 * x * T for x in sigma])
    for got, exact in ((slopes, exact_s), (curv, np.broadcast_to(2 * T, (k, n, n)))):
        fixed = structured_derivatives(centre.get, [got], {"D": ("G", c)})[0]
        G = fixed["G"]
        sym_part = np.ones((n, n), dtype=bool)
        sym_part[0, 1] = sym_part[1, 0] = False
        np.testing.assert_array_equal(G[:, sym_part], G.transpose(0, 2, 1)[:, sym_part])
        assert not np.allclose(G[:, 0, 1], G[:, 1, 0], rtol=0, atol=1e-12)
        np.testing.assert_array_equal(fixed["D"], c * G)
        assert np.abs(G - exact).max() <= np.abs(got["G"] - exact).max()
