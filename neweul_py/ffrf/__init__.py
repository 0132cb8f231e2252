"""The floating-frame kernel: one NumPy-only home of the elastic-body equations.

Like :mod:`neweul_py.errors`, every layer may import it: ``elastic/`` writes data against
:mod:`.schema`, ``model/`` validates with it, :mod:`.body` holds the body equations
(``M_b(q)``, ``h_ω``, elastic forces, energies; equations.md §2) and :mod:`.splice` the
splice of bodies into the system equations, whose source the generated modules embed
(``codegen/elastic.py``). Nothing here imports sympy or another layer of the package.
"""

from __future__ import annotations

from .body import (
    KERNEL_FUNCTIONS,
    ffrf_body_mass,
    ffrf_elastic_forces,
    ffrf_kinetic_energy,
    ffrf_mass_blocks,
    ffrf_prepare,
    ffrf_strain_energy,
    ffrf_velocity_terms,
)
from .schema import (
    FIXED_ARRAYS,
    FLAT_FORMAT,
    INERTIA_FORMS,
    KERNEL_ARRAYS,
    SCHEMA,
    SCHEMA_VERSION,
    TAYLOR_NAMES,
    check_flat,
    frame_stiffening,
    mode_count,
)
from .splice import (
    MAX_BLOCK_CONDITION,
    PROTOCOL,
    SPLICE_FUNCTIONS,
    ffrf_add_force,
    ffrf_add_mass,
    ffrf_bodies,
    ffrf_cloud,
    ffrf_system,
    ffrf_terms,
)

__all__ = [
    "FIXED_ARRAYS",
    "FLAT_FORMAT",
    "INERTIA_FORMS",
    "KERNEL_ARRAYS",
    "KERNEL_FUNCTIONS",
    "MAX_BLOCK_CONDITION",
    "PROTOCOL",
    "SCHEMA",
    "SCHEMA_VERSION",
    "SPLICE_FUNCTIONS",
    "TAYLOR_NAMES",
    "check_flat",
    "ffrf_add_force",
    "ffrf_add_mass",
    "ffrf_bodies",
    "ffrf_body_mass",
    "ffrf_cloud",
    "ffrf_elastic_forces",
    "ffrf_kinetic_energy",
    "ffrf_mass_blocks",
    "ffrf_prepare",
    "ffrf_strain_energy",
    "ffrf_system",
    "ffrf_terms",
    "ffrf_velocity_terms",
    "frame_stiffening",
    "mode_count",
]
