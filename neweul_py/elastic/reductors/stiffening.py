"""Stress stiffening of reduced bodies: geometric stiffness from FE files, checks, spin stiffness.

The floating-frame invariants carry the geometric stiffness ``K_G,c`` of the 12 unit inertia
load cases ``c`` (``reference/equations.md`` §2; Wallrapp 1994) in the first-order parts of
``Ct``, ``Cr`` and ``Oe``. The ``K_G,c`` come either from an element formulation the FE layer
knows (:meth:`neweul_py.fem.beam.BeamModel.stiffening`,
:meth:`neweul_py.fem.solid.SolidModel.stiffening`, :func:`neweul_py.fem.geometric.shell_stiffening`
— each runs :func:`~neweul_py.elastic.reductors.invariants.stress_stiffening`), or, for models built
elsewhere, from the optional ``KG.<case>`` group of the FE file
(:func:`~neweul_py.elastic.io.fe_files.read_stiffening`). This module checks them against the model
and the basis and attaches them (``neweul reduce … --stiffening``).
"""

from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np
import scipy.sparse as sps

from ...errors import DataError
from ..bodies.invariants import LOAD_CASES, Invariants, omega_products
from ..fe_model import FEModel
from ..io.fe_files import read_stiffening, read_stiffening_responses
from .invariants import attach_invariants
from .second_order import second_order_field

__all__ = ["attach_stiffening", "check_stiffening", "load_responses", "load_stiffening",
           "spin_stiffness"]


def check_stiffening(stiffening: Mapping[str, object], n_dofs: int,
                     source: str | None = None) -> dict[str, sps.csr_matrix]:
    """Validate ``K_G,c`` against a basis with ``n_dofs`` rows (the FE model's DOFs).

    Raises
    ------
    DataError
        Naming ``source`` and the item ``KG.<case>``: unknown case, a shape other than
        ``(n_dofs, n_dofs)``, NaN/Inf.
    """
    out = {}
    for case, A in stiffening.items():
        item = f"KG.{case}"
        if case not in LOAD_CASES:
            raise DataError(f"unknown load case {case!r} (one of {', '.join(LOAD_CASES)})",
                            source, item)
        A = sps.csr_matrix(A, dtype=np.float64)
        if A.shape != (n_dofs, n_dofs):
            raise DataError(f"stiffening matrix has shape {A.shape}, but the basis has "
                            f"{n_dofs} rows (the model's DOFs): expected ({n_dofs}, "
                            f"{n_dofs})", source, item)
        if not np.all(np.isfinite(A.data)):
            raise DataError("stiffening matrix has NaN/Inf entries", source, item)
        out[case] = A
    return out


def load_responses(path: str | os.PathLike, fe: FEModel) -> dict[str, np.ndarray]:
    """The static responses ``UG.<case>`` of the FE file ``path`` (``{}`` without them),
    checked against ``fe``'s DOF count."""
    out = read_stiffening_responses(path)
    for case, u in out.items():
        if u.shape != (fe.n_dofs,):
            raise DataError(f"static response has shape {u.shape}, the model has "
                            f"{fe.n_dofs} DOFs", str(path), f"UG.{case}")
    return out


def load_stiffening(path: str | os.PathLike, fe: FEModel) -> dict[str, sps.csr_matrix]:
    """The ``KG.<case>`` group of the FE file ``path``, checked against ``fe``.

    Raises
    ------
    DataError
        The file has no stiffening group, or it does not fit the model (file and item named).
    """
    KG = read_stiffening(path)
    if not KG:
        raise DataError("no geometric-stiffness matrices (KG.<case>) in the FE file: write "
                        "them with write_fe_model(…, stiffening=…) or build the model with "
                        "`neweul fem beam|solid-beam --stiffening`", str(path), "KG")
    return check_stiffening(KG, fe.n_dofs, str(path))


def attach_stiffening(body, fe: FEModel, stiffening: Mapping[str, object],
                      source: str | None = None, responses: Mapping[str, object] | None = None,
                      **kwargs):
    """``attach_invariants(body, fe, geometric_stiffness=…)`` after :func:`check_stiffening`
    against the body's full basis (``source`` is named in errors, default ``fe.source``).

    With the static ``responses`` ``u_c`` of the load cases (FE file group ``UG.<case>``) a
    Galerkin body (one-sided, or two-sided with ``W = V``: symmetric models) also gets its
    second-order displacement field
    (:func:`~neweul_py.elastic.reductors.second_order.second_order_field`, ``docs/equations.md``
    §2.3), which the kernel uses instead of the first-order stiffening terms."""
    src = fe.source if source is None else source
    n = fe.n_dofs if body.V is None else body.V.shape[0]
    if n != fe.n_dofs:
        raise DataError(f"the body's basis has {n} rows, the FE model {fe.n_dofs} DOFs", src,
                        "V")
    KG = check_stiffening(stiffening, n, src)
    out = attach_invariants(body, fe, geometric_stiffness=KG, **kwargs)
    if not responses:
        return out
    if not _galerkin(body):
        import warnings

        warnings.warn(f"{src}: the body is two-sided (W ≠ V), so its stiffening keeps the "
                      "first-order terms, not the second-order field of the static responses "
                      "(docs/equations.md §2.3; reduce with --one-sided for it)", stacklevel=2)
        return out
    field = second_order_field(fe, body.V, KG, responses, source=src)
    return out.with_(invariants={**out.invariants, **field.to_flat()})


def _galerkin(body) -> bool:
    """Whether the body's left basis is its right basis (to round-off): one-sided data, or
    the two-sided reduction of a symmetric FE model."""
    if not body.two_sided:
        return True
    V, W = body.V, body.W
    return W is not None and W.shape == V.shape and bool(
        np.abs(W - V).max() <= 1e-10 * max(float(np.abs(V).max()), 1e-300))


def spin_stiffness(inv: Invariants, omega: np.ndarray) -> np.ndarray:
    """``Ke + Σ_c ω_q[c] Oe¹[:, :, c]``: the elastic stiffness at a constant angular velocity.

    The linearization of the elastic rows of §2 about ``q = 0`` for a frame turning with the
    constant ``ω`` (no frame acceleration): centrifugal softening and, when the body holds
    geometric stiffening, stress stiffening (``Oe¹`` includes ``Wᵀ K_G,ωq V``). Gyroscopic
    (Coriolis) coupling ``Σ_k Ge_k ω`` is not included; the undamped frequencies of the
    modes it does not couple (e.g. flapwise bending of a blade spinning about its chord
    normal) are the eigenvalues of ``(spin_stiffness, Me)``.
    """
    wq = omega_products(np.asarray(omega, dtype=np.float64))
    K = inv.Ke.m0.copy()
    if inv.Oe.m1 is not None:
        K += np.einsum("ikc,c->ik", inv.Oe.m1, wq)
    return K
