"""Reductors: FE model in, reduced body out (``docs/equations.md`` §2–3).

Basis generation apart from projection (pyMOR style): every reductor computes its right and
left bases ``V``, ``W`` and hands them to the one Petrov–Galerkin projection of
:mod:`~neweul_py.elastic.reductors.projection`.

* :mod:`~neweul_py.elastic.reductors.modal` – modal truncation, two- or one-sided, with
  static correction; :mod:`~neweul_py.elastic.reductors.eigen` – the sparse shift-invert
  eigensolvers of the (unsymmetric) pencil;
* :mod:`~neweul_py.elastic.reductors.krylov` – second-order Krylov (moment matching);
* :mod:`~neweul_py.elastic.reductors.craig_bampton` – clamped-interface reduction;
* :mod:`~neweul_py.elastic.reductors.invariants` – the floating-frame invariants of a basis;
  :mod:`~neweul_py.elastic.reductors.interface` – node sets and averaged interface frames;
  :mod:`~neweul_py.elastic.reductors.stiffening`,
  :mod:`~neweul_py.elastic.reductors.second_order` – geometric stiffening;
* :mod:`~neweul_py.elastic.reductors.static_state` – the static state of a working-point body.
"""

from .craig_bampton import reduce_craig_bampton
from .krylov import reduce_krylov
from .modal import reduce_modal
from .projection import project

__all__ = ["project", "reduce_craig_bampton", "reduce_krylov", "reduce_modal"]
