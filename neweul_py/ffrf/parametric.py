"""Parameter-dependent elastic bodies: interpolation weights and mixed body data (§4, §2.3).

A parametric body holds ``k`` samples of its flat invariants in common coordinates (Panzer
et al. 2010, equations.md §4, steps 1–6) at the sample values ``s_1 < … < s_k`` of its
scheduling variable ``σ``. At every evaluation the body is ``X(σ) = Σ_i w_i(σ) X_i`` for
every stored array — the kernel's working form is linear in the arrays, so the samples are
prepared once, their arrays stacked into one matrix ``B`` (k, N) (:func:`ffrf_stack`, one row
per sample, every array of the body flattened into the columns) and kept as its base and the
columns that vary over the samples (:mod:`.varying`), and each evaluation mixes them with
**one** matrix product ``w B`` of those columns (:func:`ffrf_mix`; the arrays of the mixed
body are views into that one result): no loop over samples or arrays doing arithmetic.

The weights are the cardinal functions of the interpolation, stored as piecewise cubic
polynomials ``w_i(σ) = Σ_m c[m, j, i] (σ − b_j)^(3−m)`` on interval ``j`` of the breakpoints
``b`` (the layout of ``scipy.interpolate.PPoly.c``): hat functions for ``linear``, the
not-a-knot spline for ``cubic``; :func:`weight_polynomials` makes them (at generation time,
with SciPy) and :func:`ffrf_weights` evaluates them (NumPy only, complex-step
differentiable). A value outside ``[b_1, b_n] = [s_1, s_k]`` is an error naming the body, the
value and the range: no extrapolation.

**Interpolation coordinate** (equations.md §4.1). The cubic weights may be taken in a
coordinate ``ξ(σ)`` other than ``σ`` itself: ``w_i(σ) = S_i(ξ(σ))`` with ``S_i`` the cardinal
not-a-knot splines through ``ξ_i = ξ(s_i)``. ``ξ`` is given as a table ``(σ_j, ξ_j)``,
strictly monotone, whose knots ``σ_j`` include every sample value and span exactly
``[s_1, s_k]``; between the knots ``ξ`` is the shape-preserving PCHIP interpolant of the table.
The stored weights are the piecewise cubic Hermite interpolants on the knots of the exact
values ``S_i(ξ_j)`` and slopes ``S_i′(ξ_j) ξ′(σ_j)`` (an O(h⁴) approximation of the
composition for knot spacing ``h``): still cubic, so the generated module evaluates them as
before; they sum to one (``Σ S_i ≡ 1``, ``Σ S_i′ ≡ 0``) and are the unit vectors at the
samples.

**Sample slopes** (equations.md §4.2). With ``hermite`` weights every sample also carries
its slope ``X_i′ = dX/dσ(s_i)`` and the body is ``X(σ) = Σ_i w_i(σ) X_i + Σ_i v_i(σ) X_i′``:
the piecewise cubic Hermite interpolant in ``ξ`` (``ξ = σ`` without a coordinate) through the
values and the slopes ``dX/dξ = X_i′/ξ′(s_i)`` at the samples. The ``2k`` weights
``[w; v]`` are the columns of one coefficient array, so the module mixes ``[X_i; X_i′]``
with the same one product; ``w_i``, ``v_i`` vanish outside the two intervals next to
``s_i`` (no global coupling), ``Σ w_i ≡ 1``, and the slopes enter through the *linear* part
of the kernel's working form only (:func:`ffrf_slope_form`). ``quintic-hermite`` weights
also interpolate the sample curvatures ``X_i″ = d²X/dσ²(s_i)``: the piecewise quintic Hermite
interpolant (C², error O(h⁶) against O(h⁴)), ``3k`` weights ``[w; v; u]`` mixing
``[X_i; X_i′; X_i″]``, stored as quintic pieces ((6, n−1, 3k); :func:`ffrf_weights`
evaluates any degree). In a coordinate ``ξ`` the curvatures convert with ``ξ″`` too
(:func:`weight_polynomials`), and the composed weights are stored as cubic Hermite pieces on
the knots as above (C¹ in ``σ``, O(h⁴) in the knot spacing).

Frozen-parameter assumption: the equations use ``X(σ(t))`` without the time derivatives of the
weights (the usual linear-parameter-varying reading of parametric reduced models), exact for
a constant ``σ`` and a good approximation while ``σ`` changes slowly against the body's
dynamics.
"""

from __future__ import annotations

import numpy as np

