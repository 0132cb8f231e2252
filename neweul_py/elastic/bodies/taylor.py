"""Taylor objects: matrices that depend linearly on the elastic coordinates.

Every invariant of the floating frame of reference (``docs/equations.md`` §2) is a Taylor
expansion in the elastic coordinates ``q`` (Wallrapp 1994, "Standardization of flexible body
modeling in multibody system codes, Part I"; Schwertassek & Wallrapp 1999, ch. 6)::

    X(q) = X⁰ + Σ_k X¹_k q_k,      X⁰: (nrow, ncol),  X¹: (nrow, nq, ncol)

The index order of ``m1`` is the one of the SID text format, ``m1(row, mode, column)``.
The SID ``structure`` flag says how the matrices are stored in a file (``0`` zero, ``1``
diagonal, ``2`` symmetric, ``3`` full, ``4`` identity); here the arrays are always held
expanded (full), the flag is kept so that a file can be written back the way it was read.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from ...errors import DataError

__all__ = ["STRUCTURES", "Taylor"]

#: SID structure flags.
STRUCTURES = {0: "zero", 1: "diagonal", 2: "symmetric", 3: "full", 4: "identity"}


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Taylor:
    """A Taylor object ``X(q) = m0 + Σ_k m1[:, k, :] q_k`` (Wallrapp 1994).

    Parameters
    ----------
    order
        0 (constant) or 1 (linear in ``q``).
    nrow, ncol
        Size of the matrix.
    nq
        Number of elastic coordinates the first-order part refers to (kept as given for
        order 0; SID writers put either 0 or the number of modes there).
    nqn
        Number of coordinates of higher-order terms (always 0 here).
    structure
        SID storage flag (:data:`STRUCTURES`); the arrays are held expanded regardless.
    m0
        (nrow, ncol) constant part.
    m1
        (nrow, nq, ncol) first-order part, ``None`` for order 0.

    Raises
    ------
    DataError
        Inconsistent sizes, an unknown structure, or arrays that contradict the structure
        flag (e.g. a non-symmetric matrix flagged symmetric).

    Examples
    --------
    >>> t = Taylor.from_arrays(np.eye(2), np.ones((2, 3, 2)))
    >>> t.evaluate([1.0, 0.0, 0.0]).tolist()
    [[2.0, 1.0], [1.0, 2.0]]
    """

    order: int
    nrow: int
    ncol: int
    nq: int
    nqn: int
    structure: int
    m0: np.ndarray
    m1: np.ndarray | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        for key in ("order", "nrow", "ncol", "nq", "nqn", "structure"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, int | np.integer) or v < 0:
                raise DataError(f"{key} must be a non-negative integer, got {v!r}", item=key)
            set_(self, key, int(v))
        if self.order not in (0, 1):
            raise DataError(f"only orders 0 and 1 are supported, got {self.order}", item="order")
        if self.nqn != 0:
            raise DataError(f"higher-order terms (nqn = {self.nqn}) are not supported", item="nqn")
        if self.structure not in STRUCTURES:
            raise DataError(f"unknown structure {self.structure} (0…4)", item="structure")
        m0 = _frozen(self.m0)
        if m0.shape != (self.nrow, self.ncol):
            raise DataError(f"m0 has shape {m0.shape}, expected {(self.nrow, self.ncol)}",
                            item="m0")
        set_(self, "m0", m0)
        if self.order == 0:
            if self.m1 is not None:
                raise DataError("an order-0 Taylor object has no m1", item="m1")
        else:
            m1 = np.zeros((self.nrow, self.nq, self.ncol)) if self.m1 is None else self.m1
            m1 = _frozen(m1)
            if m1.shape != (self.nrow, self.nq, self.ncol):
                raise DataError(f"m1 has shape {m1.shape}, expected "
                                f"{(self.nrow, self.nq, self.ncol)}", item="m1")
            set_(self, "m1", m1)
        self._check_structure()

    def _check_structure(self) -> None:
        s = self.structure
        mats = [self.m0] + ([] if self.m1 is None else [self.m1.transpose(1, 0, 2)])
        if s in (1, 2, 4) and self.nrow != self.ncol:
            raise DataError(f"structure {s} ({STRUCTURES[s]}) needs a square matrix, got "
                            f"{self.nrow}×{self.ncol}", item="structure")
        if s == 0 and any(np.any(a) for a in mats):
            raise DataError("structure 0 (zero) but nonzero entries", item="structure")
        if s == 4:
            if not np.array_equal(self.m0, np.eye(self.nrow)) or (
                    self.m1 is not None and np.any(self.m1)):
                raise DataError("structure 4 (identity) but not the identity",
                                item="structure")
        if s == 1:
            off = ~np.eye(self.nrow, dtype=bool)
            if any(np.any(a[..., off]) for a in mats):
                raise DataError("structure 1 (diagonal) but off-diagonal entries",
                                item="structure")
        if s == 2:
            for a in mats:
                if not np.array_equal(a, np.swapaxes(a, -1, -2)):
                    raise DataError("structure 2 (symmetric) but not symmetric",
                                    item="structure")

    # ----------------------------------------------------------------- constructors
    @classmethod
    def from_arrays(cls, m0: np.ndarray, m1: np.ndarray | None = None, *,
                    nq: int | None = None, structure: int = 3) -> Taylor:
        """A Taylor object from expanded arrays (order 1 iff ``m1`` is given).

        ``nq`` defaults to ``m1.shape[1]`` (order 1) or 0 (order 0).
        """
        m0 = np.asarray(m0, dtype=np.float64)
        if m0.ndim != 2:
            raise DataError(f"m0 must be 2-D, got shape {m0.shape}", item="m0")
        if m1 is None:
            return cls(0, m0.shape[0], m0.shape[1], nq or 0, 0, structure, m0, None)
        m1 = np.asarray(m1, dtype=np.float64)
        if m1.ndim != 3:
            raise DataError(f"m1 must be 3-D (row, mode, column), got shape {m1.shape}",
                            item="m1")
        return cls(1, m0.shape[0], m0.shape[1], m1.shape[1] if nq is None else nq, 0,
                   structure, m0, m1)

    @classmethod
    def from_entries(cls, order: int, nrow: int, ncol: int, nq: int, nqn: int,
                     structure: int,
                     m0_entries: Iterable[tuple[int, int, float]] = (),
                     m1_entries: Iterable[tuple[int, int, int, float]] = ()) -> Taylor:
        """Expand the (1-based) entries of a SID block according to ``structure``.

        ``m0_entries`` are ``(i, j, value)``, ``m1_entries`` ``(i, k, j, value)``; entries not
        listed are zero. Structure 2 (symmetric) mirrors each entry (the mean where both
        triangles are listed, as some exporters do); 4 is the identity
        (no entries); 0 is zero (no entries). Index and structure checks are the caller's
        (the SID parser reports them with line numbers).
        """
        m0 = np.zeros((nrow, ncol))
        m1 = np.zeros((nrow, nq, ncol)) if order == 1 else None
        if structure == 4:
            m0 = np.eye(nrow, ncol)
        s0: dict[tuple[int, int], list[float]] = {}
        s1: dict[tuple[int, int, int], list[float]] = {}
        for i, j, v in m0_entries:
            if structure == 2:
                s0.setdefault((max(i, j), min(i, j)), []).append(v)
            else:
                m0[i - 1, j - 1] = v
        for i, k, j, v in m1_entries if m1 is not None else ():
            if structure == 2:
                s1.setdefault((max(i, j), k, min(i, j)), []).append(v)
            else:
                m1[i - 1, k - 1, j - 1] = v
        # symmetric: one triangle is enough; where both are listed, take the mean
        for (i, j), vals in s0.items():
            m0[i - 1, j - 1] = m0[j - 1, i - 1] = float(np.mean(vals))
        for (i, k, j), vals in s1.items():
            m1[i - 1, k - 1, j - 1] = m1[j - 1, k - 1, i - 1] = float(np.mean(vals))
        return cls(order, nrow, ncol, nq, nqn, structure, m0, m1)

    # ------------------------------------------------------------------- evaluation
    def evaluate(self, q: np.ndarray | Iterable[float] | None = None) -> np.ndarray:
        """``X(q) = m0 + Σ_k m1[:, k, :] q_k``, vectorized over leading axes of ``q``.

        Parameters
        ----------
        q
            (..., nq) elastic coordinates; ``None`` gives ``m0``.

        Returns
        -------
        numpy.ndarray
            (..., nrow, ncol).
        """
        if q is None:
            return self.m0.copy()
        q = np.asarray(q, dtype=np.float64)
        if self.order == 0:
            return np.broadcast_to(self.m0, q.shape[:-1] + self.m0.shape).copy()
        if q.shape[-1] != self.nq:
            raise DataError(f"q has {q.shape[-1]} entries, the Taylor object has nq = "
                            f"{self.nq}", item="q")
        return self.m0 + np.einsum("ikj,...k->...ij", self.m1, q)

    def m1_matrix(self, column: int) -> np.ndarray:
        """The (nrow, nq) matrix ``m1[:, :, column]`` (e.g. one ``Oe`` column, q-coefficients)."""
        if self.m1 is None:
            return np.zeros((self.nrow, self.nq))
        return self.m1[:, :, column].copy()

    # --------------------------------------------------------------------- helpers
    def with_order(self, order: int) -> Taylor:
        """The same object raised to order 1 (zero ``m1``) or cut to order 0 (drops ``m1``)."""
        if order == self.order:
            return self
        if order == 0:
            return Taylor(0, self.nrow, self.ncol, self.nq, 0, self.structure, self.m0)
        return Taylor(1, self.nrow, self.ncol, self.nq, 0, self.structure, self.m0,
                      np.zeros((self.nrow, self.nq, self.ncol)))

    def with_structure(self, structure: int | None = None) -> Taylor:
        """A copy flagged ``structure``; ``None`` picks the most compact valid flag."""
        if structure is None:
            structure = self.natural_structure()
        return Taylor(self.order, self.nrow, self.ncol, self.nq, self.nqn, structure,
                      self.m0, self.m1)

    def natural_structure(self) -> int:
        """The most compact flag the arrays satisfy: 0 zero, 4 identity, 1 diagonal,
        2 symmetric, else 3."""
        mats = [self.m0] + ([] if self.m1 is None else [self.m1.transpose(1, 0, 2)])
        if not any(np.any(a) for a in mats):
            return 0
        if self.nrow != self.ncol:
            return 3
        if np.array_equal(self.m0, np.eye(self.nrow)) and (
                self.m1 is None or not np.any(self.m1)):
            return 4
        off = ~np.eye(self.nrow, dtype=bool)
        if not any(np.any(a[..., off]) for a in mats):
            return 1
        if all(np.array_equal(a, np.swapaxes(a, -1, -2)) for a in mats):
            return 2
        return 3

    def entries(self) -> tuple[list[tuple[int, int, float]], list[tuple[int, int, int, float]]]:
        """The nonzero (1-based) entries a SID file lists for this object.

        Structure 0 and 4 list nothing, 1 only diagonal entries, 2 the lower triangle
        (``i ≥ j``), 3 all nonzero entries; m0 row-major, m1 by row, mode, column.
        """
        s = self.structure
        if s in (0, 4):
            return [], []
        keep = np.ones((self.nrow, self.ncol), dtype=bool)
        if s == 1:
            keep = np.eye(self.nrow, dtype=bool)
        elif s == 2:
            keep = np.tril(keep)
        i0, j0 = np.nonzero((self.m0 != 0) & keep)
        e0 = [(int(i) + 1, int(j) + 1, float(self.m0[i, j])) for i, j in zip(i0, j0,
                                                                             strict=True)]
        e1: list[tuple[int, int, int, float]] = []
        if self.m1 is not None:
            i1, k1, j1 = np.nonzero((self.m1 != 0) & keep[:, None, :])
            e1 = [(int(i) + 1, int(k) + 1, int(j) + 1, float(self.m1[i, k, j]))
                  for i, k, j in zip(i1, k1, j1, strict=True)]
        return e0, e1

    def equals(self, other: Taylor, *, rtol: float = 0.0, atol: float = 0.0) -> bool:
        """Same order and sizes and (within tolerances) the same arrays."""
        if (self.order, self.nrow, self.ncol) != (other.order, other.nrow, other.ncol):
            return False
        if not np.allclose(self.m0, other.m0, rtol=rtol, atol=atol):
            return False
        if self.order == 1:
            return self.m1.shape == other.m1.shape and bool(
                np.allclose(self.m1, other.m1, rtol=rtol, atol=atol))
        return True

    def transformed(self, left: np.ndarray | None = None,
                    right: np.ndarray | None = None,
                    modes: np.ndarray | None = None) -> Taylor:
        """``L X(q) R`` with the elastic coordinates changed by ``q = T q̃`` (``modes = T``).

        Used to check invariance under a change of modal basis: with ``V → V T`` and
        ``W → W S`` the elastic-row invariants transform with ``left = Sᵀ`` and the
        first-order terms with ``modes = T``.
        """
        m0 = self.m0
        m1 = self.m1
        if left is not None:
            m0 = left @ m0
            m1 = None if m1 is None else np.einsum("ab,bkj->akj", left, m1)
        if right is not None:
            m0 = m0 @ right
            m1 = None if m1 is None else np.einsum("akj,jb->akb", m1, right)
        if modes is not None and m1 is not None:
            m1 = np.einsum("akj,kl->alj", m1, modes)
        return Taylor.from_arrays(m0, m1)
