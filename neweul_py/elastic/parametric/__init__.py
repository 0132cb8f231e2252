"""Parametric bodies: samples of a reduced body over a parameter (``docs/equations.md`` §4).

Two builders make the samples of a
:class:`~neweul_py.elastic.bodies.parametric.ParametricBody`:

* :mod:`~neweul_py.elastic.parametric.local_interpolation` – the local bodies brought to
  common coordinates (Panzer et al. 2010);
* :mod:`~neweul_py.elastic.parametric.global_basis` – one global basis for all samples (the
  local bases of all samples, or :mod:`~neweul_py.elastic.parametric.snapshot_basis`, a small
  basis from frequency-response snapshots);

:mod:`~neweul_py.elastic.parametric.samples` holds what both share: the checks of the samples,
their values, stacks and central differences (slopes and curvatures of Hermite weights).
"""

from .global_basis import global_parametric_body
from .local_interpolation import interpolate

__all__ = ["global_parametric_body", "interpolate"]
