"""The mixing of parametric samples (``neweul_py.ffrf.parametric``): one product of the stacked
sample arrays must equal the weighted sum of every array of every sample.

Reference: the explicit sum ``Σ_i w_i X_i`` per array (the definition, equations.md §4).
"""

from __future__ import annotations

import numpy as np
import pytest

from neweul_py.ffrf.parametric import ffrf_mix, ffrf_stack


def _sample(rng: np.random.Generator) -> dict:
    return {"mass": float(rng.uniform(1, 2)), "nq": 3, "fixed": True,
            "Me": rng.standard_normal((3, 3)), "ks": rng.standard_normal(3),
            "md0": rng.standard_normal(3),
            "quad": {"mass": float(rng.uniform(1, 2)), "T1": rng.standard_normal((4, 2)),
                     "C2": None, "where": {"J": (0, 9, (3, 3))}}}


def test_one_product_equals_the_weighted_sum_of_every_array() -> None:
    """Arrays, the mass, the nested body of a second-order field and extra rows (``S_V,i``)
    mixed with real and with complex weights (the complex step in σ) equal ``Σ w_i X_i``;
    the other entries are sample 1's."""
    rng = np.random.default_rng(3)
    samples = [_sample(rng) for _ in range(4)]
    rows = rng.standard_normal((4, 2, 5))
    mixing = ffrf_stack(samples, {"_sv": rows})
    assert mixing["stack"].shape[0] == 4
    for w in (rng.standard_normal(4), rng.standard_normal(4) + 1e-30j * rng.standard_normal(4)):
        got = ffrf_mix(mixing, w)
        for key in ("Me", "ks", "md0", "mass"):
            ref = sum(wi * s[key] for wi, s in zip(w, samples, strict=True))
            np.testing.assert_allclose(got[key], ref, rtol=1e-13, atol=1e-300)
            if np.iscomplexobj(w):
                np.testing.assert_allclose(np.imag(got[key]), np.imag(ref), rtol=1e-13)
        quad = sum(wi * s["quad"]["T1"] for wi, s in zip(w, samples, strict=True))
        np.testing.assert_allclose(got["quad"]["T1"], quad, rtol=1e-13)
        np.testing.assert_allclose(got["_sv"], np.tensordot(w, rows, axes=1), rtol=1e-13)
        assert got["nq"] == 3 and got["fixed"] is True and got["quad"]["C2"] is None
    # the samples themselves are untouched
    assert samples[0]["quad"]["T1"].shape == (4, 2)


# ---------------------------------------------------------------- interpolation coordinate
def _composition(samples, knots, xi, p):
    """The definition: ``S_i(ξ(σ))``, ``ξ`` the PCHIP of the table, ``S_i`` the cardinal
    not-a-knot splines through ``ξ(s_i)`` (SciPy, evaluated directly)."""
    from scipy.interpolate import CubicSpline, PchipInterpolator

    xi_of = PchipInterpolator(knots, xi)
    return CubicSpline(xi_of(samples), np.eye(samples.size), bc_type="not-a-knot")(xi_of(p))


def test_coordinate_weights_are_the_composition_and_sum_to_one() -> None:
    """Weights in a coordinate ``ξ(σ)`` (equations.md §4.1): within 1e-6 of ``S_i(ξ(σ))``
    on 161 knots (the Hermite pieces are O(h⁴)), summing to one, the unit vectors at the
    samples (to round-off); a decreasing coordinate gives the same weights as its negative."""
    from neweul_py.ffrf.parametric import ffrf_weights, weight_polynomials

    s = np.arange(-4000.0, 4001.0, 1000.0)
    knots = np.linspace(-4000.0, 4000.0, 161)
    xi = 3.0 * np.tanh(knots / 2500.0) + 1e-4 * knots
    b, c = weight_polynomials(s, "cubic", np.vstack([knots, xi]))
    assert np.array_equal(b, knots) and c.shape == (4, 160, 9)
    for p in (-3999.0, -1234.5, -10.0, 333.0, 2999.0, 3999.9):
        w = ffrf_weights(b, c, p, "tm")
        np.testing.assert_allclose(w, _composition(s, knots, xi, p), atol=1e-6)
        assert abs(w.sum() - 1.0) < 1e-13
    for j, v in enumerate(s):   # the right end is the last piece at dx = h: round-off
        np.testing.assert_allclose(ffrf_weights(b, c, v, "tm"), np.eye(9)[j], atol=1e-15)
    _, c2 = weight_polynomials(s, "cubic", np.vstack([knots, -xi]))
    np.testing.assert_allclose(c2, c, rtol=0, atol=1e-15)


