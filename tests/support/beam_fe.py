"""The 3-D Euler–Bernoulli beam of the invariant tests: a thin wrapper around the public
builder :func:`neweul_py.fem.beam.beam_model` (see its module docstring for the element
matrices) with the helpers the tests use (clamped statics and modes, axial forces, the
geometric stiffness of given element axial forces, cross-product operators).

``lumped=True`` gives a diagonal mass matrix (half the element mass to each node; with
``rotary=True`` half the section rotary inertia to the rotational DOFs, else none: particles).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sps

from neweul_py.elastic.fe_model import FEModel
from neweul_py.fem.beam import BeamModel, BeamSection, beam_model


@dataclass
class Beam:
    """The FE model plus what the tests need to know about it."""

    fe: FEModel
    n_el: int
    length: float
    E: float
    G: float
    rho: float
    A: float
    Iy: float
    Iz: float
    rotary: bool
    lumped: bool
    model: BeamModel

    @property
    def n(self) -> int:
        return self.fe.M.shape[0]

    def dof(self, node: int, kind: int) -> int:
        """Global index of DOF ``kind`` (0…5) of node number ``node`` (0-based)."""
        return 6 * node + kind

    @property
    def free(self) -> np.ndarray:
        """DOFs left when node 0 (the root) is clamped."""
        return np.arange(6, self.n)

    def geometric_stiffness(self, N: np.ndarray) -> sps.csr_matrix:
        """Assembled geometric stiffness of the element axial forces ``N`` (n_el,)."""
        return self.model.geometric_stiffness_of_forces(N)

    def axial_forces(self, u: np.ndarray) -> np.ndarray:
        """Element axial forces ``EA (u2 − u1)/h`` of a displacement vector."""
        return self.model.axial_forces(u)

    def clamped_static(self, f: np.ndarray) -> np.ndarray:
        """Static response to the load ``f`` with the root clamped."""
        fr = self.free
        K = self.fe.K.tocsc()[fr][:, fr]
        u = np.zeros(self.n)
        u[fr] = sps.linalg.spsolve(K, f[fr])
        return u

    def clamped_modes(self, count: int) -> tuple[np.ndarray, np.ndarray]:
        """First ``count`` eigenpairs (ω², V) of the clamped beam; V (n, count), Vᵀ M V = I."""
        fr = self.free
        K = self.fe.K.toarray()[np.ix_(fr, fr)]
        M = self.fe.M.toarray()[np.ix_(fr, fr)]
        lam, X = sla.eigh(K, M, subset_by_index=[0, count - 1])
        V = np.zeros((self.n, count))
        V[fr] = X
        return lam, V

    def cross_operator(self, b: int) -> sps.csr_matrix:
        """n×n matrix of ``u ↦ e_b × u`` on the nodal translations (rotations → 0)."""
        e = np.eye(3)[b]
        blk = np.zeros((6, 6))
        blk[:3, :3] = np.cross(e, np.eye(3)).T      # column j: e_b × e_j
        return sps.kron(sps.eye(self.n_el + 1), blk, format="csr")



#: A rigid double pendulum (two links, planar hinges about z, gravity −y) whose second link
#: carries ``{extra}`` (e.g. an ``elastic_bodies:`` block) and whose tip ``{tip}`` (``link2`` or
#: a node frame such as ``beam.tip``) a spring–damper ties to the ground: the model of
#: ``benchmarks/bench_elastic.py`` and of the kernel's reference test (``tests/ffrf``);
#: ``str.format`` fields ``name``, ``extra``, ``tip``.
DOUBLE_PENDULUM = """\
name: {name}
parameters: {{m: 1.0, l: 1.0, g: 9.81, k: 50.0, c: 0.5}}
gravity: [0, -g, 0]
coordinates: {{a: {{initial: 0.3}}, b: {{initial: -0.2}}}}
frames:
  link1: {{rotation: [[z, a]]}}
  link2: {{parent: link1, translation: [l, 0, 0], rotation: [[z, b]]}}
bodies:
  arm1: {{frame: link1, mass: m, center_of_mass: [0.5*l, 0, 0],
        inertia: {{diag: [0.05, 0.05, 0.1]}}}}
  arm2: {{frame: link2, mass: m, center_of_mass: [0.5*l, 0, 0],
        inertia: {{diag: [0.05, 0.05, 0.1]}}}}
{extra}
forces:
  tip: {{type: spring_damper, between: [ISYS, {tip}], points: [[2.5, 0, 0], [0, 0, 0]],
        stiffness: k, damping: c, length: 0.5}}
"""

def beam(n_el: int = 20, length: float = 1.0, *, E: float = 1.0e4, G: float = 4.0e3,
         rho: float = 1.0, A: float = 1.0, Iy: float = 1.0e-4, Iz: float = 4.0e-4,
         offset: tuple[float, float, float] = (0.0, 0.0, 0.0), rotary: bool = False,
         lumped: bool = False, first_id: int = 1) -> Beam:
    """A uniform beam along x (see the module docstring); ``Jt = Iy + Iz`` (circular-like)."""
    section = BeamSection(E=E, G=G, rho=rho, A=A, Iy=Iy, Iz=Iz)
    model = beam_model(length, n_el, section, origin=offset, rotary=rotary, lumped=lumped,
                       first_id=first_id)
    return Beam(model.fe, n_el, length, E, G, rho, A, Iy, Iz, rotary, lumped, model)
