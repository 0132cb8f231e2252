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
``tests/support/beam_fe.py`` for Euler–Bernoulli beams).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ...errors import DataError
from ...ffrf import (
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
    "LEVI_CIVITA",
    "LOAD_CASES",
    "OMEGA_PRODUCTS",
    "Invariants",
    "NodeFrame",
    "QuadraticField",
    "body_invariants",
    "omega_products",
    "skew",
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
    :func:`neweul_py.elastic.reductors.second_order.second_order_field`.

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

    def __post_init__(self) -> None:
        """``A`` (ny, nq, nq) finite and the extended body of ``nq + ny`` coordinates."""
        if not isinstance(self.body, Invariants):
            raise DataError(f"must be Invariants, got {type(self.body).__name__}",
                            item="quad")
        A = np.asarray(self.A, dtype=np.float64)
        if A.ndim != 3 or A.shape[1] != A.shape[2] or not np.all(np.isfinite(A)):
            raise DataError(f"must be finite (ny, nq, nq), got shape {A.shape}", item="quad.A")
        if self.body.nq != A.shape[0] + A.shape[1]:
            raise DataError(f"{A.shape[0]} quadratic and {A.shape[1]} elastic coordinates for "
                            f"an extended body of {self.body.nq}", item="quad.A")
        object.__setattr__(self, "A", A)

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

    All matrices are :class:`~neweul_py.elastic.bodies.taylor.Taylor` objects in the conventions of
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
        if self.quadratic is not None and self.quadratic.A.shape[1] != nq:
            raise DataError(f"a second-order field of {self.quadratic.A.shape[1]} elastic "
                            f"coordinates, the body has {nq}", item="quad.A")
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


def body_invariants(body) -> Invariants | None:
    """The :class:`Invariants` stored in a reduced body's invariants slot (or ``None``)."""
    return None if body.invariants is None else Invariants.from_flat(body.invariants)