def test_identity_coordinate_gives_the_cubic_spline_weights() -> None:
    """``ξ = σ`` on any knots reproduces the not-a-knot weights in σ (round-off)."""
    from neweul_py.ffrf.parametric import ffrf_weights, weight_polynomials

    s = np.array([0.0, 0.7, 1.5, 2.0, 3.1])
    knots = np.unique(np.concatenate([s, np.linspace(0.0, 3.1, 23)]))
    b0, c0 = weight_polynomials(s, "cubic")
    b1, c1 = weight_polynomials(s, "cubic", np.vstack([knots, knots]))
    for p in np.linspace(0.0, 3.1, 41):
        np.testing.assert_allclose(ffrf_weights(b1, c1, p, "x"), ffrf_weights(b0, c0, p, "x"),
                                   rtol=0, atol=1e-13)


def test_complex_step_differentiates_the_coordinate_weights() -> None:
    """``Im w(σ + ih)/h`` equals central differences of ``w`` (the generated module's
    Jacobian through the schedule uses the complex step)."""
    from neweul_py.ffrf.parametric import ffrf_weights, weight_polynomials

    s = np.array([0.0, 1.0, 2.0, 4.0])
    knots = np.linspace(0.0, 4.0, 17)
    b, c = weight_polynomials(s, "cubic", np.vstack([knots, np.sqrt(1.0 + knots)]))
    for p in (0.3, 1.7, 3.2):
        cs = ffrf_weights(b, c, p + 1e-30j, "x").imag / 1e-30
        fd = (ffrf_weights(b, c, p + 1e-6, "x") - ffrf_weights(b, c, p - 1e-6, "x")) / 2e-6
        np.testing.assert_allclose(cs, fd, rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize(("table", "words"), [
    (np.zeros((3, 4)), "(2, n ≥ 2)"),
    (np.array([[0.0, 1.0, 2.0], [0.0, np.nan, 1.0]]), "finite"),
    (np.array([[0.0, 2.0, 1.0], [0.0, 1.0, 2.0]]), "strictly increasing"),
    (np.array([[0.0, 1.0, 1.5], [0.0, 1.0, 2.0]]), "span the samples' range"),
    (np.array([[0.0, 0.5, 2.0], [0.0, 1.0, 2.0]]), "missing [1.0]"),
    (np.array([[0.0, 1.0, 2.0], [0.0, 2.0, 1.0]]), "strictly monotone"),
])
def test_bad_coordinate_tables_are_refused(table, words) -> None:
    """Each malformed table (shape, NaN, knot order, range, a missing sample, a
    non-monotone coordinate) is one error saying what is wrong; linear weights refuse a
    coordinate."""
    from neweul_py.ffrf.parametric import coordinate_problem, weight_polynomials

    s = np.array([0.0, 1.0, 2.0])
    assert words in coordinate_problem(s, table)
    with pytest.raises(ValueError, match="interpolation coordinate"):
        weight_polynomials(s, "cubic", table)
    good = np.array([[0.0, 1.0, 2.0], [0.0, 1.0, 3.0]])
    assert coordinate_problem(s, good) is None
    with pytest.raises(ValueError, match="cubic weights"):
        weight_polynomials(s, "linear", good)


def test_crowded_or_oversized_coordinates_are_refused() -> None:
    """A coordinate whose values crowd samples together (weights of 1e299, or NaN) exceeds
    the Lebesgue bound; more knots than MAX_KNOTS, or a table of strings, is refused by
    name (the fresh-clone audit's cases)."""
    from neweul_py.ffrf.parametric import MAX_KNOTS, coordinate_problem, weight_polynomials

    s = np.array([0.0, 1.0, 2.0])
    for xi1 in (1e-300, 1e-6):
        with pytest.raises(ValueError, match="crowd the samples"):
            weight_polynomials(s, "cubic", np.array([[0.0, 1.0, 2.0], [0.0, xi1, 1.0]]))
    big = np.vstack([np.linspace(0.0, 2.0, MAX_KNOTS + 1)] * 2)
    assert f"more than {MAX_KNOTS}" in coordinate_problem(s, big)
    assert "real numbers" in coordinate_problem(s, np.array([["0", "1"], ["0", "1"]]))
