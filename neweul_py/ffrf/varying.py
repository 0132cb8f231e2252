"""Stacks of per-sample arrays stored as one base and the entries that vary.

The samples of a parametric body (its values, slopes and curvatures, docs/equations.md §4)
differ only in a few blocks — in the middle ear the membrane's rows of ``K``, ``D``, ``G``
and the coupling block of ``M``, while the air's blocks and most invariants are the same in
every sample. One encoder, :func:`split_varying`, and one decoder, :func:`ffrf_expand`,
store such a stack ``X`` (k, …) as

* ``base`` (…): the entries that do not vary, from the first sample whose ``base_rows``
  weight is not zero (zero at the entries that vary);
* ``index`` (nv,): the flat positions of the entries that vary, increasing;
* ``varying`` (k, nv): their values per sample,

and read it back as ``X_s = r_s · base`` with ``X_s.flat[index] = varying_s``. ``r``
(``base_rows``, default all ones) weights the base per row of the stack: a stack whose rows
are samples, slopes and curvatures together has ``r = 1`` on the samples and ``0`` on their
derivatives (a constant entry has zero derivatives). The body file
(``neweul_py/elastic/io/layout.py``) and the mixing form of a generated module
(:func:`~neweul_py.ffrf.parametric.ffrf_stack`) use this one pair.

**What is dropped.** An entry is stored as varying when one sample deviates from ``r_s``
times the base by more than ``tol · c_s · scale``; else its samples are replaced by
``r_s · base``. ``scale`` is the entry's scale (:func:`entry_scale`: for matrices the
smaller of the largest magnitude in its row and in its column over the samples, so that
the round-off of an air block whose entries are ~10¹² counts as constant while the small
entries of the membrane's rows count as varying), ``c_s`` a factor per row of the stack
(``row_scale``; e.g. ``1/Δp`` for slopes, ``1/Δp²`` for curvatures, Δp the sampled range,
so that a dropped slope changes the interpolant by at most ``tol`` times the entry's
scale). The bound, for every sample ``s`` and entry ``e``::

    |X̂_s[e] − X_s[e]| ≤ tol · c_s · scale[e],      tol = VARYING_TOLERANCE = 1e-13

and ``tol = 0`` stores every entry that differs at all (exact).

**Mirrored entries.** A stack of symmetric matrices varies in pairs: the membrane's blocks
of ``K``, ``D``, ``G`` of a Galerkin body (``Vᵀ K_s V``) are symmetric at every sample.
:func:`mirror_varying` drops a varying entry ``[i, j]`` below the diagonal of a square
block whose transposed entry ``[j, i]`` varies alike (within the same bound) and lists
it in ``mirror`` (2, m): the flat positions it is copied to and from, after the varying
entries are set. **Scaled blocks.** :func:`scale_varying` leaves out a block that is a
factor times an earlier one (the damping ``D = G/ω_ref`` of loss factors) and lists it in
``scaled``, copied last (:func:`ffrf_derived`, for stacks and mixed rows alike).
:func:`ffrf_expand` and :func:`ffrf_derived` are embedded in generated modules (NumPy
only).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

__all__ = ["VARYING_TOLERANCE", "entry_scale", "ffrf_derived", "ffrf_expand",
           "mirror_varying", "scale_varying", "split_varying"]

#: Default relative tolerance of :func:`split_varying` (module docstring).
VARYING_TOLERANCE = 1e-13


def entry_scale(stack: np.ndarray) -> np.ndarray:
    """The scale of every entry of a stack ``(k, …)`` of samples, of the samples' shape.

    For samples of two or more axes (matrices, and stacks of them) the scale of entry
    ``[…, i, j]`` is ``min(max|X[…, i, :]|, max|X[…, :, j]|)`` over all samples and leading
    axes (the smaller of its row's and its column's largest magnitude); for vectors and
    scalars the largest magnitude of the stack.
    """
    a = np.abs(np.asarray(stack, dtype=np.float64))
    shape = a.shape[1:]
    if len(shape) < 2:
        return np.full(shape, float(a.max(initial=0.0)))
    lead = (0, *range(1, len(shape) - 1))
    rows = a.max(axis=(*lead, a.ndim - 1))          # (n_rows,)
    cols = a.max(axis=(*lead, a.ndim - 2))          # (n_cols,)
    return np.broadcast_to(np.minimum(rows[:, None], cols[None, :]), shape).copy()


def split_varying(stack: np.ndarray, scale: np.ndarray | float | None = None, *,
                  base_rows: np.ndarray | None = None, row_scale: np.ndarray | None = None,
                  tol: float = VARYING_TOLERANCE
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(base, index, varying)`` of a stack ``(k, …)`` (module docstring).

    Parameters
    ----------
    stack
        The samples, first axis.
    scale
        Scale of every entry (the samples' shape, or broadcastable to it); default
        :func:`entry_scale` of the stack.
    base_rows
        ``r`` (k,): the weight of the base in every row; default ones.
    row_scale
        ``c`` (k,): the factor of the tolerance in every row; default ones.
    tol
        Relative tolerance (``0``: exact).

    Returns
    -------
    tuple
        ``base`` (the samples' shape, zero where the entries vary), ``index`` (nv,) int64
        flat positions, ``varying`` (k, nv) float64.
    """
    a = np.asarray(stack, dtype=np.float64)
    k, shape = a.shape[0], a.shape[1:]
    flat = a.reshape(k, -1)
    r = np.ones(k) if base_rows is None else np.asarray(base_rows, dtype=np.float64)
    c = np.ones(k) if row_scale is None else np.asarray(row_scale, dtype=np.float64)
    first = np.flatnonzero(r)
    base = (flat[first[0]] / r[first[0]] if first.size else np.zeros(flat.shape[1])).copy()
    sc = entry_scale(a) if scale is None else scale
    allowed = tol * np.broadcast_to(np.asarray(sc, dtype=np.float64), shape).reshape(-1)
    moving = np.zeros(flat.shape[1], dtype=bool)
    for s in range(k):                       # row by row: no (k, N) temporary
        moving |= np.abs(flat[s] - r[s] * base) > c[s] * allowed
    index = np.flatnonzero(moving).astype(np.int64)
    base[index] = 0.0
    return base.reshape(shape), index, np.ascontiguousarray(flat[:, index])