from .varying import (
    VARYING_TOLERANCE,
    entry_scale,
    ffrf_derived,
    mirror_varying,
    scale_varying,
    split_varying,
)

__all__ = ["HERMITE_ORDERS", "PARAMETRIC_FUNCTIONS", "coordinate_problem", "ffrf_mix",
           "ffrf_slope_form", "ffrf_slope_prepared", "ffrf_stack", "ffrf_unmix", "ffrf_weights",
           "hermite_coefficients", "slope_step", "weight_coefficients", "weight_polynomials"]


#: The Hermite weights and how many derivatives of the samples they interpolate: the
#: sample slopes ``X_i′`` (cubic), and the slopes and curvatures ``X_i″`` (quintic).
HERMITE_ORDERS = {"hermite": 1, "quintic-hermite": 2}


def weight_coefficients(samples: np.ndarray, interpolation: str) -> np.ndarray:
    """``c`` (d+1, k−1, ·): the cardinal weight functions as piecewise polynomials of degree
    ``d`` (module docstring; 3, and 5 for ``quintic-hermite``).

    Parameters
    ----------
    samples
        Strictly increasing sample values (k ≥ 2).
    interpolation
        ``"linear"``, ``"cubic"`` (not-a-knot; two samples give the linear weights),
        ``"hermite"`` (:func:`hermite_coefficients`: (4, k−1, 2k)) or ``"quintic-hermite"``
        ((6, k−1, 3k)).
    """
    s = np.asarray(samples, dtype=np.float64)
    k = s.size
    if interpolation in HERMITE_ORDERS:
        return hermite_coefficients(s, HERMITE_ORDERS[interpolation])
    if interpolation == "linear" or k == 2:
        c = np.zeros((4, k - 1, k))
        h = np.diff(s)
        for j in range(k - 1):
            c[3, j, j], c[3, j, j + 1] = 1.0, 0.0
            c[2, j, j], c[2, j, j + 1] = -1.0 / h[j], 1.0 / h[j]
        return c
    from scipy.interpolate import CubicSpline

    return np.ascontiguousarray(CubicSpline(s, np.eye(k), bc_type="not-a-knot").c)


def hermite_coefficients(samples: np.ndarray, derivatives: int = 1) -> np.ndarray:
    """The Hermite basis on the samples (module docstring), columns in blocks of ``k``.

    ``derivatives = 1``: ``c`` (4, k−1, 2k), the cubic Hermite basis — columns ``0…k−1``
    the value weights ``w_i`` (``w_i(s_j) = δ_ij``, ``w_i′(s_j) = 0``), columns ``k…2k−1``
    the slope weights ``v_i`` (``v_i(s_j) = 0``, ``v_i′(s_j) = δ_ij``). ``derivatives = 2``:
    ``c`` (6, k−1, 3k), the quintic Hermite basis (equations.md §4.2), with a third block of
    curvature weights ``u_i`` (``u_i″(s_j) = δ_ij``, value and slope zero at every sample;
    the other blocks have zero second derivatives at the samples)."""
    s = np.asarray(samples, dtype=np.float64)
    k = s.size
    h = np.diff(s)[:, None]
    unit = [np.hstack([np.eye(k) if b == a else np.zeros((k, k))
                       for b in range(derivatives + 1)]) for a in range(derivatives + 1)]
    if derivatives == 1:
        return _hermite_pieces(unit[0], unit[1], h)
    if derivatives == 2:
        return _quintic_pieces(unit[0], unit[1], unit[2], h)
    raise ValueError(f"Hermite weights with 1 or 2 derivatives, not {derivatives!r}")


def _hermite_pieces(y: np.ndarray, m: np.ndarray, h: np.ndarray) -> np.ndarray:
    """The cubic pieces (4, n−1, ·) with values ``y`` and slopes ``m`` (n, ·) at breakpoints
    ``h = diff(b)[:, None]`` apart."""
    dy = (y[1:] - y[:-1]) / h
    c = np.empty((4, h.shape[0], y.shape[1]))
    c[0] = (m[:-1] + m[1:] - 2.0 * dy) / h**2
    c[1] = (3.0 * dy - 2.0 * m[:-1] - m[1:]) / h
    c[2], c[3] = m[:-1], y[:-1]
    return np.ascontiguousarray(c)


