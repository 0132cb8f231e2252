"""Parameter-dependent elastic bodies: interpolation weights and mixed body data (§4, §2.3).

A parametric body holds ``k`` samples of its flat invariants in common coordinates (Panzer
et al. 2010, equations.md §4, steps 1–6) at the sample values ``s_1 < … < s_k`` of its
scheduling variable ``σ``. At every evaluation the body is ``X(σ) = Σ_i w_i(σ) X_i`` for
every stored array — the kernel's working form is linear in the arrays, so the samples are
prepared once and mixed (:func:`ffrf_mix`).

The weights are the cardinal functions of the interpolation, stored as piecewise cubic
polynomials ``w_i(σ) = Σ_m c[m, j, i] (σ − s_j)^(3−m)`` on interval ``j`` (the layout of
``scipy.interpolate.PPoly.c``): hat functions for ``linear``, the not-a-knot spline for
``cubic``; :func:`weight_coefficients` makes them (at generation time, with SciPy) and
:func:`ffrf_weights` evaluates them (NumPy only, complex-step differentiable). A value
outside ``[s_1, s_k]`` is an error naming the body, the value and the range: no
extrapolation.

Frozen-parameter assumption: the equations use ``X(σ(t))`` without the time derivatives of the
weights (the usual linear-parameter-varying reading of parametric reduced models), exact for
a constant ``σ`` and a good approximation while ``σ`` changes slowly against the body's
dynamics.
"""

from __future__ import annotations

import numpy as np

__all__ = ["PARAMETRIC_FUNCTIONS", "ffrf_mix", "ffrf_weights", "weight_coefficients"]


def weight_coefficients(samples: np.ndarray, interpolation: str) -> np.ndarray:
    """``c`` (4, k−1, k): the cardinal weight functions as piecewise cubics (module docstring).

    Parameters
    ----------
    samples
        Strictly increasing sample values (k ≥ 2).
    interpolation
        ``"linear"`` or ``"cubic"`` (not-a-knot; two samples give the linear weights).
    """
    s = np.asarray(samples, dtype=np.float64)
    k = s.size
    if interpolation == "linear" or k == 2:
        c = np.zeros((4, k - 1, k))
        h = np.diff(s)
        for j in range(k - 1):
            c[3, j, j], c[3, j, j + 1] = 1.0, 0.0
            c[2, j, j], c[2, j, j + 1] = -1.0 / h[j], 1.0 / h[j]
        return c
    from scipy.interpolate import CubicSpline

    return np.ascontiguousarray(CubicSpline(s, np.eye(k), bc_type="not-a-knot").c)


def ffrf_weights(samples, coefficients, value, name):
    """The weights ``w_i(σ)`` (k,) at ``value`` (real or complex; the interval from its real
    part). Raises ``ValueError`` naming the body ``name`` outside ``[s_1, s_k]``."""
    s = samples
    x = np.real(value)
    if not (s[0] <= x <= s[-1]):
        raise ValueError(f"elastic body {name!r}: schedule value {x:.6g} outside the sampled "
                         f"range [{s[0]:.6g}, {s[-1]:.6g}] (no extrapolation)")
    j = min(int(np.searchsorted(s, x, side="right")) - 1, s.size - 2)
    dx = value - s[j]
    c = coefficients[:, j, :]
    return ((c[0] * dx + c[1]) * dx + c[2]) * dx + c[3]


def ffrf_mix(samples, w):
    """``Σ_i w_i b_i`` of prepared samples (the numeric entries; the rest from sample 1)."""
    out = dict(samples[0])
    for key, value in samples[0].items():
        if isinstance(value, np.ndarray):
            out[key] = sum(wi * b[key] for wi, b in zip(w, samples, strict=True))
        elif key == "quad":                  # the extended body of a second-order field
            out[key] = ffrf_mix([b[key] for b in samples], w)
        elif key == "mass":                  # complex in the complex step in σ
            v = sum(wi * b[key] for wi, b in zip(w, samples, strict=True))
            out[key] = v if np.iscomplexobj(v) else float(v)
    return out


#: The functions a generated module embeds for parametric bodies.
PARAMETRIC_FUNCTIONS = (ffrf_weights, ffrf_mix)
