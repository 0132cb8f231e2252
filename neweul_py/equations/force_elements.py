"""Generalized forces of the force elements (equations.md §1, "Force elements contribute
through the Jacobians of their points of action").

Each element derives its own loads (:meth:`~neweul_py.model.ForceElement.loads`, against the
kinematics); :func:`apply_force_element` adds them, times the element's ``enabled`` factor, to
the model's generalized forces, its hysteretic matrix and its reported quantities.

Loss factors (equations.md §1.1): an element with ``loss_factor`` η gets the viscous
equivalent ``(η/ω_ref) k_t`` of its tangent stiffness ``k_t`` on its own rate (in ``q − k``),
and adds ``η k_t`` to the hysteretic matrix ``G`` of ``K + iG`` — by construction
``G = −ω_ref ∂(q_loss)/∂ẏ`` of exactly those loss-equivalent forces: ``η k_t (∂s/∂y)ᵀ(∂s/∂y)``
for a spring–damper, ``η (c_jᵀ K_t c_k + J_R,jᵀ K_r J_R,k)`` for a bushing.
"""

from __future__ import annotations

import sympy as sp

from ..kinematics import Kinematics
from ..model import ForceElement
from ..model.algebra import total
from ..model.forces.loads import LossTerms

__all__ = ["LossTerms", "apply_force_element"]

Terms = list[list[sp.Expr]]


def apply_force_element(
    kin: Kinematics,
    fe: ForceElement,
    force_terms: Terms,
    loss: LossTerms | None = None,
    omega_ref: sp.Expr | float = 1.0,
) -> dict[str, sp.Expr]:
    """Add ``fe``'s generalized forces, times its ``enabled`` factor, to ``force_terms``.

    Parameters
    ----------
    loss, omega_ref
        Entries of the hysteretic matrix ``G`` to add to (times ``enabled``; module
        docstring) and the reference angular frequency ``ω_ref = 2π f_ref`` of the
        loss-equivalent viscous forces.

    Returns
    -------
    dict
        The reported quantities (:class:`~neweul_py.model.ForceOutput` components), also
        multiplied by ``enabled``.
    """
    loads = fe.loads(kin, omega_ref)
    enabled = fe.enabled
    for j in range(kin.n):
        if loads.generalized[j]:
            value = total(loads.generalized[j])
            force_terms[j].append(value if enabled == 1 else enabled * value)
    reported = loads.reported
    if enabled != 1:
        reported = {k: enabled * v for k, v in reported.items()}
    if loss is not None:
        for jk, items in loads.loss.items():
            value = total(items)
            loss.setdefault(jk, []).append(value if enabled == 1 else enabled * value)
    return reported
