"""The acousto-structural FE model of the tympanic membrane (TM), ear canal, tympanic cavity and
antrum/mastoid, the TM held by the stiffening ossicular chain — the public entry point.

The work is split by job (``docs/equations-middle-ear.md`` for the formulation):

* :mod:`~neweul_py.fem.ear_parameters` – the physical data (:class:`MiddleEarParameters`) and
  the validity limits;
* :mod:`~neweul_py.fem.ear_model` – geometry, meshes and constant matrices
  (:func:`build_middle_ear`), including the lumped antrum/mastoid behind the aditus;
* :mod:`~neweul_py.fem.ossicular_chain` – the rigid malleus on the chain's stiffening
  characteristic;
* :mod:`~neweul_py.fem.ear_static` – the nonlinear static state under Δp and its validity
  checks (:func:`solve_static`, :func:`static_validity`);
* :mod:`~neweul_py.fem.ear_working_point` – the linearized u–p model at a working point, its
  hysteretic damping and static data (:func:`working_point_model`);
* :mod:`~neweul_py.fem.ear_sweep` – the sweep driver (:func:`pressure_sweep`);
* :mod:`~neweul_py.fem.working_point_file` – the optional ``static``/``loss`` groups of the file;
* :mod:`~neweul_py.fem.ear_transfer` – frequency responses with the chain (checks).

Static load: ``Δp = p_canal − p_cavity``; ``Δp > 0`` pushes the TM medially, as a *negative
middle-ear pressure* does.
"""

from __future__ import annotations

from .ear_model import MiddleEar, build_middle_ear, support_stiffness
from .ear_parameters import (
    MAX_DISPLACEMENT_FRACTION,
    MAX_VOLUME_FRACTION,
    THIN_SHELL_RATIO,
    MiddleEarParameters,
)
from .ear_static import (
    ValidityBound,
    interface_forces,
    lowest_tangent_eigenvalue,
    malleus_coordinates,
    solve_static,
    static_summary,
    static_validity,
    support_at,
    tm_displacements,
)
from .ear_sweep import SweepResult, parse_pressures, pressure_sweep
from .ear_working_point import hysteretic_damping, static_data, working_point_model

__all__ = [
    "MAX_DISPLACEMENT_FRACTION",
    "MAX_VOLUME_FRACTION",
    "THIN_SHELL_RATIO",
    "MiddleEar",
    "MiddleEarParameters",
    "SweepResult",
    "ValidityBound",
    "build_middle_ear",
    "hysteretic_damping",
    "interface_forces",
    "lowest_tangent_eigenvalue",
    "malleus_coordinates",
    "parse_pressures",
    "pressure_sweep",
    "solve_static",
    "static_data",
    "static_summary",
    "static_validity",
    "support_at",
    "support_stiffness",
    "tm_displacements",
    "working_point_model",
]