def _quintic_pieces(y: np.ndarray, m: np.ndarray, a: np.ndarray, h: np.ndarray
                    ) -> np.ndarray:
    """The quintic pieces (6, n−1, ·) with values ``y``, slopes ``m`` and second derivatives
    ``a`` (n, ·) at breakpoints ``h = diff(b)[:, None]`` apart: on each piece
    ``p(x) = y₀ + m₀x + a₀x²/2 + c₂x³ + c₁x⁴ + c₀x⁵``, the top three coefficients from the
    conditions at ``x = h`` (the standard quintic Hermite solve)."""
    y0, y1, m0, m1, a0, a1 = y[:-1], y[1:], m[:-1], m[1:], a[:-1], a[1:]
    # residuals of the quadratic Taylor part at x = h: value, slope, second derivative
    r0 = y1 - (y0 + m0 * h + 0.5 * a0 * h**2)
    r1 = m1 - (m0 + a0 * h)
    r2 = a1 - a0
    c = np.empty((6, h.shape[0], y.shape[1]))
    c[2] = (10.0 * r0 - 4.0 * r1 * h + 0.5 * r2 * h**2) / h**3
    c[1] = (-15.0 * r0 + 7.0 * r1 * h - r2 * h**2) / h**4
    c[0] = (6.0 * r0 - 3.0 * r1 * h + 0.5 * r2 * h**2) / h**5
    c[3], c[4], c[5] = 0.5 * a0, m0, y0
    return np.ascontiguousarray(c)


#: Most knots of an interpolation coordinate (the cap of ``neweul fem --static-curve`` too):
#: the generated module embeds (4, n−1, k) weight coefficients.
MAX_KNOTS = 10_001
#: Largest Lebesgue constant ``max_σ Σ_i |w_i(σ)|`` of coordinate weights (at the knots and
#: 7 points inside each piece): a
#: coordinate whose values crowd some samples together amplifies the sample data by more.
MAX_LEBESGUE = 100.0


def coordinate_problem(samples: np.ndarray, coordinate: np.ndarray) -> str | None:
    """What is wrong with an interpolation coordinate table (module docstring), or ``None``.

    ``coordinate`` (2, n): knots ``σ_j`` (row 0) and coordinate values ``ξ_j`` (row 1)."""
    c = np.asarray(coordinate)
    if c.ndim != 2 or c.shape[0] != 2 or c.shape[1] < 2:
        return f"must be a (2, n ≥ 2) table of knots and values, got shape {c.shape}"
    if c.dtype.kind not in "fi":
        return f"must hold real numbers, got dtype {c.dtype}"
    if c.shape[1] > MAX_KNOTS:
        return f"has {c.shape[1]} knots, more than {MAX_KNOTS}"
    if not np.all(np.isfinite(c)):
        return "holds a value that is not a finite number"
    knots, xi = c.astype(np.float64)
    s = np.asarray(samples, dtype=np.float64)
    if np.any(np.diff(knots) <= 0):
        return "its knots (row 0) must be strictly increasing"
    if knots[0] != s[0] or knots[-1] != s[-1]:
        return (f"its knots must span the samples' range [{s[0]!r}, {s[-1]!r}] exactly, "
                f"got [{knots[0]!r}, {knots[-1]!r}]")
    absent = [float(v) for v in s if v not in knots]
    if absent:
        return f"its knots must include every sample value; missing {absent}"
    d = np.diff(xi)
    if not (np.all(d > 0) or np.all(d < 0)):
        return "its values (row 1) must be strictly monotone in the knots"
    return None


