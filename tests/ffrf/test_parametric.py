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
    mixed with real and with complex weights (the complex step in σ), dense or nonzero in a
    band of samples only, equal ``Σ w_i X_i``; the other entries are sample 1's."""
    rng = np.random.default_rng(3)
    samples = [_sample(rng) for _ in range(4)]
    rows = rng.standard_normal((4, 2, 5))
    mixing = ffrf_stack(samples, {"_sv": rows})
    assert mixing["varying"].shape[0] == 4
    band = np.r_[0.0, rng.standard_normal(2), 0.0]     # local weights: the band's rows only
    for w in (rng.standard_normal(4), rng.standard_normal(4) + 1e-30j * rng.standard_normal(4),
              band, band + 1e-30j * np.r_[0.0, 1.0, 2.0, 0.0]):
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
    with pytest.raises(ValueError, match="cubic or Hermite weights"):
        weight_polynomials(s, "linear", good)


def test_crowded_or_oversized_coordinates_are_refused() -> None:
    """A coordinate whose values crowd samples together (weights of 1e299, or NaN) exceeds
    the Lebesgue bound; more knots than MAX_KNOTS, or a table of strings, is refused by
    name."""
    from neweul_py.ffrf.parametric import MAX_KNOTS, coordinate_problem, weight_polynomials

    s = np.array([0.0, 1.0, 2.0])
    for xi1 in (1e-300, 1e-6):
        with pytest.raises(ValueError, match="crowd the samples"):
            weight_polynomials(s, "cubic", np.array([[0.0, 1.0, 2.0], [0.0, xi1, 1.0]]))
    big = np.vstack([np.linspace(0.0, 2.0, MAX_KNOTS + 1)] * 2)
    assert f"more than {MAX_KNOTS}" in coordinate_problem(s, big)
    assert "real numbers" in coordinate_problem(s, np.array([["0", "1"], ["0", "1"]]))


def test_hermite_weights_interpolate_values_and_slopes() -> None:
    """Hermite weights (equations.md §4.2): in σ they reproduce any cubic from its values
    and slopes at the samples (reference: the cubic); in a coordinate ξ(σ) they equal the
    cubic Hermite interpolant in ξ of scipy's ``CubicHermiteSpline`` with the slopes
    ``dX/dξ = X′/ξ′(s_i)`` (composition on fine knots, O(h⁴)); value weights sum to one and
    are the unit vectors at the samples, slope weights vanish there."""
    from scipy.interpolate import CubicHermiteSpline, PchipInterpolator

    from neweul_py.ffrf.parametric import ffrf_weights, weight_polynomials

    s = np.array([0.0, 0.5, 1.5, 2.0])
    k = s.size
    f, df = (lambda x: x**3 - 2 * x**2 + 0.3), (lambda x: 3 * x**2 - 4 * x)
    b, c = weight_polynomials(s, "hermite")
    assert c.shape == (4, k - 1, 2 * k)
    for x in (0.1, 0.7, 1.2, 1.99):
        w = ffrf_weights(b, c, x, "x")
        assert abs(w @ np.r_[f(s), df(s)] - f(x)) < 1e-13
        assert abs(w[:k].sum() - 1.0) < 1e-14
    for i, x in enumerate(s):
        w = ffrf_weights(b, c, x, "x")
        np.testing.assert_allclose(w, np.r_[np.eye(k)[i], np.zeros(k)], atol=1e-14)
    knots = np.unique(np.r_[np.linspace(0.0, 2.0, 201), s])
    xi = np.exp(knots)                              # ξ(σ) = e^σ
    b, c = weight_polynomials(s, "hermite", np.vstack([knots, xi]))
    dxi = PchipInterpolator(knots, xi).derivative()(s)
    ref = CubicHermiteSpline(np.exp(s), np.sin(s), np.cos(s) / dxi)
    for x in (0.1, 0.7, 1.2, 1.99):
        w = ffrf_weights(b, c, x, "x")
        assert abs(w @ np.r_[np.sin(s), np.cos(s)] - ref(np.exp(x))) < 1e-6


