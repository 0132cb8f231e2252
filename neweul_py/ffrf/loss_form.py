"""The loss-factor form of the frequency domain (docs/equations.md §1.1): one rule for every layer.

A model with loss factors carries a hysteretic matrix ``G`` (``K + iG`` in the frequency
domain) and, in its time-domain damping ``D``, the viscous equivalent ``G/ω_ref`` that is exact
at the reference frequency ``f_ref``. The frequency-domain solvers (FE models, reduced and
parametric bodies, linearized generated modules) therefore solve

    K + iG + jω (D − G/ω_ref) − ω² M,

i.e. they see the stiffness ``K + iG`` and the damping ``D − G/ω_ref``
(:func:`loss_form`). ``"viscous"`` keeps ``K`` and ``D``: the time-domain model itself. The
two agree at ``ω = ω_ref``.

Plain arithmetic on arrays or SciPy sparse matrices (NumPy only, like the rest of the kernel).
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["DAMPING_FORMS", "loss_form"]

#: Damping forms of the frequency domain: ``"loss"`` (``K + iG`` where the model has a
#: hysteretic matrix ``G``) and ``"viscous"`` (its time-domain equivalent in ``D``).
DAMPING_FORMS = ("loss", "viscous")


def loss_form(K: Any, D: Any, G: Any, f_ref: float) -> tuple[Any, Any]:
    """Stiffness and damping of the loss-factor form: ``(K + iG, D − G/ω_ref)``.

    Parameters
    ----------
    K, D, G
        Stiffness, time-domain damping (containing ``G/ω_ref``) and hysteretic matrix: NumPy
        arrays or SciPy sparse matrices of one shape.
    f_ref
        Reference frequency [Hz] of the time-domain equivalent, ``ω_ref = 2π f_ref``.

    Returns
    -------
    (K_loss, D_loss)
        ``K + iG`` (complex) and ``D − G/ω_ref``: ``K_loss + jω D_loss − ω² M`` is
        ``K + iG + jω (D − G/ω_ref) − ω² M`` (docs/equations.md §1.1).
    """
    w_ref = 2 * math.pi * float(f_ref)
    return K + 1j * G, D - G / w_ref