def mirror_varying(index: np.ndarray, varying: np.ndarray, blocks: Iterable[tuple[int, int]],
                   allowed: np.ndarray, row_scale: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(index, varying, mirror)`` of :func:`split_varying`'s ``index``, ``varying`` with
    the entries below the diagonal of the square blocks that equal their transposed entry
    moved to ``mirror`` (module docstring, "Mirrored entries").

    Parameters
    ----------
    index, varying
        From :func:`split_varying`.
    blocks
        ``(start, n)``: an ``n × n`` matrix in C order at the flat positions
        ``start … start + n² − 1`` of a sample.
    allowed
        The bound of every flat entry, ``tol · scale`` (N,).
    row_scale
        ``c`` (k,): its factor per row of the stack; default ones.

    Returns
    -------
    tuple
        ``index`` (nv′,), ``varying`` (k, nv′) and ``mirror`` (2, m) int64: the flat
        positions set from (row 1) the positions of row 0, increasing in row 0.
    """
    index = np.asarray(index, dtype=np.int64)
    if not index.size:
        return index, varying, np.zeros((2, 0), dtype=np.int64)
    c = np.ones(varying.shape[0]) if row_scale is None else np.asarray(row_scale, float)
    dst, src = [np.zeros(0, dtype=np.int64)], [np.zeros(0, dtype=np.int64)]
    for start, n in blocks:
        lo, hi = np.searchsorted(index, [start, start + n * n])
        i, j = np.divmod(index[lo:hi] - start, n)
        low = np.flatnonzero(i > j) + lo                  # columns below the diagonal
        t = start + (index[low] - start) % n * n + (index[low] - start) // n
        k = np.minimum(np.searchsorted(index, t), index.size - 1)
        hit = index[k] == t
        low, k = low[hit], k[hit]
        near = np.all(np.abs(varying[:, low] - varying[:, k])
                      <= c[:, None] * np.asarray(allowed)[index[low]], axis=0)
        dst.append(index[low[near]])
        src.append(index[k[near]])
    mirror = np.vstack([np.concatenate(dst), np.concatenate(src)])
    mirror = mirror[:, np.argsort(mirror[0], kind="stable")]
    keep = ~np.isin(index, mirror[0])
    return index[keep], np.ascontiguousarray(varying[:, keep]), mirror


def scale_varying(stack: np.ndarray, base: np.ndarray, base_rows: np.ndarray,
                  index: np.ndarray, varying: np.ndarray, mirror: np.ndarray,
                  blocks: Sequence[tuple[int, int]], allowed: np.ndarray,
                  row_scale: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(index, varying, mirror, scaled)``: the blocks of a stack ``(k, N)`` that are a
    factor times an earlier block of the same size (``D = G/ω_ref``) left out of
    :func:`split_varying`'s ``index``, ``varying`` and :func:`mirror_varying`'s ``mirror``
    and listed in ``scaled`` (m, 4) float64 rows ``[start, stop, source start, factor]``.

    A block is scaled when ``factor`` times the source block *as read back*
    (:func:`ffrf_expand`) is within ``c_s · allowed`` of the block in every row, the bound
    of the stack; ``blocks`` are ``(start, stop)`` column ranges, ``allowed`` (N,) and
    ``row_scale`` (k,) as in :func:`mirror_varying`.
    """
    c = np.ones(stack.shape[0]) if row_scale is None else np.asarray(row_scale, float)
    rows = []
    for n, (start, stop) in enumerate(blocks):
        for src, src_stop in blocks[:n]:
            if src_stop - src != stop - start or any(r[0] == src for r in rows):
                continue
            b = _read_columns(base, base_rows, index, varying, mirror, src, src_stop)
            peak = np.unravel_index(np.argmax(np.abs(b)), b.shape)
            if b[peak] == 0:
                continue
            factor = float(stack[(peak[0], start + peak[1])] / b[peak])
            if factor != 0 and np.all(np.abs(stack[:, start:stop] - factor * b)
                                      <= c[:, None] * allowed[start:stop]):
                rows.append((start, stop, src, factor))
                break
    scaled = np.array(rows, dtype=np.float64).reshape(-1, 4)
    out = np.zeros(base.size, dtype=bool)
    for start, stop, _src, _f in rows:
        out[start:stop] = True
    keep, mkeep = ~out[index], ~out[mirror[0]]
    return index[keep], np.ascontiguousarray(varying[:, keep]), mirror[:, mkeep], scaled


def _read_columns(base, base_rows, index, varying, mirror, start, stop):
    """Columns ``start:stop`` of :func:`ffrf_expand` of the stack (the others not built;
    a mirror pair stays inside one square block)."""
    lo, hi = np.searchsorted(index, [start, stop])
    inside = (mirror[0] >= start) & (mirror[0] < stop)
    return ffrf_expand(base[start:stop], base_rows, index[lo:hi] - start, varying[:, lo:hi],
                       mirror[:, inside] - start)


def ffrf_expand(base, base_rows, index, varying, mirror=None, scaled=None):
    """The stack ``(k, …)`` of :func:`split_varying`'s ``base`` (…), ``base_rows`` (k,),
    ``index`` (nv,) and ``varying`` (k, nv): ``r_s · base`` with the varying entries set,
    then the mirrored and scaled ones (:func:`ffrf_derived`)."""
    base = np.asarray(base)
    out = np.multiply.outer(np.asarray(base_rows, dtype=np.float64), base.reshape(-1))
    out[:, np.asarray(index, dtype=np.intp)] = varying
    ffrf_derived(out, mirror, scaled)
    return out.reshape((out.shape[0], *base.shape))


def ffrf_derived(flat, mirror=None, scaled=None):
    """Set, in place, the entries of ``flat`` (…, N) that are copies: the mirrored ones
    (``mirror`` (2, m) of :func:`mirror_varying`: row 0 from row 1), then the scaled blocks
    (``scaled`` (m, 4) of :func:`scale_varying`: ``[start, stop)`` as the factor times the
    block at the source). For a stack and for a mixed row ``w B`` alike (both linear)."""
    if mirror is not None and np.size(mirror):
        flat[..., np.asarray(mirror[0], dtype=np.intp)] = flat[
            ..., np.asarray(mirror[1], dtype=np.intp)]
    for start, stop, src, factor in (() if scaled is None else np.asarray(scaled)):
        i, j, k = int(start), int(stop), int(src)
        flat[..., i:j] = factor * flat[..., k:k + j - i]
    return flat