def test_quintic_hermite_weights_interpolate_values_slopes_and_curvatures() -> None:
    """Quintic Hermite weights (equations.md §4.2): in σ they reproduce any polynomial of
    degree ≤ 5 from its values, slopes and second derivatives at the samples (reference: the
    polynomial itself), are the unit vectors of the values at the samples, and their first
    and second derivatives there, from both sides, are the unit vectors of the slopes and
    curvatures (scipy's ``PPoly`` derivatives of the stored pieces). In a coordinate
    ξ(σ) = e^σ they reproduce a quadratic in ξ from data given in σ (chain rule
    ``X′ = ξ′ dX/dξ``,
    ``X″ = ξ″ dX/dξ + ξ′² d²X/dξ²``; composition on fine knots, O(h⁴))."""
    from scipy.interpolate import PPoly

    from neweul_py.ffrf.parametric import ffrf_weights, weight_polynomials

    s = np.array([-1.0, 0.2, 0.9, 2.0])
    k = s.size
    f = np.polynomial.Polynomial([0.3, -1.0, 0.5, 2.0, -0.7, 0.25])
    b, c = weight_polynomials(s, "quintic-hermite")
    assert c.shape == (6, k - 1, 3 * k)
    data = np.r_[f(s), f.deriv(1)(s), f.deriv(2)(s)]
    for x in (-0.9, 0.1, 0.55, 1.3, 1.99):
        w = ffrf_weights(b, c, x, "x")
        assert abs(w @ data - f(x)) < 1e-12 * max(1.0, abs(f(x)))
        assert abs(w[:k].sum() - 1.0) < 1e-13
    weights = PPoly(c, b)
    for i, x in enumerate(s):
        np.testing.assert_allclose(ffrf_weights(b, c, x, "x"), np.eye(3 * k)[i], atol=1e-14)
        for side in (-1e-13, 1e-13):                 # both pieces next to an inner sample
            if b[0] <= x + side <= b[-1]:
                np.testing.assert_allclose(weights(x + side, 1), np.eye(3 * k)[k + i],
                                           atol=1e-9)
                np.testing.assert_allclose(weights(x + side, 2), np.eye(3 * k)[2 * k + i],
                                           atol=1e-9)
    knots = np.unique(np.round(np.r_[np.linspace(-1.0, 2.0, 601), s], 12))
    b, c = weight_polynomials(s, "quintic-hermite", np.vstack([knots, np.exp(knots)]))
    g = np.polynomial.Polynomial([1.0, -0.4, 0.05])        # X = g(ξ), ξ = e^σ
    xs = np.exp(s)
    data = np.r_[g(xs), g.deriv(1)(xs) * xs, g.deriv(1)(xs) * xs + g.deriv(2)(xs) * xs**2]
    for x in (-0.9, 0.1, 0.55, 1.3, 1.99):
        w = ffrf_weights(b, c, x, "x")
        assert abs(w @ data - g(np.exp(x))) < 1e-6 * abs(g(np.exp(x))) + 1e-7
    with pytest.raises(ValueError, match="1 or 2 derivatives"):
        from neweul_py.ffrf.parametric import hermite_coefficients
        hermite_coefficients(s, 3)


def test_slope_working_form_is_the_linear_part() -> None:
    """``ffrf_slope_prepared`` of a body's flat arrays and a slope equals ``F(X + X′) −
    F(X)`` of the kernel's working form ``F`` (affine: the constant maps cancel), computed
    here with a unit step (reference: the difference itself, to round-off)."""
    import scipy.sparse as sps

    from neweul_py.elastic.fe_model import FEModel
    from neweul_py.elastic.reductors.invariants import compute_invariants
    from neweul_py.ffrf.body import ffrf_prepare
    from neweul_py.ffrf.parametric import ffrf_slope_prepared

    rng = np.random.default_rng(4)
    n, nq = 9, 3                                   # lumped mass points (tests/ffrf/test_body)
    x = rng.normal(size=(n, 3))
    ids = np.arange(1, n + 1)
    fe = FEModel(M=sps.diags(np.repeat(rng.uniform(0.5, 2.0, n), 3)).tocsr(),
                 K=sps.identity(3 * n, format="csr"), D=None, nodes=np.column_stack([ids, x]),
                 dof_node=np.repeat(ids, 3), dof_kind=np.tile(np.array(["ux", "uy", "uz"]), n))
    flat = compute_invariants(fe, rng.normal(size=(3 * n, nq)) * 0.3).to_flat()
    # a slope keeps the sample's zero pattern (as samples of one body share their flags)
    slope = {k: (1e-3 * rng.standard_normal(v.shape) * (v != 0) if isinstance(v, np.ndarray)
                 and v.dtype.kind == "f" else v) for k, v in flat.items()}
    got = ffrf_slope_prepared(ffrf_prepare, flat, slope)
    plus = ffrf_prepare({k: (v + slope[k] if isinstance(v, np.ndarray) and v.dtype.kind == "f"
                             else v) for k, v in flat.items()})
    base = ffrf_prepare(flat)
    for key in ("T0", "T1", "Me", "Ke", "G", "P", "P0"):
        np.testing.assert_allclose(got[key], plus[key] - base[key], rtol=0,
                                   atol=1e-12 * max(np.abs(plus[key]).max(), 1.0))
    assert not np.any(got["P"])


def test_mixing_keeps_what_does_not_vary_once() -> None:
    """Samples and their slopes interleaved (``orders`` 0, 1, …): an array equal in every
    sample with zero slopes is kept as the base only, one that varies as its columns; the
    mix equals ``Σ w_i X_i + Σ v_i X_i′`` for real and complex weights (reference: the
    explicit sum)."""
    rng = np.random.default_rng(5)
    k = 4
    const = rng.standard_normal((3, 3))
    rows = []
    for _ in range(k):
        value = {"mass": 1.5, "Me": const, "ks": rng.standard_normal(3)}
        slope = {"mass": 0.0, "Me": np.zeros((3, 3)), "ks": rng.standard_normal(3)}
        rows += [value, slope]
    orders = np.tile([0, 1], k)
    mixing = ffrf_stack(rows, None, orders, 3.0)
    assert mixing["index"].size == 3 and mixing["varying"].shape == (2 * k, 3)
    assert np.array_equal(mixing["base"][1:10], const.ravel())     # after the mass
    for w in (rng.standard_normal(2 * k), rng.standard_normal(2 * k) + 1e-30j):
        w = w.copy()
        w[0::2] /= w[0::2].real.sum()                   # the value weights sum to one
        got = ffrf_mix(mixing, w)
        for key in ("Me", "ks", "mass"):
            ref = sum(wi * r[key] for wi, r in zip(w, rows, strict=True))
            np.testing.assert_allclose(got[key], ref, rtol=1e-13, atol=1e-15)
