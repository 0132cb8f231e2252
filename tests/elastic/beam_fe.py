"""A straight 3-D Euler–Bernoulli beam FE model for the invariant tests (vectorized assembly).

The beam lies on the line ``(x0 + s, y0, z0)``, ``0 ≤ s ≤ L``, with 6 DOFs per node
``ux, uy, uz, rx, ry, rz``. Element matrices (Przemieniecki, *Theory of Matrix Structural
Analysis*, 1968; Cook et al., *Concepts and Applications of FEA*):

* axial and torsion: linear elements, consistent mass ``ρAL/6 [2 1; 1 2]`` (torsion with the
  polar inertia ``ρ(Iy+Iz)``);
* bending in the x-y plane (``uy``, ``rz``, ``v' = θz``) and x-z plane (``uz``, ``ry``,
  ``w' = −θy``): cubic Hermite stiffness ``EI/L³ [12 6L −12 6L; …]``, consistent mass
  ``ρAL/420 [156 22L 54 −13L; …]``, optional rotary inertia ``ρI/(30L) [36 3L −36 3L; …]``;
* geometric (stress) stiffness of an axial force ``N``: ``N/(30L) [36 3L −36 3L; …]`` per
  bending plane.

``lumped=True`` gives a diagonal mass matrix (half the element mass to each node; with
``rotary=True`` half the section rotary inertia to the rotational DOFs, else none: particles).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sps

from neweul_py.elastic.fe_model import FEModel


def _hermite(L: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    k = np.array([[12, 6 * L, -12, 6 * L], [6 * L, 4 * L**2, -6 * L, 2 * L**2],
                  [-12, -6 * L, 12, -6 * L], [6 * L, 2 * L**2, -6 * L, 4 * L**2]]) / L**3
    m = np.array([[156, 22 * L, 54, -13 * L], [22 * L, 4 * L**2, 13 * L, -3 * L**2],
                  [54, 13 * L, 156, -22 * L], [-13 * L, -3 * L**2, -22 * L, 4 * L**2]]) \
        * L / 420
    g = np.array([[36, 3 * L, -36, 3 * L], [3 * L, 4 * L**2, -3 * L, -L**2],
                  [-36, -3 * L, 36, -3 * L], [3 * L, -L**2, -3 * L, 4 * L**2]]) / (30 * L)
    return k, m, g


# local DOF positions (0…11) of the two bending planes and the axial/torsion pairs
_XY = [1, 5, 7, 11]            # uy1 rz1 uy2 rz2
_XZ = [2, 4, 8, 10]            # uz1 ry1 uz2 ry2  (w' = −θy: flip the θ signs)
_FLIP = np.diag([1.0, -1.0, 1.0, -1.0])


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
        h = self.length / self.n_el
        _, _, g = _hermite(h)
        ke = np.zeros((12, 12))
        ke[np.ix_(_XY, _XY)] = g
        ke[np.ix_(_XZ, _XZ)] = _FLIP @ g @ _FLIP
        return _assemble(np.asarray(N)[:, None, None] * ke, self.n_el)

    def axial_forces(self, u: np.ndarray) -> np.ndarray:
        """Element axial forces ``EA (u2 − u1)/h`` of a displacement vector."""
        h = self.length / self.n_el
        ux = u[0::6]
        return self.E * self.A * np.diff(ux) / h

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


def _assemble(ke: np.ndarray, n_el: int) -> sps.csr_matrix:
    """Assemble element matrices (n_el, 12, 12) of consecutive 2-node elements."""
    dofs = 6 * np.arange(n_el)[:, None] + np.arange(12)[None, :]        # (ne, 12)
    rows = np.repeat(dofs, 12, axis=1).ravel()
    cols = np.tile(dofs, (1, 12)).ravel()
    n = 6 * (n_el + 1)
    return sps.csr_matrix((np.broadcast_to(ke, (n_el, 12, 12)).ravel(), (rows, cols)),
                          shape=(n, n))


def beam(n_el: int = 20, length: float = 1.0, *, E: float = 1.0e4, G: float = 4.0e3,
         rho: float = 1.0, A: float = 1.0, Iy: float = 1.0e-4, Iz: float = 4.0e-4,
         offset: tuple[float, float, float] = (0.0, 0.0, 0.0), rotary: bool = False,
         lumped: bool = False, first_id: int = 1) -> Beam:
    """A uniform beam along x (see the module docstring); ``Jt = Iy + Iz`` (circular-like)."""
    h = length / n_el
    Jt = Iy + Iz
    k, m, g = _hermite(h)
    ke = np.zeros((12, 12))
    me = np.zeros((12, 12))
    bar_k = np.array([[1.0, -1.0], [-1.0, 1.0]]) / h
    bar_m = np.array([[2.0, 1.0], [1.0, 2.0]]) * h / 6
    ke[np.ix_([0, 6], [0, 6])] = E * A * bar_k
    ke[np.ix_([3, 9], [3, 9])] = G * Jt * bar_k
    ke[np.ix_(_XY, _XY)] = E * Iz * k
    ke[np.ix_(_XZ, _XZ)] = E * Iy * (_FLIP @ k @ _FLIP)
    if lumped:
        half = rho * A * h / 2
        rot = [rho * Jt * h / 2, rho * Iy * h / 2, rho * Iz * h / 2] if rotary else [0.0] * 3
        diag = np.array([half] * 3 + rot)
        me = np.diag(np.concatenate([diag, diag]))
    else:
        me[np.ix_([0, 6], [0, 6])] = rho * A * bar_m
        me[np.ix_([3, 9], [3, 9])] = rho * Jt * bar_m
        me[np.ix_(_XY, _XY)] = rho * A * m
        me[np.ix_(_XZ, _XZ)] = rho * A * (_FLIP @ m @ _FLIP)
        if rotary:
            me[np.ix_(_XY, _XY)] += rho * Iz * g
            me[np.ix_(_XZ, _XZ)] += rho * Iy * (_FLIP @ g @ _FLIP)
    K = _assemble(np.broadcast_to(ke, (n_el, 12, 12)), n_el)
    M = _assemble(np.broadcast_to(me, (n_el, 12, 12)), n_el)
    nn = n_el + 1
    ids = first_id + np.arange(nn)
    s = np.linspace(0.0, length, nn)
    nodes = np.column_stack([ids, s + offset[0], np.full(nn, offset[1]),
                             np.full(nn, offset[2])])
    kinds = np.tile(np.array(["ux", "uy", "uz", "rx", "ry", "rz"]), nn)
    fe = FEModel(M=M, K=K, D=None, nodes=nodes, dof_node=np.repeat(ids, 6), dof_kind=kinds,
                 name="beam")
    return Beam(fe, n_el, length, E, G, rho, A, Iy, Iz, rotary, lumped)
