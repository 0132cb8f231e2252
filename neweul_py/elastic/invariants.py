"""Floating-frame-of-reference invariants of an elastic body (``docs/equations.md`` §2).

From an FE model (mass matrix ``M``, node coordinates, DOF map) and a right basis ``V``
(displacements ``x = V q``) and left basis ``W`` (test functions; ``W = V`` for one-sided
data), :func:`compute_invariants` computes the invariants of Wallrapp (1994) and Schwertassek &
Wallrapp (1999, ch. 6) that the equations of the body need::

    [ m I    m̃dᵀ   md¹  ] [ a ]   [ ω̃ω̃ md + 2 ω̃ md¹ q̇          ]   [ 0               ]
    [ m̃d     J     Crvᵀ ] [ α ] + [ ω̃ J ω + Σ_k Gr_k q̇_k ω       ] + [ 0               ] = h
    [ Ct     Cr    Me   ] [ q̈ ]   [ Oe(q) ω_q + Σ_k Ge_k q̇_k ω    ]   [ Ke q + De q̇ + kσ ]

``a``, ``α``, ``ω``: acceleration, angular acceleration and angular velocity of the reference
frame, in reference-frame components; ``ω_q = [ωx², ωy², ωz², ωxωy, ωyωz, ωxωz]``.
:meth:`Invariants.mass_matrix` and :meth:`Invariants.velocity_terms` assemble exactly this.

Conventions (fixed here, identical for data read from SID files)
------------------------------------------------------------------
* ``m̃d`` is the skew matrix of ``md = ∫ (x + u) dm`` and appears as ``m̃d`` in the rotational
  row and ``m̃dᵀ = −m̃d`` in the translational row (from ``α × r = −r̃ α``).
* ``md¹`` (3×nq) is the first-order part of ``md``; it is the translational-row coupling
  (one-sided: ``md¹ = Ct⁰ᵀ``).
* ``J(q) = −∫ ũ ũ dm`` about the frame origin, ``J¹_k = sym(Gr_k)``.
* ``Cr(q)`` (elastic row): ``Cr⁰ = ∫ Φᵀ x̃ᵀ dm = (∫ x̃ Φ dm)ᵀ``, ``Cr¹_k = ∫ Φᵀ Φ̃_kᵀ dm``
  (+ geometric stiffening). ``Crv`` is the same with ``V`` in place of ``W`` and without
  stiffening: the rotational-row coupling (``Crvᵀ`` in the matrix above). For one-sided data
  read from SID, ``Crv = Cr⁰ + antisym(Cr¹)`` (the kinematic part).
* ``Gr = [Gr_1 | … | Gr_nq]`` (3×3nq), ``Gr_k = −2 ∫ x̃ Φ̃_k dm``;
  ``Ge = [Ge_1 | … | Ge_nq]`` (nq×3nq), ``Ge_k = 2 ∫ Φᵀ Φ̃_kᵀ dm`` (3 columns per mode).
* ``Oe`` columns ``ωx², ωy², ωz², ωxωy, ωyωz, ωxωz``: ``Oe(q) ω_q = ∫ Φᵀ ω̃ω̃ (x + u) dm``
  (+ stiffening in ``Oe¹``); one-sided, ``Oe⁰ ω_q = −½ ωᵀ J¹ ω`` holds exactly.
* Node frames: ``origin(q) = x_P + Φ_P q``, ``AP(q) = AP⁰ + Σ_k ψ̃_k AP⁰ q_k``.

Two-sided rule (§2): terms describing displacement use ``V`` (``md¹``, ``J¹``, ``Gr``,
``Crv``, node ``origin``, ``Φ``, ``Ψ``); elastic-equation rows use ``Wᵀ`` (``Ct``, ``Cr``,
``Me``, ``Ge``, ``Oe``, ``Ke``, ``De``, ``kσ`` and the modal loads ``W_Pᵀ f`` of node forces,
:attr:`NodeFrame.phi_w` / :attr:`NodeFrame.psi_w`).

Evaluating volume integrals with the FE mass matrix
---------------------------------------------------
Every integral ``∫ f·g dm`` is evaluated as ``Fᵀ M G`` with ``F``, ``G`` the nodal DOF vectors
of the fields (translations at ``ux, uy, uz``, small rotations at ``rx, ry, rz``). The rigid
fields are exact: translation ``T_t`` (``e_a`` at the translational DOFs) and rotation
``T_r`` (``e_a × x`` at the translational DOFs, ``e_a`` at the rotational DOFs), so ``m``,
``md⁰``, ``J⁰``, ``Ct⁰``, ``Cr⁰``, ``Me``, ``md¹`` are exact for any consistent or lumped
mass matrix (including rotary inertia of rotational DOFs). Cross products with a field act
on its nodal translations (``P_b G``: ``e_b × g`` at every node, rotations 0), and they are
evaluated in the symmetric form::

    ∫ f·(e_b × g) dm       ≈ ½ [ Fᵀ M (P_b G) − (P_b F)ᵀ M G ]
    ∫ (e_a × f)·(e_b × g) dm ≈ (P_a F)ᵀ M (P_b G)

which is exact for a lumped mass matrix and, for consistent matrices, keeps the structure of
the continuum (one-sided: ``Ge`` skew, ``Cr¹`` antisymmetric in (row, mode), ``Oe¹``
symmetric, ``J¹ = sym Gr``, ``Oe⁰ = −½ J¹``); the error vanishes with mesh refinement (for
the consistent Euler–Bernoulli beam, whose axial and transverse interpolations differ, the
spin softening of a bending mode comes out 1.00036 instead of 1 with 20 elements). The
rotary inertia of rotational DOFs enters the mass blocks, not the cross-product terms.
Planar models (missing DOF directions) give the in-plane invariants only. As in the SID
standard, products of elastic quantities beyond first order are dropped (``Gr`` is
constant, ``J`` linear in ``q``).

:meth:`Invariants.transformed` changes the modal coordinates (``V → V R``, ``Wᵀ → L Wᵀ``),
e.g. to bring samples to common coordinates before interpolation (§4, step 6).

Geometric stiffening (Wallrapp 1994; Schwertassek & Wallrapp 1999, ch. 6)
-------------------------------------------------------------------------
The inertia loads of the reference-frame motion prestress the body; to first order the
elastic rows gain ``Σ_c s_c K_G,c q`` with ``s_c ∈ {a_x, a_y, a_z, α_x, α_y, α_z, ω_q}`` and
``K_G,c`` the geometric stiffness of the stress state caused by a unit value of ``s_c``. They
are stored in the first-order parts of ``Ct`` (``a``), ``Cr`` (``α``) and ``Oe`` (``ω_q``)::

    Ct¹[i, k, a] += (Wᵀ K_G,a V)[i, k],   Cr¹[i, k, b] += (Wᵀ K_G,αb V)[i, k],
    Oe¹[i, k, c] += (Wᵀ K_G,c V)[i, k].

The ``K_G,c`` depend on the element formulation: :func:`stress_stiffening` applies the unit
d'Alembert loads (:func:`inertia_loads`) to the body supported at its reference frame and
hands each static displacement to the formulation's stress-stiffness function (see
``tests/elastic/beam_fe.py`` for Euler–Bernoulli beams).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sps

from ..errors import DataError
from ..ffrf import (
    FLAT_FORMAT,
    TAYLOR_NAMES,
    ffrf_body_mass,
    ffrf_elastic_forces,
    ffrf_mass_blocks,
    ffrf_prepare,
    ffrf_velocity_terms,
)
from .taylor import Taylor

__all__ = [
    "LOAD_CASES",
    "OMEGA_PRODUCTS",
    "Invariants",
    "NodeFrame",
    "QuadraticField",
    "attach_invariants",
    "body_invariants",
    "compute_invariants",
    "inertia_loads",
    "inertia_responses",
    "omega_products",
    "skew",
    "stress_stiffening",
]

#: Unit load cases of geometric stiffening: frame acceleration, angular acceleration, ω_q.
LOAD_CASES = ("ax", "ay", "az", "alphax", "alphay", "alphaz",
              "wxx", "wyy", "wzz", "wxy", "wyz", "wxz")
#: Index pairs (a, b) of the ω_q columns ``ωx², ωy², ωz², ωxωy, ωyωz, ωxωz``.
OMEGA_PRODUCTS = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))
_TAYLORS = TAYLOR_NAMES

#: The permutation (Levi-Civita) symbol ``ε_ijk``.
LEVI_CIVITA = np.zeros((3, 3, 3))
LEVI_CIVITA[0, 1, 2] = LEVI_CIVITA[1, 2, 0] = LEVI_CIVITA[2, 0, 1] = 1.0
LEVI_CIVITA[0, 2, 1] = LEVI_CIVITA[2, 1, 0] = LEVI_CIVITA[1, 0, 2] = -1.0


def skew(v: np.ndarray) -> np.ndarray:
    """``ṽ`` with ``ṽ b = v × b``, vectorized: (..., 3) → (..., 3, 3)."""
    return -np.einsum("ijk,...k->...ij", LEVI_CIVITA, np.asarray(v, dtype=np.float64))


def omega_products(omega: np.ndarray) -> np.ndarray:
    """``ω_q = [ωx², ωy², ωz², ωxωy, ωyωz, ωxωz]`` (vectorized over leading axes)."""
    w = np.asarray(omega, dtype=np.float64)
    return np.stack([w[..., a] * w[..., b] for a, b in OMEGA_PRODUCTS], axis=-1)


def _omega_q_coefficients(Q: np.ndarray) -> np.ndarray:
    """A quadratic form ``Σ_ab Q[..., a, b] ω_a ω_b`` as coefficients of ω_q: (..., 6)."""
    cols = [Q[..., a, a] if a == b else Q[..., a, b] + Q[..., b, a] for a, b in OMEGA_PRODUCTS]
    return np.stack(cols, axis=-1)


# ------------------------------------------------------------------------ data model
@dataclass(frozen=True, eq=False)
class NodeFrame:
    """A node frame of an elastic body (§2): pose and mode shapes at a node.

    Parameters
    ----------
    id
        Node id.
    origin
        Taylor 3×1, ``origin(q) = x_P + Φ_P q`` (uses ``V``).
    phi, psi
        Taylor 3×nq: translational / rotational mode shapes at the node (``V``).
    AP
        Taylor 3×3: node-frame orientation, ``AP(q) = AP⁰ + Σ_k ψ̃_k AP⁰ q_k``.
    phi_w, psi_w
        (3, nq) rows of the left basis ``W`` at the node: the modal load of a node force
        ``f`` and torque ``l`` is ``phi_wᵀ f + psi_wᵀ l``. ``None`` for one-sided data
        (then ``phi``/``psi`` are used).
    """

    id: int
    origin: Taylor
    phi: Taylor
    psi: Taylor
    AP: Taylor
    phi_w: np.ndarray | None = None
    psi_w: np.ndarray | None = None

    @property
    def load_phi(self) -> np.ndarray:
        """(3, nq) modal-load matrix of a node force (``W`` rows, or ``Φ`` one-sided)."""
        return self.phi.m0 if self.phi_w is None else self.phi_w

    @property
    def load_psi(self) -> np.ndarray:
        """(3, nq) modal-load matrix of a node torque (``W`` rows, or ``Ψ`` one-sided)."""
        return self.psi.m0 if self.psi_w is None else self.psi_w


@dataclass(frozen=True, eq=False)
class QuadraticField:
    """The second-order displacement field ``u = Φ q + Y y(q)``, ``y_j = ½ qᵀ A_j q``
    (``docs/equations.md`` §2.3), built by
    :func:`neweul_py.elastic.second_order.second_order_field`.

    Parameters
    ----------
    body
        The invariants of the extended basis ``[Φ, Y]`` (one-sided, no stiffening, no node
        frames): with ``z = [q; y(q)]`` its consistent FFRF equations are the exact kinetic
        energy of the field, so ``M_b(q) = Tᵀ M_b,z(z) T`` is a Gram matrix and positive.
    A
        (ny, nq, nq) symmetric ``A_j``.
    """

    body: Invariants
    A: np.ndarray

    def transformed(self, R: np.ndarray) -> QuadraticField:
        """After ``q = R q̃``: ``z = diag(R, I) z̃``, ``A_j → Rᵀ A_j R``."""
        ny = self.A.shape[0]
        nq, nr = R.shape
        Rz = np.zeros((nq + ny, nr + ny))
        Rz[:nq, :nr] = R
        Rz[nq:, nr:] = np.eye(ny)
        return QuadraticField(self.body.transformed(Rz),          # stays one-sided
                              np.einsum("jkl,kK,lL->jKL", self.A, R, R))

    def to_flat(self) -> dict[str, np.ndarray]:
        """The flat arrays ``quad.<key>`` of the extended body and ``quad.A``."""
        out = {f"quad.{k}": v for k, v in self.body.to_flat().items() if k != "names"}
        out["quad.A"] = self.A.copy()
        return out

    @classmethod
    def from_flat(cls, flat: Mapping[str, np.ndarray]) -> QuadraticField:
        """Inverse of :meth:`to_flat` (the other keys of ``flat`` are ignored)."""
        inner = {k[5:]: v for k, v in flat.items() if k.startswith("quad.") and k != "quad.A"}
        try:
            body = Invariants.from_flat({**inner, "names": np.array([], dtype=str)})
        except DataError as exc:
            raise DataError(exc.message, exc.file, f"quad.{exc.item}" if exc.item else "quad",
                            exc.line) from None
        return cls(body, np.asarray(flat["quad.A"], dtype=np.float64))


@dataclass(frozen=True, eq=False)
class Invariants:
    """The invariants of an elastic body in the floating frame of reference (§2).

    All matrices are :class:`~neweul_py.elastic.taylor.Taylor` objects in the conventions of
    the module docstring (SID conventions; ``J`` 3×3 here, 6×1 in SID files).

    Parameters
    ----------
    m
        Mass.
    md
        3×1, order 1: first mass moment about the frame origin, ``md¹ = ∫ Φ dm`` (V).
    J
        3×3, order 1: inertia tensor about the frame origin (``J¹`` from V).
    Ct, Cr
        nq×3: elastic-row couplings with ``a`` and ``α`` (W; order 1 = geometric stiffening
        for ``Ct``, kinematic + stiffening for ``Cr``).
    Crv
        nq×3: rotational-row coupling (V, kinematic), ``Crvᵀ`` in the mass matrix.
    Me
        nq×nq modal mass ``Wᵀ M V``.
    Gr, Ge
        3×3nq and nq×3nq gyroscopic blocks (3 columns per mode).
    Oe
        nq×6, order 1: centrifugal terms (columns ω_q).
    ksigma
        nq×1: modal forces of reference stresses.
    Ke, De
        nq×nq modal stiffness ``Wᵀ K V`` and damping ``Wᵀ D V``.
    nodes
        Node frames.
    names
        Names of the elastic coordinates.
    two_sided
        Whether ``W ≠ V`` (the SID writer refuses two-sided data).
    J2
        (nq, nq, 3, 3) second-order inertia ``C2[k, l, a, b] = ∫ (e_a × Φ_k)·(e_b × Φ_l) dm``
        (V): ``J(q) += Σ q_k q_l C2[k, l]``, ``Gr_k(q) += 2 Σ_l q_l C2[l, k]``
        (equations.md §2.1); ``None`` for data without it (SID files).
    quadratic
        The second-order displacement field of a stiffened body (§2.3), which the kernel
        uses instead of the first-order stiffening terms; ``None`` without it.
    Le, loss_f_ref
        Optional nq×nq hysteretic matrix ``Wᵀ G V`` of the frequency-domain stiffness
        ``Ke + i Le`` (loss factors, §1.1) and its reference frequency [Hz] (flat keys
        ``Le.m0``, ``loss.f_ref``); ``De`` holds the time-domain equivalent.
    """

    m: float
    md: Taylor
    J: Taylor
    Ct: Taylor
    Cr: Taylor
    Crv: Taylor
    Me: Taylor
    Gr: Taylor
    Ge: Taylor
    Oe: Taylor
    ksigma: Taylor
    Ke: Taylor
    De: Taylor
    nodes: tuple[NodeFrame, ...] = ()
    names: tuple[str, ...] = ()
    two_sided: bool = False
    J2: np.ndarray | None = None
    quadratic: QuadraticField | None = None
    Le: np.ndarray | None = None
    loss_f_ref: float | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        nq = self.Me.nrow
        if (self.Le is None) != (self.loss_f_ref is None):
            raise DataError("the hysteretic matrix and its reference frequency come together",
                            item="Le.m0")
        if self.Le is not None:
            le = np.array(self.Le, dtype=np.float64)
            if le.shape != (nq, nq):
                raise DataError(f"shape {le.shape}, expected ({nq}, {nq})", item="Le.m0")
            le.setflags(write=False)
            set_(self, "Le", le)
            set_(self, "loss_f_ref", float(self.loss_f_ref))
        want = {"md": (3, 1), "J": (3, 3), "Ct": (nq, 3), "Cr": (nq, 3), "Crv": (nq, 3),
                "Me": (nq, nq), "Gr": (3, 3 * nq), "Ge": (nq, 3 * nq), "Oe": (nq, 6),
                "ksigma": (nq, 1), "Ke": (nq, nq), "De": (nq, nq)}
        for name, shape in want.items():
            t = getattr(self, name)
            if not isinstance(t, Taylor):
                raise DataError(f"must be a Taylor object, got {type(t).__name__}", item=name)
            if (t.nrow, t.ncol) != shape:
                raise DataError(f"size {t.nrow}×{t.ncol}, expected {shape[0]}×{shape[1]} "
                                f"(nq = {nq})", item=name)
            if t.order == 1 and t.nq != nq:
                raise DataError(f"first-order terms for {t.nq} modes, the body has {nq}",
                                item=name)
        set_(self, "m", float(self.m))
        set_(self, "nodes", tuple(self.nodes))
        if self.J2 is not None:
            j2 = np.array(self.J2, dtype=np.float64)
            if j2.shape != (nq, nq, 3, 3):
                raise DataError(f"shape {j2.shape}, expected ({nq}, {nq}, 3, 3)", item="J.m2")
            j2.setflags(write=False)
            set_(self, "J2", j2)
        names = tuple(self.names) or tuple(f"q{i + 1}" for i in range(nq))
        if len(names) != nq:
            raise DataError(f"{len(names)} names for {nq} elastic coordinates", item="names")
        set_(self, "names", names)
        for n in self.nodes:
            for key, shape in (("origin", (3, 1)), ("phi", (3, nq)), ("psi", (3, nq)),
                               ("AP", (3, 3))):
                t = getattr(n, key)
                if (t.nrow, t.ncol) != shape:
                    raise DataError(f"size {t.nrow}×{t.ncol}, expected {shape}",
                                    item=f"nodes[{n.id}].{key}")
            for key in ("phi_w", "psi_w"):
                a = getattr(n, key)
                if a is not None and np.shape(a) != (3, nq):
                    raise DataError(f"shape {np.shape(a)}, expected (3, {nq})",
                                    item=f"nodes[{n.id}].{key}")

    # ---------------------------------------------------------------------- access
    @property
    def nq(self) -> int:
        """Number of elastic coordinates."""
        return self.Me.nrow

    def node(self, node_id: int) -> NodeFrame:
        """The node frame with id ``node_id``."""
        for n in self.nodes:
            if n.id == node_id:
                return n
        raise DataError(f"no node frame {node_id} (have {[n.id for n in self.nodes]})",
                        item="nodes")

    def blocks(self, name: str) -> np.ndarray:
        """``Gr`` as (nq, 3, 3) blocks ``Gr_k`` or ``Ge`` as (nq, nq, 3) blocks ``Ge_k``."""
        t = getattr(self, name).m0
        if name == "Gr":
            return t.reshape(3, self.nq, 3).transpose(1, 0, 2).copy()
        if name == "Ge":
            return t.reshape(self.nq, self.nq, 3).transpose(1, 0, 2).copy()
        raise DataError(f"no block form of {name}", item=name)

    # ---------------------------------------------------------------- the equations
    def kernel_form(self) -> dict:
        """The working form of :func:`neweul_py.ffrf.ffrf_prepare` (the one implementation
        of the body equations)."""
        return ffrf_prepare(self.to_flat())

    def mass_matrix(self, q: np.ndarray | None = None) -> np.ndarray:
        """The (6+nq)² body mass matrix of §2 for ``[a, α, q̈]`` (unsymmetric in general):
        :func:`neweul_py.ffrf.ffrf_body_mass`."""
        q = np.zeros(self.nq) if q is None else np.asarray(q, dtype=np.float64)
        return ffrf_body_mass(self.kernel_form(), q)

    def velocity_terms(self, q: np.ndarray, qd: np.ndarray, omega: np.ndarray) -> np.ndarray:
        """The (6+nq) vector ``h_ω`` of velocity-dependent inertia terms of §2:
        :func:`neweul_py.ffrf.ffrf_velocity_terms`."""
        q, qd, w = (np.asarray(v, dtype=np.float64) for v in (q, qd, omega))
        b = self.kernel_form()
        return np.concatenate(ffrf_velocity_terms(b, q, qd, w, ffrf_mass_blocks(b, q)))

    def elastic_forces(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """``Ke q + De q̇ + kσ`` (elastic rows, left-hand side)."""
        return ffrf_elastic_forces(self.kernel_form(), np.asarray(q, float),
                                   np.asarray(qd, float))

    # ------------------------------------------------------------ change of basis
    def transformed(self, right: np.ndarray | None = None,
                    left: np.ndarray | None = None) -> Invariants:
        """The invariants after a change of elastic coordinates ``q = R q̃``, ``Wᵀ → L Wᵀ``.

        With the new bases ``Ṽ = V R`` and ``W̃ = W Lᵀ`` every index that counts modes of
        ``V`` (the columns of ``Me``, ``Ke``, ``De``, all first-order mode indices, the
        ``Gr``/``Ge`` blocks, the rows of ``Crv``, the node ``Φ``, ``Ψ``) is transformed with
        ``R`` and every elastic-equation row (``Ct``, ``Cr``, ``Me``, ``Ge``, ``Oe``, ``Ke``,
        ``De``, ``kσ``, the node load matrices) with ``L``. Used to bring samples to common
        coordinates before interpolating (``equations.md`` §4, step 6). Changing only
        ``left`` of one-sided data gives two-sided data.

        Parameters
        ----------
        right
            (nq, nq̃) matrix ``R`` (default identity).
        left
            (nq̃, nq) matrix ``L`` (default identity for one-sided data; ``Rᵀ`` keeps a
            one-sided body one-sided).
        """
        nq = self.nq
        R = np.eye(nq) if right is None else np.asarray(right, dtype=np.float64)
        two = self.two_sided or left is not None
        if left is None:
            L = R.T if not self.two_sided else np.eye(nq)
        else:
            L = np.asarray(left, dtype=np.float64)
        if R.shape[0] != nq or L.shape != (R.shape[1], nq):
            raise DataError(f"right {R.shape} / left {L.shape} do not fit nq = {nq}",
                            item="transformed")
        nr = R.shape[1]

        def modes(t: Taylor) -> np.ndarray | None:      # first-order mode index by R
            return None if t.m1 is None else np.einsum("ikj,kl->ilj", t.m1, R)

        def rows_l(t: Taylor, cols_r: bool = False) -> Taylor:
            m0 = L @ t.m0
            m0 = m0 @ R if cols_r else m0
            m1 = modes(t)
            m1 = None if m1 is None else np.einsum("ai,ikj->akj", L, m1)
            if m1 is not None and cols_r:
                m1 = np.einsum("akj,jb->akb", m1, R)
            return Taylor.from_arrays(m0, m1, nq=nr)

        def geo(t: Taylor) -> Taylor:
            return Taylor.from_arrays(t.m0, modes(t), nq=nr)

        gr = np.einsum("kab,kl->lab", self.blocks("Gr"), R)
        ge = np.einsum("ai,kib,kl->lab", L, self.blocks("Ge"), R)
        crv0 = R.T @ self.Crv.m0
        crv1 = None if self.Crv.m1 is None else np.einsum("ki,kjb,jl->ilb", R, self.Crv.m1, R)
        nodes = []
        for n in self.nodes:
            nodes.append(NodeFrame(
                n.id, geo(n.origin), Taylor.from_arrays(n.phi.m0 @ R, nq=nr),
                Taylor.from_arrays(n.psi.m0 @ R, nq=nr), geo(n.AP),
                (n.load_phi @ L.T) if two else None, (n.load_psi @ L.T) if two else None))
        names = self.names if nr == nq else ()
        j2 = None if self.J2 is None else np.einsum("klab,kK,lL->KLab", self.J2, R, R)
        return Invariants(
            m=self.m, md=geo(self.md), J=geo(self.J), Ct=rows_l(self.Ct), Cr=rows_l(self.Cr),
            Crv=Taylor.from_arrays(crv0, crv1, nq=nr), Me=rows_l(self.Me, True),
            Gr=Taylor.from_arrays(gr.transpose(1, 0, 2).reshape(3, 3 * nr), nq=nr),
            Ge=Taylor.from_arrays(ge.transpose(1, 0, 2).reshape(nr, 3 * nr), nq=nr),
            Oe=rows_l(self.Oe), ksigma=rows_l(self.ksigma), Ke=rows_l(self.Ke, True),
            De=rows_l(self.De, True), nodes=tuple(nodes), names=names, two_sided=two, J2=j2,
            quadratic=None if self.quadratic is None or two else self.quadratic.transformed(R),
            Le=None if self.Le is None else L @ self.Le @ R, loss_f_ref=self.loss_f_ref)

    # --------------------------------------------------------------------- storage
    def to_flat(self) -> dict[str, np.ndarray]:
        """Flat ``name → array`` form for the reduced-body file (no objects, no pickles).

        Keys: ``X.m0`` / ``X.m1`` for every Taylor object ``X``, ``m``, ``names``,
        ``two_sided``, ``format``, and stacked node data ``nodes.id`` (nk,),
        ``nodes.origin.m0`` (nk, 3, 1), ``nodes.origin.m1`` (nk, 3, nq, 1), ``nodes.phi``,
        ``nodes.psi``, ``nodes.phi_w``, ``nodes.psi_w`` (nk, 3, nq), ``nodes.AP.m0``
        (nk, 3, 3), ``nodes.AP.m1`` (nk, 3, nq, 3).
        """
        out: dict[str, np.ndarray] = {
            "format": np.array(FLAT_FORMAT),
            "m": np.array(self.m),
            "names": np.array(self.names, dtype=str),
            "two_sided": np.array(self.two_sided),
        }
        for name in _TAYLORS:
            t: Taylor = getattr(self, name)
            out[f"{name}.m0"] = t.m0.copy()
            if t.m1 is not None:
                out[f"{name}.m1"] = t.m1.copy()
        if self.J2 is not None:
            out["J.m2"] = self.J2.copy()
        nq, nk = self.nq, len(self.nodes)
        out["nodes.id"] = np.array([n.id for n in self.nodes], dtype=np.int64)
        out["nodes.origin.m0"] = np.array([n.origin.m0 for n in self.nodes]).reshape(nk, 3, 1)
        out["nodes.origin.m1"] = np.array(
            [n.origin.with_order(1).m1 for n in self.nodes]).reshape(nk, 3, nq, 1)
        out["nodes.phi"] = np.array([n.phi.m0 for n in self.nodes]).reshape(nk, 3, nq)
        out["nodes.psi"] = np.array([n.psi.m0 for n in self.nodes]).reshape(nk, 3, nq)
        out["nodes.phi_w"] = np.array([n.load_phi for n in self.nodes]).reshape(nk, 3, nq)
        out["nodes.psi_w"] = np.array([n.load_psi for n in self.nodes]).reshape(nk, 3, nq)
        out["nodes.AP.m0"] = np.array([n.AP.m0 for n in self.nodes]).reshape(nk, 3, 3)
        out["nodes.AP.m1"] = np.array(
            [n.AP.with_order(1).m1 for n in self.nodes]).reshape(nk, 3, nq, 3)
        if self.quadratic is not None:
            out.update(self.quadratic.to_flat())
        if self.Le is not None:
            out["Le.m0"] = self.Le.copy()
            out["loss.f_ref"] = np.array(self.loss_f_ref)
        return out

    @classmethod
    def from_flat(cls, flat: Mapping[str, np.ndarray]) -> Invariants:
        """Inverse of :meth:`to_flat`.

        Raises
        ------
        DataError
            Unknown format tag or missing/inconsistent arrays (item: the array name).
        """
        def get(key: str) -> np.ndarray:
            if key not in flat:
                raise DataError("missing array", item=f"invariants.{key}")
            return np.asarray(flat[key])

        fmt = str(get("format"))
        if fmt != FLAT_FORMAT:
            raise DataError(f"unknown invariants format {fmt!r} (expected {FLAT_FORMAT!r})",
                            item="invariants.format")
        try:
            return cls._from_flat(flat, get)
        except (IndexError, ValueError, TypeError) as exc:  # arrays of the wrong size/type
            raise DataError(f"inconsistent arrays ({' '.join(str(exc).split())})",
                            item="invariants") from None

    @classmethod
    def _from_flat(cls, flat: Mapping[str, np.ndarray], get) -> Invariants:
        taylors = {}
        for name in _TAYLORS:
            m0 = get(f"{name}.m0")
            m1 = flat.get(f"{name}.m1")
            taylors[name] = Taylor.from_arrays(m0, None if m1 is None else np.asarray(m1))
        nq = taylors["Me"].nrow
        two_sided = bool(get("two_sided"))
        ids = get("nodes.id").astype(np.int64)
        nodes = []
        for i, node_id in enumerate(ids):
            phi = get("nodes.phi")[i]
            psi = get("nodes.psi")[i]
            nodes.append(NodeFrame(
                int(node_id),
                Taylor.from_arrays(get("nodes.origin.m0")[i], get("nodes.origin.m1")[i]),
                Taylor.from_arrays(phi, nq=nq), Taylor.from_arrays(psi, nq=nq),
                Taylor.from_arrays(get("nodes.AP.m0")[i], get("nodes.AP.m1")[i]),
                get("nodes.phi_w")[i].copy() if two_sided else None,
                get("nodes.psi_w")[i].copy() if two_sided else None))
        j2 = flat.get("J.m2")
        quadratic = QuadraticField.from_flat(flat) if "quad.A" in flat else None
        le = flat.get("Le.m0")
        return cls(m=float(get("m")), nodes=tuple(nodes),
                   names=tuple(str(s) for s in get("names")), two_sided=two_sided,
                   J2=None if j2 is None else np.asarray(j2), quadratic=quadratic,
                   Le=None if le is None else np.asarray(le),
                   loss_f_ref=None if le is None else float(get("loss.f_ref")), **taylors)

    # ------------------------------------------------------------------------ SID
    @classmethod
    def from_sid(cls, body, *, gr_layout: str = "auto", ge_layout: str = "auto") -> Invariants:
        """The invariants of a :class:`~neweul_py.elastic.sid.SIDBody` (one-sided).

        Parameters
        ----------
        body
            The SID data.
        gr_layout, ge_layout
            Column layout of ``Gr`` (3×3nq) and ``Ge`` (nq×3nq) in the file: ``"mode"``
            (``[G_1 | … | G_nq]``, 3 columns per mode, column ``3(k−1)+b``) or
            ``"component"`` (``[G^x | G^y | G^z]``, nq columns per ω component, column
            ``(b−1)·nq+k``). Exporters differ (the SIMPACK-style file of EMBS_ModelicaLib
            uses ``"component"`` for both, the PY_SID beam file ``"mode"`` for ``Gr`` and
            ``"component"`` for ``Ge``). ``"auto"`` picks the layout in which the block
            satisfies its kinematic identity with the first-order terms, ``sym Gr_k = J¹_k``
            and ``Ge_k = 2 Cr¹_k``, falling back to ``"mode"`` when these are zero or
            equally good (always the case for nq = 1).

        Notes
        -----
        Missing blocks are zero. SID holds one rotational coupling ``Cr``; the rigid-row
        coupling is ``Crv = Cr⁰ + antisym(Cr¹)`` (antisymmetric in row and mode: the kinematic
        part ``∫ Φ_iᵀ Φ̃_kᵀ dm``; the symmetric part of ``Cr¹`` is geometric stiffening and
        acts in the elastic rows only). ``J`` is expanded to 3×3; ``Gr``/``Ge`` are stored per
        mode here.
        """
        from .sid import j_as_matrix  # local: sid does not depend on invariants

        nq = body.nq

        def tay(name: str, shape: tuple[int, int], order: int = 0) -> Taylor:
            t = body.get(name)
            if t is None:
                return Taylor.from_arrays(np.zeros(shape),
                                          np.zeros((shape[0], nq, shape[1])) if order else None,
                                          nq=nq)
            return t

        J = j_as_matrix(tay("J", (3, 3), 1)).with_order(1)
        Cr = tay("Cr", (nq, 3))
        Gr = _per_mode(tay("Gr", (3, 3 * nq)), nq, gr_layout, "Gr",
                       lambda b: np.abs(0.5 * (b + b.transpose(0, 2, 1))
                                        - J.m1.transpose(1, 0, 2)).max())
        cr1 = Cr.m1 if Cr.m1 is not None else np.zeros((nq, nq, 3))
        Ge = _per_mode(tay("Ge", (nq, 3 * nq)), nq, ge_layout, "Ge",
                       lambda b: np.abs(b - 2 * cr1.transpose(1, 0, 2)).max())
        # rigid-row coupling: the kinematic part of Cr¹ is antisymmetric in (row, mode), the
        # geometric stiffening (Wᵀ K_G V, one-sided) symmetric; only the former belongs there
        Crv = Taylor.from_arrays(Cr.m0, None if Cr.m1 is None else
                                 0.5 * (Cr.m1 - Cr.m1.transpose(1, 0, 2)), nq=nq)
        nodes = tuple(NodeFrame(n.id, n.origin, n.phi, n.psi, n.AP) for n in body.nodes)
        return cls(
            m=body.mass, md=tay("mdCM", (3, 1), 1).with_order(1), J=J,
            Ct=tay("Ct", (nq, 3)), Cr=Cr, Crv=Crv, Me=tay("Me", (nq, nq)), Gr=Gr, Ge=Ge,
            Oe=tay("Oe", (nq, 6), 1).with_order(1), ksigma=tay("ksigma", (nq, 1)),
            Ke=tay("Ke", (nq, nq)), De=tay("De", (nq, nq)), nodes=nodes, names=body.ielastq)

    def to_sid(self, header: str = "", layout: str = "component"):
        """A :class:`~neweul_py.elastic.sid.SIDBody` of one-sided invariants.

        ``J`` is written 6×1, ``Gr`` and ``Ge`` in ``layout`` (``"component"``, as in
        SIMPACK-style files, or ``"mode"``; see :meth:`from_sid`), ``Crv`` is dropped (SID
        has one ``Cr``); each block gets its most compact structure flag.

        Raises
        ------
        DataError
            For two-sided data (the SID format holds one basis).
        """
        from .sid import SIDBody, SIDNode, j_as_column

        if self.two_sided:
            raise DataError("two-sided invariants cannot be written as SID (one basis only)",
                            item="two_sided")
        if layout not in ("mode", "component"):
            raise DataError(f"layout must be 'mode' or 'component', got {layout!r}",
                            item="layout")
        nq = self.nq

        def out(t: Taylor) -> Taylor:
            t = Taylor(t.order, t.nrow, t.ncol, nq, 0, 3, t.m0, t.m1)
            return t.with_structure(None)

        def gyro(name: str) -> Taylor:
            blocks = self.blocks(name)                       # (k, row, b)
            order = (1, 0, 2) if layout == "mode" else (1, 2, 0)
            m0 = blocks.transpose(*order).reshape(blocks.shape[1], 3 * nq)
            return out(Taylor.from_arrays(m0, nq=nq))

        taylors = {"mdCM": out(self.md), "J": out(j_as_column(self.J)), "Ct": out(self.Ct),
                   "Cr": out(self.Cr), "Me": out(self.Me), "Gr": gyro("Gr"),
                   "Ge": gyro("Ge"), "Oe": out(self.Oe), "ksigma": out(self.ksigma),
                   "Ke": out(self.Ke), "De": out(self.De)}
        nodes = tuple(SIDNode(n.id, "body ref", out(n.origin), out(n.phi), out(n.psi),
                              out(n.AP)) for n in self.nodes)
        return SIDBody(self.m, self.names, nodes, taylors, header)


def _per_mode(t: Taylor, nq: int, layout: str, name: str, misfit) -> Taylor:
    """A SID ``Gr``/``Ge`` block brought to the per-mode layout (see Invariants.from_sid)."""
    if layout not in ("auto", "mode", "component"):
        raise DataError(f"layout must be 'auto', 'mode' or 'component', got {layout!r}",
                        item=name)
    rows = t.m0.shape[0]
    by_mode = t.m0.reshape(rows, nq, 3).transpose(1, 0, 2)          # (k, row, b)
    by_comp = t.m0.reshape(rows, 3, nq).transpose(2, 0, 1)
    if layout == "auto":
        layout = "component" if misfit(by_comp) < misfit(by_mode) else "mode"
    blocks = by_comp if layout == "component" else by_mode
    return Taylor.from_arrays(blocks.transpose(1, 0, 2).reshape(rows, 3 * nq), nq=nq)


# ------------------------------------------------------------------------ DOF map
@dataclass(frozen=True)
class _Dofs:
    """Node table and, per node and direction, the DOF index (−1: no such DOF)."""

    n: int
    ids: np.ndarray            # (nn,)
    xyz: np.ndarray            # (nn, 3)
    trans: np.ndarray          # (nn, 3) int
    rot: np.ndarray            # (nn, 3) int
    where: dict = field(default_factory=dict)

    @classmethod
    def of(cls, fe) -> _Dofs:
        nodes = np.asarray(fe.nodes, dtype=np.float64)
        ids = nodes[:, 0].astype(np.int64)
        order = np.argsort(ids)
        dof_node = np.asarray(fe.dof_node).astype(np.int64)
        kinds = np.asarray(fe.dof_kind).astype(str)
        n = dof_node.size
        pos = np.searchsorted(ids[order], dof_node)
        pos = np.clip(pos, 0, ids.size - 1)
        if np.any(ids[order][pos] != dof_node):
            bad = dof_node[ids[order][pos] != dof_node][0]
            raise DataError(f"DOF on unknown node {bad}", fe.source, "dof_node")
        node_of = order[pos]
        trans = np.full((ids.size, 3), -1, dtype=np.int64)
        rot = np.full((ids.size, 3), -1, dtype=np.int64)
        for a, (tk, rk) in enumerate((("ux", "rx"), ("uy", "ry"), ("uz", "rz"))):
            sel = np.nonzero(kinds == tk)[0]
            trans[node_of[sel], a] = sel
            sel = np.nonzero(kinds == rk)[0]
            rot[node_of[sel], a] = sel
        return cls(n, ids, nodes[:, 1:4], trans, rot,
                   {int(i): k for k, i in enumerate(ids)})

    def gather(self, U: np.ndarray, which: str = "trans") -> np.ndarray:
        """(n, p) DOF vectors → (nn, p, 3) node triplets (0 where a DOF is missing)."""
        idx = self.trans if which == "trans" else self.rot
        ok = idx >= 0
        out = np.zeros((idx.shape[0], U.shape[1], 3))
        nodes, comps = np.nonzero(ok)
        out[nodes, :, comps] = U[idx[nodes, comps], :]
        return out

    def scatter(self, T: np.ndarray, which: str = "trans") -> np.ndarray:
        """(nn, p, 3) node triplets → (n, p) DOF vectors (missing DOFs dropped)."""
        idx = self.trans if which == "trans" else self.rot
        nodes, comps = np.nonzero(idx >= 0)
        out = np.zeros((self.n, T.shape[1]))
        out[idx[nodes, comps], :] = T[nodes, :, comps]
        return out

    def rigid_fields(self) -> tuple[np.ndarray, np.ndarray]:
        """``T_t`` and ``T_r`` (n, 3): rigid translation and rotation about the origin."""
        nn = self.ids.size
        eye = np.broadcast_to(np.eye(3), (nn, 3, 3))
        Tt = self.scatter(eye)
        # T_r[:, b] translational = e_b × x: (e_b × x)_a = ε_abk x_k
        tr = np.einsum("abk,ik->iba", LEVI_CIVITA, self.xyz)
        Tr = self.scatter(tr) + self.scatter(eye, "rot")
        return Tt, Tr


def _cross_pair(dofs: _Dofs, F: np.ndarray, MtF: np.ndarray, G: np.ndarray,
                MG: np.ndarray) -> np.ndarray:
    """``C[p, k, b] = ∫ f_p·(e_b × g_k) dm ≈ ½ [Fᵀ M P_b G − (P_b F)ᵀ M G]`` (p, k, 3)."""
    f, g = dofs.gather(F), dofs.gather(G)
    mtf, mg = dofs.gather(MtF), dofs.gather(MG)
    pair = (np.tensordot(mtf, g, axes=([0], [0])).transpose(0, 2, 1, 3)
            - np.tensordot(mg, f, axes=([0], [0])).transpose(2, 0, 1, 3))
    return 0.5 * np.einsum("abc,pkac->pkb", LEVI_CIVITA, pair)


def _cross_fields(dofs: _Dofs, G: np.ndarray) -> list[np.ndarray]:
    """``[P_0 G, P_1 G, P_2 G]``: ``e_b × g`` at the translational DOFs (each (n, k))."""
    g = dofs.gather(G)
    return [dofs.scatter(np.cross(np.eye(3)[b], g)) for b in range(3)]


def _cross_cross(dofs: _Dofs, F: np.ndarray, mpg: np.ndarray) -> np.ndarray:
    """``Q[i, k, a, b] = (P_a F_i)ᵀ M (P_b G_k)`` (nq, nq, 3, 3) from ``mpg`` = the node
    triplets of ``M P_b G`` (nn, nq, 3b, 3c): ``∫ (e_a × f_i)·(e_b × g_k) dm``."""
    f_t = dofs.gather(F)
    pf = np.stack([np.cross(np.eye(3)[a], f_t) for a in range(3)], axis=2)  # (nn,nq,3a,3c)
    nn, nf = f_t.shape[0], F.shape[1]
    ng = mpg.shape[1]
    Q = (pf.transpose(0, 3, 1, 2).reshape(3 * nn, 3 * nf).T
         @ mpg.transpose(0, 3, 1, 2).reshape(3 * nn, 3 * ng))
    return Q.reshape(nf, 3, ng, 3).transpose(0, 2, 1, 3)


def _as_operator(A, n: int, item: str):
    if A is None:
        return None
    if sps.issparse(A):
        A = sps.csr_matrix(A)
    else:
        A = np.asarray(A, dtype=np.float64)
    if A.shape != (n, n):
        raise DataError(f"shape {A.shape}, expected ({n}, {n})", item=item)
    return A


# ---------------------------------------------------------------------------- API
def inertia_loads(fe) -> dict[str, np.ndarray]:
    """The d'Alembert nodal loads of the 12 unit load cases of :data:`LOAD_CASES`.

    Frame acceleration ``e_a``: ``f = −M T_t e_a``; angular acceleration ``e_b``:
    ``f = −M T_r e_b``; centrifugal case ``ω_q[c] = 1``: ``f = −Σ_ab B_c,ab g_ab`` with
    ``g_ab = ½ [M P_a t_b + P_a (M t_b)]`` (``t_b = T_r e_b``; the symmetric cross-product
    form of the module docstring), so that the modal loads are exactly the order-0 terms of
    the elastic rows: ``Wᵀ f = −Ct⁰ e_a``, ``−Cr⁰ e_b``, ``−Oe⁰[:, c]``. Apply them to the body
    supported at its reference frame, compute the stress state and its geometric stiffness
    ``K_G,c``, and pass these to :func:`compute_invariants` (``geometric_stiffness``).

    Returns
    -------
    dict
        Case name → (n,) load vector.
    """
    dofs = _Dofs.of(fe)
    M = sps.csr_matrix(fe.M)
    Tt, Tr = dofs.rigid_fields()
    MTr = M @ Tr
    out = {}
    for a, name in enumerate(("ax", "ay", "az")):
        out[name] = -(M @ Tt[:, a])
    for b, name in enumerate(("alphax", "alphay", "alphaz")):
        out[name] = -MTr[:, b]
    P_t = _cross_fields(dofs, Tr)            # P_t[a][:, b] = P_a t_b
    P_mt = _cross_fields(dofs, MTr)          # P_mt[a][:, b] = P_a (M t_b)
    g = np.stack([0.5 * (M @ P_t[a] + P_mt[a]) for a in range(3)], axis=1)   # (n, 3a, 3b)
    coeff = _omega_q_coefficients(g)                                          # (n, 6)
    for c, name in enumerate(LOAD_CASES[6:]):
        out[name] = -coeff[:, c]
    return out


def inertia_responses(fe, support: Sequence[int],
                      cases: Sequence[str] = LOAD_CASES) -> dict[str, np.ndarray]:
    """The static displacements ``u_c`` of the unit inertia load cases (:func:`inertia_loads`)
    with the DOFs ``support`` fixed: ``K u_c = f_c`` on the others, ``u_c = 0`` on them.

    They span the second-order displacement field of a stiffened body
    (:func:`neweul_py.elastic.second_order.second_order_field`) and give its geometric
    stiffness (:func:`stress_stiffening`).

    Raises
    ------
    DataError
        Unknown cases or support DOFs, or a support that leaves ``K`` singular.
    """
    import scipy.sparse.linalg as spla

    n = fe.K.shape[0]
    bad = [c for c in cases if c not in LOAD_CASES]
    if bad:
        raise DataError(f"unknown load cases {bad}", fe.source, "cases")
    fixed = np.asarray(support, dtype=np.int64)
    if fixed.size and (fixed.min() < 0 or fixed.max() >= n):
        raise DataError(f"support DOFs outside 0…{n - 1}", fe.source, "support")
    free = np.setdiff1d(np.arange(n), fixed)
    Kf = sps.csc_matrix(fe.K)[free][:, free]
    try:
        lu = spla.splu(Kf)
    except RuntimeError as exc:
        raise DataError(f"K is singular on the unsupported DOFs ({exc})", fe.source,
                        "support") from None
    loads = inertia_loads(fe)
    out = {}
    for c in cases:
        u = np.zeros(n)
        u[free] = lu.solve(loads[c][free])
        if not np.all(np.isfinite(u)):
            raise DataError("K is singular on the unsupported DOFs", fe.source, "support")
        out[c] = u
    return out


def stress_stiffening(fe, geometric_stiffness_of, support: Sequence[int],
                      cases: Sequence[str] = LOAD_CASES) -> dict[str, object]:
    """The geometric stiffness of each unit load case, body supported at ``support``.

    Wallrapp's procedure: the d'Alembert loads of a unit frame acceleration, angular
    acceleration or ω-product (:func:`inertia_loads`) are applied to the body held at its
    reference frame (the DOFs ``support`` fixed), the static displacement ``u_c`` solves
    ``K u_c = f_c`` on the remaining DOFs (:func:`inertia_responses`), and
    ``geometric_stiffness_of(u_c)`` — the element formulation's stress stiffness of that
    state — is ``K_G,c``.

    Parameters
    ----------
    fe
        The FE model.
    geometric_stiffness_of
        Callable ``u (n,) → K_G`` (n×n, sparse or dense) of the element formulation.
    support
        DOF indices fixed in the static solutions (e.g. all DOFs of the node at the frame
        origin); must make ``K`` nonsingular on the others.
    cases
        Load cases to compute (default all of :data:`LOAD_CASES`).

    Returns
    -------
    dict
        Case → ``K_G,c``, ready for ``compute_invariants(…, geometric_stiffness=…)``.

    Raises
    ------
    DataError
        Unknown cases or support DOFs, or a support that leaves ``K`` singular.
    """
    return {c: geometric_stiffness_of(u)
            for c, u in inertia_responses(fe, support, cases).items()}


def compute_invariants(
    fe,
    V: np.ndarray,
    W: np.ndarray | None = None,
    *,
    nodes: Sequence[int] = (),
    node_orientations: Mapping[int, np.ndarray] | None = None,
    geometric_stiffness: Mapping[str, object] | None = None,
    ksigma: np.ndarray | None = None,
    names: Sequence[str] | None = None,
) -> Invariants:
    """The floating-frame invariants of §2 from an FE model and bases ``V``, ``W``.

    Parameters
    ----------
    fe
        The :class:`~neweul_py.elastic.fe_model.FEModel` (``M``, ``K``, ``D``, nodes, DOF map);
        the body reference frame is the FE coordinate system.
    V
        (n, nq) right basis: ``x = V q``.
    W
        (n, nq) left basis (test functions); ``None`` for one-sided data (``W = V``).
    nodes
        Ids of the nodes that get node frames (interfaces, outputs).
    node_orientations
        Node id → 3×3 orientation ``AP⁰`` of the node frame (default identity).
    geometric_stiffness
        Load case (:data:`LOAD_CASES`) → n×n geometric stiffness ``K_G,c`` of the stress
        state of a unit value of that case (see :func:`inertia_loads`); missing cases have
        none. Adds ``Wᵀ K_G,c V`` to the first-order parts of ``Ct``, ``Cr``, ``Oe``.
    ksigma
        (nq,) modal forces of reference stresses (default 0).
    names
        Names of the elastic coordinates (default ``q1 … qnq``).

    Returns
    -------
    Invariants

    Raises
    ------
    DataError
        Bases of the wrong shape or not finite, unknown node ids or load cases.

    References
    ----------
    ``docs/equations.md`` §2; Wallrapp 1994; Schwertassek & Wallrapp 1999, ch. 6.

    Examples
    --------
    >>> inv = compute_invariants(fe, V, nodes=[tip_id])           # doctest: +SKIP
    >>> inv.Me.m0, inv.node(tip_id).phi.m0                        # doctest: +SKIP
    """
    dofs = _Dofs.of(fe)
    n = dofs.n
    M = sps.csr_matrix(fe.M)
    Mt = sps.csr_matrix(M.T)
    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[0] != n:
        raise DataError(f"V has shape {V.shape}, expected ({n}, nq)", fe.source, "V")
    nq = V.shape[1]
    two_sided = W is not None
    W = V if W is None else np.asarray(W, dtype=np.float64)
    if W.shape != V.shape:
        raise DataError(f"W has shape {W.shape}, V has {V.shape}", fe.source, "W")
    for key, X in (("V", V), ("W", W)):
        if not np.all(np.isfinite(X)):
            raise DataError("not finite", fe.source, key)
    KG = {}
    for case, A in (geometric_stiffness or {}).items():
        if case not in LOAD_CASES:
            raise DataError(f"unknown load case {case!r} (one of {', '.join(LOAD_CASES)})",
                            fe.source, "geometric_stiffness")
        KG[case] = _as_operator(A, n, f"geometric_stiffness.{case}")

    Tt, Tr = dofs.rigid_fields()
    MTt, MTr = M @ Tt, M @ Tr                 # fields multiplied by M
    MtTt, MtTr = Mt @ Tt, Mt @ Tr             # test fields: Xᵀ M = (Mᵀ X)ᵀ
    MV, MtV = M @ V, Mt @ V
    MtW = MtV if not two_sided else Mt @ W

    # --- mass, first moment, inertia (exact rigid fields)
    m3 = Tt.T @ MTt
    present = dofs.trans.max(axis=0) >= 0
    m = float(np.mean(np.diag(m3)[present])) if present.any() else 0.0
    S = Tr.T @ MTt                            # S[b, a] = ε_abk md_k
    md0 = np.zeros(3)
    for k in range(3):
        vals = [LEVI_CIVITA[a, b, k] * S[b, a] for a in range(3) for b in range(3)
                if LEVI_CIVITA[a, b, k] != 0 and present[a]]
        md0[k] = np.mean(vals) if vals else 0.0
    J0 = Tr.T @ MTr
    J0 = 0.5 * (J0 + J0.T)
    md1 = MtTt.T @ V                          # ∫ Φ dm (3, nq), V

    # --- one-cross-product integrals
    Gr_c = _cross_pair(dofs, Tr, MtTr, V, MV)          # (3, nq, 3): ∫ t_a·(e_b × Φ_k)
    Gr = 2.0 * Gr_c                                    # Gr_k[a, b]
    J1 = 0.5 * (Gr + np.swapaxes(Gr, 0, 2))            # J¹_k = sym Gr_k, as (a, k, b)
    Cr_kin = _cross_pair(dofs, W, MtW, V, MV)          # (nq, nq, 3), W rows
    Crv1 = Cr_kin if not two_sided else _cross_pair(dofs, V, MtV, V, MV)
    Oe0_q = _cross_pair(dofs, W, MtW, Tr, MTr)         # [i, b, a] = ∫ w_i·(e_a × t_b)
    Oe0 = _omega_q_coefficients(np.swapaxes(Oe0_q, 1, 2))

    # --- two-cross-product integrals: Oe¹ = −(P_a W)ᵀ M (P_b V), C2 = (P_a V)ᵀ M (P_b V)
    mpv = np.stack([dofs.gather(M @ P) for P in _cross_fields(dofs, V)], axis=2)
    Q = _cross_cross(dofs, W, mpv)
    Oe1 = -_omega_q_coefficients(Q)                    # (nq, nq, 6)
    C2 = Q if not two_sided else _cross_cross(dofs, V, mpv)

    # --- geometric stiffening (elastic rows)
    Ct1 = np.zeros((nq, nq, 3))
    Cr1 = Cr_kin.copy()
    for a in range(3):
        if (A := KG.get(LOAD_CASES[a])) is not None:
            Ct1[:, :, a] += W.T @ (A @ V)
        if (A := KG.get(LOAD_CASES[3 + a])) is not None:
            Cr1[:, :, a] += W.T @ (A @ V)
    C2g = np.zeros((nq, nq, 3, 3))
    for c, (a, b) in enumerate(OMEGA_PRODUCTS):
        if (A := KG.get(LOAD_CASES[6 + c])) is not None:
            Oe1[:, :, c] += W.T @ (A @ V)
            # the same stiffening as a centrifugal potential −½ ωᵀ J_G(q) ω in the inertia
            # tensor (equations.md §2.1), so that the rotational rows carry its reaction
            kv = V.T @ (A @ V)
            kv = 0.5 * (kv + kv.T)
            if a == b:
                C2g[:, :, a, a] -= kv
            else:
                C2g[:, :, a, b] -= 0.5 * kv
                C2g[:, :, b, a] -= 0.5 * kv

    K = sps.csr_matrix(fe.K)
    Ke = W.T @ (K @ V)
    De = np.zeros((nq, nq)) if fe.D is None else W.T @ (sps.csr_matrix(fe.D) @ V)
    Le = None if getattr(fe, "G", None) is None else W.T @ (sps.csr_matrix(fe.G) @ V)
    ks = np.zeros((nq, 1)) if ksigma is None else np.asarray(ksigma, float).reshape(nq, 1)

    def T(m0, m1=None) -> Taylor:
        return Taylor.from_arrays(m0, m1, nq=nq)

    inv_nodes = _node_frames(dofs, V, W if two_sided else None, nodes,
                             node_orientations or {}, fe.source)
    return Invariants(
        m=m,
        md=T(md0[:, None], md1[:, :, None]),
        J=T(J0, J1),
        Ct=T(MtW.T @ Tt, Ct1),
        Cr=T(MtW.T @ Tr, Cr1),
        Crv=T(MtV.T @ Tr, Crv1),
        Me=T(MtW.T @ V),
        Gr=T(Gr.reshape(3, 3 * nq)),
        Ge=T(2.0 * Cr_kin.reshape(nq, 3 * nq)),
        Oe=T(Oe0, Oe1),
        ksigma=T(ks),
        Ke=T(Ke),
        De=T(De),
        nodes=inv_nodes,
        names=tuple(names) if names is not None else (),
        two_sided=two_sided,
        J2=0.5 * (C2 + C2.transpose(1, 0, 3, 2)) + C2g,
        Le=Le, loss_f_ref=None if Le is None else fe.loss_reference_frequency,
    )


def _node_frames(dofs: _Dofs, V: np.ndarray, W: np.ndarray | None, ids: Sequence[int],
                 orientations: Mapping[int, np.ndarray], source) -> tuple[NodeFrame, ...]:
    ids = [int(i) for i in ids]
    missing = [i for i in ids if i not in dofs.where]
    if missing:
        raise DataError(f"unknown node ids {missing}", source, "nodes")
    bad = [i for i in orientations if int(i) not in dofs.where]
    if bad:
        raise DataError(f"orientation for unknown node ids {bad}", source, "node_orientations")
    if not ids:
        return ()
    nq = V.shape[1]
    rows = np.array([dofs.where[i] for i in ids])
    sub = _Dofs(dofs.n, dofs.ids[rows], dofs.xyz[rows], dofs.trans[rows], dofs.rot[rows])
    phi = sub.gather(V).transpose(0, 2, 1)             # (nk, 3, nq)
    psi = sub.gather(V, "rot").transpose(0, 2, 1)
    phw = psw = None
    if W is not None:
        phw = sub.gather(W).transpose(0, 2, 1)
        psw = sub.gather(W, "rot").transpose(0, 2, 1)
    out = []
    for j, node_id in enumerate(ids):
        AP0 = np.asarray(orientations.get(node_id, np.eye(3)), dtype=np.float64)
        if AP0.shape != (3, 3):
            raise DataError(f"orientation of node {node_id} has shape {AP0.shape}",
                            source, "node_orientations")
        AP1 = np.einsum("kab,bc->akc", skew(psi[j].T), AP0)   # ψ̃_k AP⁰ as (3, nq, 3)
        out.append(NodeFrame(
            node_id,
            Taylor.from_arrays(sub.xyz[j][:, None], phi[j][:, :, None]),
            Taylor.from_arrays(phi[j], nq=nq), Taylor.from_arrays(psi[j], nq=nq),
            Taylor.from_arrays(AP0, AP1),
            None if phw is None else phw[j], None if psw is None else psw[j]))
    return tuple(out)


# ------------------------------------------------------------------ reduced bodies
def attach_invariants(body, fe, *, nodes: Sequence[int] | None = None, **kwargs):
    """The reduced body with its invariants slot filled from ``fe`` and its full bases.

    Parameters
    ----------
    body
        A :class:`~neweul_py.elastic.reduced_body.ReducedBody` holding the full bases
        (``store_bases=True`` in the reductor).
    fe
        The FE model it was reduced from.
    nodes
        Node-frame ids (default: the body's kept nodes).
    **kwargs
        Passed to :func:`compute_invariants` (``geometric_stiffness``, ``ksigma``, …).

    Returns
    -------
    ReducedBody
        ``body.with_(invariants=inv.to_flat())``; read back with :func:`body_invariants`.

    Raises
    ------
    DataError
        The body has no full bases, or they do not fit the FE model.
    """
    if body.V is None or (body.two_sided and body.W is None):
        raise DataError("the reduced body holds no full bases (reduce with store_bases=True)",
                        item="V")
    ids = [int(i) for i in np.asarray(body.nodes)[:, 0]] if nodes is None else nodes
    inv = compute_invariants(fe, body.V, body.W if body.two_sided else None, nodes=ids,
                             **kwargs)
    flat = inv.to_flat()
    # Me, Ke, De are the body's projected M, K, D (same bases): keep the projection's bits, so
    # that the file stores them once (reduced_body.SHARED_INVARIANTS)
    for key, own in (("Me.m0", body.M), ("Ke.m0", body.K), ("De.m0", body.D),
                     ("Le.m0", body.G)):
        if own is not None and key in flat and own.shape == flat[key].shape and np.allclose(
                own, flat[key], rtol=1e-9, atol=1e-12 * max(float(np.abs(own).max()), 1e-300)):
            flat[key] = np.array(own, dtype=np.float64)
    return body.with_(invariants=flat)


def body_invariants(body) -> Invariants | None:
    """The :class:`Invariants` stored in a reduced body's invariants slot (or ``None``)."""
    return None if body.invariants is None else Invariants.from_flat(body.invariants)