def weight_polynomials(samples: np.ndarray, interpolation: str,
                       coordinate: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(b, c)``: the breakpoints (n,) and the coefficients (d+1, n−1, k, 2k or 3k) of the
    weights (``d`` = 5 for quintic Hermite weights without a coordinate, 3 otherwise).

    Without ``coordinate``: ``b`` = the samples, ``c`` = :func:`weight_coefficients`. With a
    coordinate table (2, n) (cubic or Hermite weights; module docstring): ``b`` = its knots
    and ``c`` the cubic Hermite pieces of ``S_i(ξ(σ))`` — for ``hermite`` of the value
    weights ``H_i(ξ(σ))`` and the slope weights ``H̄_i(ξ(σ))/ξ′(s_i)`` (slopes in ``σ``), for
    ``quintic-hermite`` of the quintic basis with slopes and curvatures in ``σ``
    (:func:`_hermite_in_coordinate`).

    Raises
    ------
    ValueError
        A coordinate with linear weights, a coordinate table that
        :func:`coordinate_problem` refuses, or weights whose Lebesgue constant at the knots
        exceeds :data:`MAX_LEBESGUE` (values that crowd some samples together).
    """
    s = np.asarray(samples, dtype=np.float64)
    if coordinate is None:
        return s.copy(), weight_coefficients(s, interpolation)
    if interpolation not in ("cubic", *HERMITE_ORDERS):
        raise ValueError("an interpolation coordinate needs cubic or Hermite weights")
    why = coordinate_problem(s, coordinate)
    if why is not None:
        raise ValueError(f"interpolation coordinate: {why}")
    from scipy.interpolate import CubicSpline, PchipInterpolator, PPoly

    knots, xi = np.asarray(coordinate, dtype=np.float64)
    if xi[-1] < xi[0]:                       # a decreasing coordinate: the same weights
        xi = -xi
    slope = PchipInterpolator(knots, xi).derivative()(knots)
    at = np.searchsorted(knots, s)           # the samples' knots
    xs = xi[at]                              # ξ at the samples
    k = s.size
    with np.errstate(all="ignore"):          # crowded values: refused below
        if interpolation == "cubic":
            spline = CubicSpline(xs, np.eye(k), bc_type="not-a-knot")
        else:
            spline = PPoly(_hermite_in_coordinate(xs, s, np.array([knots, xi]), slope[at],
                                                  interpolation), xs)
        blocks = spline.c.shape[2] // k              # 1, 2 or 3: values, slopes, curvatures
        unit = np.hstack([np.eye(k)] + [np.zeros((k, k))] * (blocks - 1))
        y = spline(xi)                           # (n, ·): S_i(ξ_j); unit rows at the samples
        y[at] = unit
        m = spline(xi, 1) * slope[:, None]       # S_i′(ξ_j) ξ′(σ_j)
        if blocks > 1:
            m[at] = np.roll(unit, k, axis=1)     # the slope weights' unit slopes in σ
        h = np.diff(knots)[:, None]
        c = _hermite_pieces(y, m, h)
        t = (np.arange(1, 8) / 8.0)[:, None, None] * h[None]     # 7 points inside each piece
        inside = ((c[0] * t + c[1]) * t + c[2]) * t + c[3]
    lebesgue = float(np.max(np.r_[np.abs(y[:, :k]).sum(axis=1),
                                  np.abs(inside[:, :, :k]).sum(axis=2).ravel()]))
    if not (lebesgue <= MAX_LEBESGUE and np.all(np.isfinite(c))):    # NaN, inf too
        raise ValueError(f"interpolation coordinate: its values crowd the samples (the weights "
                         f"reach a Lebesgue constant of {lebesgue:.3g} > {MAX_LEBESGUE:g}); "
                         "use a coordinate that spaces the samples more evenly")
    return knots.copy(), c


def _hermite_in_coordinate(xs: np.ndarray, samples: np.ndarray, coordinate: np.ndarray,
                           slope: np.ndarray, interpolation: str) -> np.ndarray:
    """The Hermite basis in ``ξ`` on the samples' values ``xs`` for data given in ``σ``
    (equations.md §4.2): with ``Y_i = dX/dξ = X_i′/ξ′`` and
    ``Z_i = d²X/dξ² = X_i″/ξ′² − ξ″ X_i′/ξ′³`` at ``s_i``, the weight of ``X_i′`` is
    ``H¹_i/ξ′ − H²_i ξ″/ξ′³`` and that of ``X_i″`` is ``H²_i/ξ′²``. ``slope``: ``ξ′(s_i)`` of
    the PCHIP interpolant of the table (the cubic Hermite weights, as stored since format 4);
    the quintic ones take ``ξ′`` and ``ξ″`` at the samples from the not-a-knot cubic spline
    of the table ``coordinate`` = ``(σ_j, ξ_j)`` (PCHIP has no second derivative there)."""
    from scipy.interpolate import CubicSpline

    k = xs.size
    c = hermite_coefficients(xs, HERMITE_ORDERS[interpolation])
    if interpolation == "hermite":
        c[:, :, k:] /= slope
        return c
    table = CubicSpline(coordinate[0], coordinate[1], bc_type="not-a-knot")
    d1, d2 = table(samples, 1), table(samples, 2)
    c1, c2 = c[:, :, k:2 * k].copy(), c[:, :, 2 * k:].copy()
    c[:, :, k:2 * k] = c1 / d1 - c2 * d2 / d1**3
    c[:, :, 2 * k:] = c2 / d1**2
    return c


def ffrf_weights(samples, coefficients, value, name):
    """The weights ``w_i(σ)`` (k,) at ``value`` (real or complex; the interval from its real
    part). ``samples``: the breakpoints of :func:`weight_polynomials` (the sample values, or
    the knots of an interpolation coordinate). Raises ``ValueError`` naming the body
    ``name`` outside ``[s_1, s_k]``."""
    s = samples
    x = np.real(value)
    if not (s[0] <= x <= s[-1]):
        raise ValueError(f"elastic body {name!r}: schedule value {float(x)!r} outside the "
                         f"sampled range [{float(s[0])!r}, {float(s[-1])!r}] (no extrapolation)")
    j = min(int(np.searchsorted(s, x, side="right")) - 1, s.size - 2)
    dx = value - s[j]
    c = coefficients[:, j, :]
    w = c[0]
    for row in c[1:]:                         # Horner, any degree (cubic, quintic)
        w = w * dx + row
    return w


def ffrf_stack(samples, extra=None, orders=None, span=1.0, tol=VARYING_TOLERANCE):
    """The mixing form of prepared samples: ``{"base", "base_rows", "index", "varying",
    "mirror", "scaled", "layout", "template"}``, the stack ``B`` (k, N) of their entries
    stored as the entries that do not vary and those that do
    (:func:`~neweul_py.ffrf.varying.split_varying`),
    of the square matrices' entries below the diagonal that equal their transposed entry only
    those (:func:`~neweul_py.ffrf.varying.mirror_varying`), of a matrix that is a factor times
    another only the factor (:func:`~neweul_py.ffrf.varying.scale_varying`).

    Every numeric entry of the sample dicts (arrays, the mass, the arrays of a nested
    ``quad`` body of a second-order field) becomes a column block of ``B``; ``layout`` lists
    ``(path, start, stop, shape)`` per entry and ``template`` holds the rest (sizes, flags,
    slices) from sample 1. ``extra`` (optional): more arrays per sample, ``name → (k, …)``,
    stacked after them (the node rows ``S_V,i``, ``S_W,i`` of the splice). ``orders``
    (k,), optional: per row of ``B`` 0 for a sample's values, 1 for its slopes, 2 for its
    curvatures (default all 0); ``span``: the sampled range. A column is stored as varying
    when a row deviates from the base (the first sample's value, zero for derivatives) by
    more than ``tol · span^−order`` times the entry's scale
    (:func:`~neweul_py.ffrf.varying.entry_scale` of the values of its array)."""
    layout, columns, scales, start = [], [], [], 0
    orders = (np.zeros(len(samples), dtype=np.int64) if orders is None
              else np.asarray(orders, dtype=np.int64))
    values = orders == 0

    def add(path, block):
        nonlocal start
        shape = block.shape[1:]
        size = int(np.prod(shape, dtype=np.int64))
        layout.append((path, start, start + size, shape))
        columns.append(block.reshape(block.shape[0], size))
        scales.append(entry_scale(block[values]).reshape(size))
        start += size

    def walk(path, entries):
        for key, value in entries[0].items():
            if key == "quad":                 # the extended body of a second-order field
                walk((*path, key), [e[key] for e in entries])
            elif isinstance(value, np.ndarray) or key == "mass":
                add((*path, key), np.stack([np.asarray(e[key], dtype=np.float64)
                                            for e in entries]))

    walk((), samples)
    for key, block in (extra or {}).items():
        add((key,), np.asarray(block, dtype=np.float64))
    template = {k: v for k, v in samples[0].items()
                if not (isinstance(v, np.ndarray) or k == "mass")}
    base_rows = values.astype(np.float64)
    row_scale = float(span) ** -orders.astype(np.float64)
    scale = np.concatenate(scales)
    stack = np.hstack(columns)
    columns.clear()
    base, index, varying = split_varying(stack, scale, base_rows=base_rows,
                                         row_scale=row_scale, tol=tol)
    square = [(i, shape[0]) for _path, i, _j, shape in layout
              if len(shape) == 2 and shape[0] == shape[1] > 1]
    index, varying, mirror = mirror_varying(index, varying, square, tol * scale, row_scale)
    index, varying, mirror, scaled = scale_varying(
        stack, base, base_rows, index, varying, mirror,
        [(i, j) for _path, i, j, shape in layout if len(shape) == 2 and j - i > 1],
        tol * scale, row_scale)
    return {"base": base, "base_rows": base_rows, "index": index, "varying": varying,
            "mirror": mirror, "scaled": scaled, "layout": tuple(layout),
            "template": template}


def ffrf_mix(mixing, w):
    """``Σ_i w_i b_i``: the body of the weights ``w`` (k,) from :func:`ffrf_stack`'s form:
    ``(w·r) base`` with the varying entries ``w V`` (one product; for complex ``w``, the
    complex step in ``σ``, one product each for the real and the imaginary part, so ``V`` is
    never copied to complex; weights that vanish outside a narrow band of rows — linear
    ones, and Hermite ones with the rows of samples and slopes interleaved — use that band
    only, a view); the arrays are views into the result, the other entries those of
    sample 1."""
    V, r = mixing["varying"], mixing["base_rows"]
    nz = np.flatnonzero(w)
    if nz.size and 2 * (nz[-1] + 1 - nz[0]) <= w.size:    # local weights: their rows (a view)
        V, r, w = V[nz[0]:nz[-1] + 1], r[nz[0]:nz[-1] + 1], w[nz[0]:nz[-1] + 1]
    flat = (w @ r) * mixing["base"]
    flat[mixing["index"]] = w @ V if not np.iscomplexobj(w) else (w.real @ V) + 1j * (w.imag @ V)
    ffrf_derived(flat, mixing.get("mirror"), mixing.get("scaled"))   # the copied entries
    return ffrf_unmix(mixing, flat)


def ffrf_unmix(mixing, flat):
    """The body of the mixed values ``flat = w B`` (N,) of :func:`ffrf_stack`'s form: its
    arrays as views into ``flat`` (by the form's ``layout``), the other entries those of
    sample 1 (its ``template``)."""
    out = dict(mixing["template"])
    if "quad" in out:
        out["quad"] = dict(out["quad"])
    for path, i, j, shape in mixing["layout"]:
        target = out
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = flat[i:j].reshape(shape) if shape else flat[i]
    return out


def slope_step(sample, slope):
    """``τ`` for :func:`ffrf_slope_form`: the power of two nearest to
    ``max|X_i| / max|X_i′|`` over the float arrays of a sample and its slope (so that
    ``X_i + τ X_i′`` changes every array at the scale of its values; 1 for a zero slope)."""
    def peak(flat):
        return max((float(np.max(np.abs(v), initial=0.0)) for v in flat.values()
                    if isinstance(v, np.ndarray) and v.dtype.kind == "f"), default=0.0)
    a, b = peak(sample), peak(slope)
    return 1.0 if a == 0.0 or b == 0.0 else float(2.0 ** np.round(np.log2(a / b)))


def ffrf_slope_form(prepared, shifted, tau):
    """The working form of a sample slope ``X_i′``: ``(F(X_i + τ X_i′) − F(X_i)) / τ`` entry
    by entry, ``F`` the kernel's working form (``prepared`` = ``F(X_i)``, ``shifted`` =
    ``F(X_i + τ X_i′)``, :func:`slope_step`). ``F`` is affine in the arrays (constant maps such
    as ``P``, the mass column of ``P0``), so this is exactly its linear part, which is what
    multiplies a slope weight (module docstring), with the flags and layout of the sample;
    entries that are not numeric are those of ``prepared``."""
    out = dict(prepared)
    for key, value in prepared.items():
        if isinstance(value, dict) and key != "where":
            out[key] = ffrf_slope_form(value, shifted[key], tau)
        elif isinstance(value, np.ndarray) and value.dtype.kind == "f":
            out[key] = (shifted[key] - value) / tau
        elif key == "mass":
            out[key] = (float(shifted[key]) - float(value)) / tau
    return out


def ffrf_slope_prepared(prepare, sample, slope, *args):
    """The working form of the slope ``slope`` of ``sample`` (both flat arrays):
    :func:`ffrf_slope_form` of ``prepare(sample, *args)`` and of the sample shifted by
    ``τ`` times its slope (:func:`slope_step`)."""
    tau = slope_step(sample, slope)
    shifted = {k: (v + tau * np.asarray(slope[k], dtype=np.float64)
                   if isinstance(v, np.ndarray) and v.dtype.kind == "f" else v)
               for k, v in sample.items()}
    return ffrf_slope_form(prepare(sample, *args), prepare(shifted, *args), tau)


#: The functions a generated module embeds for parametric bodies.
PARAMETRIC_FUNCTIONS = (ffrf_weights, ffrf_stack, ffrf_mix, ffrf_unmix, slope_step,
                        ffrf_slope_form, ffrf_slope_prepared)
