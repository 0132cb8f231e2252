"""Elastic bodies as plain, validated, immutable data (``docs/reduced-body-format.md``).

* :mod:`~neweul_py.elastic.bodies.reduced` – :class:`ReducedBody`, the reduced second-order
  model of one body (two-sided: ``W ≠ V``; one-sided: ``W = V``);
* :mod:`~neweul_py.elastic.bodies.parametric` – :class:`ParametricBody`, samples of a reduced
  body in common coordinates and their interpolation weights (``docs/equations.md`` §4);
* :mod:`~neweul_py.elastic.bodies.invariants` – :class:`Invariants`, the floating-frame
  invariants (``docs/equations.md`` §2), with :mod:`~neweul_py.elastic.bodies.taylor`;
* :mod:`~neweul_py.elastic.bodies.static` – :class:`StaticDeflection`, the static state a
  working-point body is linearized about.

Nothing here computes a body from an FE model (:mod:`neweul_py.elastic.reductors`) or reads
or writes a file (:mod:`neweul_py.elastic.io`).
"""

from .invariants import Invariants, NodeFrame, QuadraticField
from .parametric import ParametricBody
from .reduced import ReducedBody
from .static import StaticDeflection
from .taylor import Taylor

__all__ = ["Invariants", "NodeFrame", "ParametricBody", "QuadraticField", "ReducedBody",
           "StaticDeflection", "Taylor"]
