"""Elastic bodies: FE models in, two-sided second-order model reduction out (DESIGN.md).

NumPy/SciPy only; never imports the symbolic layers.

* :class:`FEModel`, :func:`read_fe_model`, :func:`write_fe_model` – FE data and files;
* :func:`reduce_modal`, :func:`reduce_krylov`, :func:`reduce_craig_bampton` – reductors
  (functions model → reduced model), sharing :func:`project`;
* :mod:`~neweul_py.elastic.interface` – node sets and averaged (RBE3-like) interface frames;
  :mod:`~neweul_py.elastic.stiffening` – geometric stiffness from FE files, spin stiffness;
* :class:`ReducedBody` – the reduced body and its file format (``docs/reduced-body-format.md``);
* :func:`interpolate`, :class:`ParametricBody` – parametric reduction by matrix interpolation
  of local reduced bodies (``docs/equations.md`` §4);
* :mod:`~neweul_py.elastic.quality` – FRFs, errors, eigenvalue comparison, stability.
"""

from .craig_bampton import reduce_craig_bampton
from .fe_io import read_fe_model, read_node_sets, read_stiffening, write_fe_model
from .fe_model import DOF_KINDS, FE_KINDS, FEModel
from .interpolation import ParametricBody, load_parametric_body, save_parametric_body
from .krylov import reduce_krylov
from .local_interpolation import interpolate, kind_row_scale
from .modal import reduce_modal
from .projection import project
from .quality import (
    check_source,
    compare_eigenvalues,
    compare_frf,
    frf_full,
    frf_reduced,
    max_relative_error,
    relative_error,
    stability,
)
from .reduced_body import ReducedBody, load_reduced_body, save_reduced_body

__all__ = [
    "DOF_KINDS",
    "FE_KINDS",
    "FEModel",
    "ParametricBody",
    "ReducedBody",
    "check_source",
    "compare_eigenvalues",
    "compare_frf",
    "frf_full",
    "frf_reduced",
    "interpolate",
    "kind_row_scale",
    "load_parametric_body",
    "load_reduced_body",
    "max_relative_error",
    "project",
    "read_fe_model",
    "read_node_sets",
    "read_stiffening",
    "reduce_craig_bampton",
    "reduce_krylov",
    "reduce_modal",
    "relative_error",
    "save_parametric_body",
    "save_reduced_body",
    "stability",
    "write_fe_model",
]
