"""The middle ear: the flagship application of neweul-py, built on :mod:`neweul_py.fem` and
:mod:`neweul_py.elastic` and never imported by them (``docs/architecture.md``).

The acousto-structural FE model of the tympanic membrane (TM), ear canal, tympanic cavity and
antrum/mastoid, the TM held by the stiffening ossicular chain, is split by job
(``docs/equations-middle-ear.md`` for the formulation, ``docs/middle-ear-data.md`` for the data):

* :mod:`~neweul_py.middle_ear.parameters` – the physical data (:class:`MiddleEarParameters`)
  and the validity limits;
* :mod:`~neweul_py.middle_ear.model` – geometry, meshes and constant matrices
  (:func:`build_middle_ear`), including the lumped antrum/mastoid behind the aditus;
* :mod:`~neweul_py.middle_ear.chain` – the rigid malleus on the chain's stiffening
  characteristic;
* :mod:`~neweul_py.middle_ear.static` – the nonlinear static state under Δp and its validity
  checks (:func:`solve_static`, :func:`static_validity`);
* :mod:`~neweul_py.middle_ear.working_point` – the linearized u–p model at a working point,
  its hysteretic damping, loss record and static data (:func:`working_point_model`);
* :mod:`~neweul_py.middle_ear.sweep` – the sweep driver (:func:`pressure_sweep`), written
  through :mod:`~neweul_py.middle_ear.output` (atomic directory, CSV tables) with the pictures
  of :mod:`~neweul_py.middle_ear.plots`;
* :mod:`~neweul_py.middle_ear.transfer` – frequency responses with the chain (checks);
  :mod:`~neweul_py.middle_ear.coupled` – the unreduced FE model coupled with a multibody chain.

A working point is written as an FE file with the optional ``static``/``loss`` groups of
:mod:`neweul_py.elastic.io.working_point`.

Static load: ``Δp = p_canal − p_cavity``; ``Δp > 0`` pushes the TM medially, as a *negative
middle-ear pressure* does.
"""

from __future__ import annotations

from .model import MiddleEar, build_middle_ear, support_stiffness
from .parameters import (
    MAX_DISPLACEMENT_FRACTION,
    MAX_VOLUME_FRACTION,
    THIN_SHELL_RATIO,
    MiddleEarParameters,
)
from .static import (
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
from .sweep import SweepResult, parse_pressures, pressure_sweep
from .working_point import hysteretic_damping, static_data, working_point_model

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
