"""fem layer: small acousto-structural FE builders (see DESIGN.md) — NumPy/SciPy/scikit-fem only.

Modules, one concern each (scikit-fem style: mesh, element, assembly, form apart):

* :mod:`~neweul_py.fem.mesh` – geometry and meshes generated in code (disc/cone, extrusions, box);
* :mod:`~neweul_py.fem.acoustic` – linear acoustic pressure elements (``Mf``, ``Kf``);
* :mod:`~neweul_py.fem.shell` – the TL St. Venant–Kirchhoff facet shell of the TM (CST membrane +
  rotation-free bending, follower pressure);
* :mod:`~neweul_py.fem.beam` – Euler–Bernoulli / Timoshenko beams (2-D, 3-D) with their
  geometric stiffness; :mod:`~neweul_py.fem.solid` – Hex8/Hex20/Tet10 solid boxes and the
  initial-stress matrix; :mod:`~neweul_py.fem.geometric` – stress stiffness of the shell;
* :mod:`~neweul_py.fem.assembly` – vectorized assembly of element arrays;
* :mod:`~neweul_py.fem.coupling` – the coupling matrix ``C`` and the u–p matrices of Eq. (2);
* :mod:`~neweul_py.fem.nonlinear` – Newton's method with adaptive load stepping;
* :mod:`~neweul_py.fem.middle_ear` – the public entry of the middle-ear model (TM + ear canal +
  tympanic cavity + antrum/mastoid, the TM held by the ossicular chain), split by job into
  :mod:`~neweul_py.fem.ear_parameters` (data), :mod:`~neweul_py.fem.ear_model` (meshes,
  constant matrices), :mod:`~neweul_py.fem.ossicular_chain` (the stiffening chain),
  :mod:`~neweul_py.fem.ear_static` (static state, validity), :mod:`~neweul_py.fem.ear_working_point`
  (linearized model, loss factors, static data), :mod:`~neweul_py.fem.ear_sweep` (sweep driver),
  :mod:`~neweul_py.fem.working_point_file` (optional file groups) and
  :mod:`~neweul_py.fem.ear_transfer` (frequency responses with the chain);
* :mod:`~neweul_py.fem.output`, :mod:`~neweul_py.fem.plots` – atomic sweep output, pictures.
"""

from .beam import BeamModel, BeamSection, beam_model
from .middle_ear import (
    MiddleEar,
    MiddleEarParameters,
    SweepResult,
    build_middle_ear,
    pressure_sweep,
    solve_static,
    static_summary,
    static_validity,
    working_point_model,
)
from .nonlinear import NewtonOptions, StaticState
from .solid import SolidMaterial, SolidModel, solid_box

__all__ = [
    "BeamModel",
    "BeamSection",
    "MiddleEar",
    "MiddleEarParameters",
    "NewtonOptions",
    "SolidMaterial",
    "SolidModel",
    "StaticState",
    "SweepResult",
    "beam_model",
    "build_middle_ear",
    "pressure_sweep",
    "solid_box",
    "solve_static",
    "static_summary",
    "static_validity",
    "working_point_model",
]
