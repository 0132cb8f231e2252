"""Elastic bodies: FE models in, two-sided second-order reduced bodies out.

NumPy/SciPy only; never imports the symbolic layers (``docs/architecture.md``). Rooms by role:

* :mod:`~neweul_py.elastic.fe_model` – :class:`FEModel`, the full-order model (sparse ``M``,
  ``D``, ``K``, nodes, DOF map, inputs, outputs);
* :mod:`~neweul_py.elastic.bodies` – :class:`ReducedBody`, :class:`ParametricBody`, the
  floating-frame invariants and static states: plain, validated, immutable data;
* :mod:`~neweul_py.elastic.reductors` – :func:`reduce_modal`, :func:`reduce_krylov`,
  :func:`reduce_craig_bampton` sharing one :func:`project`; invariants, interfaces, stiffening;
* :mod:`~neweul_py.elastic.parametric` – parametric bodies by matrix interpolation
  (:func:`interpolate`, the global basis; ``docs/equations.md`` §4);
* :mod:`~neweul_py.elastic.io` – FE files, body files (``docs/reduced-body-format.md``), SID;
* :mod:`~neweul_py.elastic.quality.measures` – FRFs, errors, eigenvalue comparison, stability.
"""

from .bodies.parametric import ParametricBody
from .bodies.reduced import ReducedBody
from .fe_model import DOF_KINDS, FE_KINDS, FEModel
from .io.body_files import (
    load_parametric_body,
    load_reduced_body,
    save_parametric_body,
    save_reduced_body,
)
from .io.fe_files import read_fe_model, read_node_sets, read_stiffening, write_fe_model
from .parametric.local_interpolation import interpolate, kind_row_scale
from .quality.measures import (
    check_source,
    compare_eigenvalues,
    compare_frf,
    frf_full,
    frf_reduced,
    max_relative_error,
    relative_error,
    stability,
)
from .reductors.craig_bampton import reduce_craig_bampton
from .reductors.krylov import reduce_krylov
from .reductors.modal import reduce_modal
from .reductors.projection import project

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
