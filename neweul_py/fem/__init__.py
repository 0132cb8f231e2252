"""fem layer: generic acousto-structural FE builders (NumPy/SciPy/scikit-fem only).

Modules, one concern each (scikit-fem style: mesh, element, assembly, form apart):

* :mod:`~neweul_py.fem.mesh` – geometry and meshes generated in code (disc/cone, extrusions, box);
* :mod:`~neweul_py.fem.acoustic` – linear acoustic pressure elements (``Mf``, ``Kf``);
* :mod:`~neweul_py.fem.shell` – the TL St. Venant–Kirchhoff facet shell (CST membrane +
  rotation-free bending, follower pressure);
* :mod:`~neweul_py.fem.beam` – Euler–Bernoulli / Timoshenko beams (2-D, 3-D) with their
  geometric stiffness; :mod:`~neweul_py.fem.solid` – Hex8/Hex20/Tet10 solid boxes and the
  initial-stress matrix; :mod:`~neweul_py.fem.geometric` – stress stiffness of the shell;
* :mod:`~neweul_py.fem.assembly` – vectorized assembly of element arrays;
* :mod:`~neweul_py.fem.coupling` – the coupling matrix ``C`` and the u–p matrices of Eq. (2);
* :mod:`~neweul_py.fem.nonlinear` – Newton's method with adaptive load stepping.

The builders produce :class:`~neweul_py.elastic.fe_model.FEModel` objects for
:mod:`neweul_py.elastic`. Applications built on them (the middle ear, :mod:`neweul_py.middle_ear`)
live beside this package and are never imported by it (``docs/architecture.md``).
"""

from .beam import BeamModel, BeamSection, beam_model
from .nonlinear import NewtonOptions, StaticState
from .solid import SolidMaterial, SolidModel, solid_box

__all__ = [
    "BeamModel",
    "BeamSection",
    "NewtonOptions",
    "SolidMaterial",
    "SolidModel",
    "StaticState",
    "beam_model",
    "solid_box",
]
