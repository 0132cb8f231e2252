"""A stack of per-sample arrays as one base and the entries that vary
(``neweul_py.ffrf.varying``).

Reference: the stack itself — read back, every entry is within the documented bound
``tol · c_s · scale`` of the written one, and exact with ``tol = 0`` — and the block structure
the stacks are built with (which entries vary is known by construction).
"""

from __future__ import annotations

import numpy as np

from neweul_py.ffrf.varying import (
    VARYING_TOLERANCE,
    entry_scale,
    ffrf_expand,
    mirror_varying,
    scale_varying,
    split_varying,
)

K, NU, NP = 5, 6, 3


def _up_stack(rng: np.random.Generator) -> np.ndarray:
    """A u–p matrix per sample: the structural rows (small entries) vary, the pressure block
    (entries ~1e12) varies at round-off only, the block below the structure is zero."""
    base = np.zeros((NU + NP, NU + NP))
    base[:NU, :] = 1e-3 * rng.standard_normal((NU, NU + NP))
    base[NU:, NU:] = 1e12 * (2.0 + rng.standard_normal((NP, NP)))
    stack = np.repeat(base[None], K, axis=0)
    stack[:, :NU, :] += 1e-6 * rng.standard_normal((K, NU, NU + NP))      # the membrane
    stack[:, NU:, NU:] *= 1.0 + 1e-16 * rng.standard_normal((K, NP, NP))  # round-off
    return stack


def test_round_off_of_large_entries_is_constant_small_variations_vary() -> None:
    """The structural rows vary (stored), the pressure block's round-off does not (its
    scale is its own row's, ~1e12), the zero block is not stored; read back within
    ``tol · scale`` entry by entry."""
    stack = _up_stack(np.random.default_rng(0))
    base, index, varying = split_varying(stack)
    expected = np.zeros((NU + NP, NU + NP), dtype=bool)
    expected[:NU, :] = True
    assert np.array_equal(np.sort(index), np.flatnonzero(expected))
    assert varying.shape == (K, index.size) and base.shape == stack.shape[1:]
    back = ffrf_expand(base, np.ones(K), index, varying)
    bound = VARYING_TOLERANCE * entry_scale(stack)
    assert np.all(np.abs(back - stack) <= bound)
    assert np.array_equal(back[:, :NU], stack[:, :NU])          # what varies: bit for bit


def test_zero_tolerance_is_exact() -> None:
    """``tol = 0`` keeps every entry that differs at all: the round trip is bit for bit."""
    stack = _up_stack(np.random.default_rng(1))
    base, index, varying = split_varying(stack, tol=0.0)
    assert np.array_equal(ffrf_expand(base, np.ones(K), index, varying), stack)
    constant = np.repeat(stack[:1], K, axis=0)
    base, index, varying = split_varying(constant, tol=0.0)
    assert index.size == 0 and np.array_equal(base, stack[0])


def test_rows_of_derivatives_have_a_zero_base_and_their_own_scale() -> None:
    """Samples with their slopes interleaved (``base_rows`` 1, 0, …): a column whose values
    are equal and whose slopes are zero is the base; a slope beyond ``tol · c · scale``
    (``c = 1/Δσ``) makes its column vary; the read-back is the stack."""
    rng = np.random.default_rng(2)
    values = np.repeat(rng.standard_normal((1, 8)), K, axis=0)
    slopes = np.zeros((K, 8))
    values[:, 3] += rng.standard_normal(K)
    slopes[:, 3] = rng.standard_normal(K)
    slopes[:, 5] = 1e-20                       # far below 1e-13 · scale / Δσ: dropped
    slopes[:, 6] = 1e-9                        # above it: kept
    stack = np.empty((2 * K, 8))
    stack[0::2], stack[1::2] = values, slopes
    rows = np.tile([1.0, 0.0], K)
    span = 4.0
    scale = np.abs(values).max()
    base, index, varying = split_varying(stack, scale, base_rows=rows,
                                         row_scale=span ** -np.tile([0.0, 1.0], K))
    assert index.tolist() == [3, 6]
    back = ffrf_expand(base, rows, index, varying)
    assert np.array_equal(back[0::2], values)
    assert np.all(np.abs(back[1::2] - slopes) <= VARYING_TOLERANCE * scale / span)


def test_entry_scale_is_the_smaller_of_row_and_column_maxima() -> None:
    """Matrices: ``min(max|row|, max|column|)`` over the samples; vectors: the stack's
    largest magnitude (reference: the definition, computed by loops)."""
    rng = np.random.default_rng(3)
    stack = rng.standard_normal((3, 4, 5)) * np.logspace(0, 6, 5)
    scale = entry_scale(stack)
    for i in range(4):
        for j in range(5):
            ref = min(np.abs(stack[:, i, :]).max(), np.abs(stack[:, :, j]).max())
            assert scale[i, j] == ref
    vec = rng.standard_normal((3, 7))
    assert np.all(entry_scale(vec) == np.abs(vec).max())


def test_mirrored_entries_of_symmetric_blocks_are_stored_once() -> None:
    """A stack of matrices whose varying block is symmetric (within the bound) keeps the
    entries on and above the diagonal; the ones below are copied back from their transposed
    entries, within ``tol · c_s · scale``; an unsymmetric block and the columns after the
    square block stay as they are (reference: the stack itself)."""
    rng = np.random.default_rng(5)
    k, n = 4, 6
    A = rng.standard_normal((k, n, n))
    A = A + A.transpose(0, 2, 1)
    A[:, 0, 1] += 1e-3 * np.arange(k)                 # one unsymmetric pair: kept whole
    A[:, 2, 4] += 1e-15 * rng.standard_normal(k)      # round-off: mirrored
    tail = rng.standard_normal((k, 5))
    X = np.concatenate([A.reshape(k, -1), tail], axis=1)
    scale = np.concatenate([entry_scale(A).ravel(), np.ones(5)])
    base, index, varying = split_varying(X, scale)
    index2, varying2, mirror = mirror_varying(index, varying, [(0, n)],
                                              VARYING_TOLERANCE * scale)
    pairs = n * (n - 1) // 2
    assert mirror.shape == (2, pairs - 1) and np.all(mirror[0] // n > mirror[0] % n)
    assert 1 * n + 0 not in mirror[0] and 4 * n + 2 in mirror[0]
    assert index2.size == index.size - (pairs - 1) and varying2.shape == (k, index2.size)
    back = ffrf_expand(base, np.ones(k), index2, varying2, mirror)
    assert np.all(np.abs(back - X) <= VARYING_TOLERANCE * scale)
    np.testing.assert_array_equal(back[:, n * n:], tail)
    assert np.array_equal(ffrf_expand(base, np.ones(k), index, varying), X)
    none = mirror_varying(index[:0], varying[:, :0], [(0, n)], scale)
    assert none[2].shape == (2, 0)


def test_a_block_that_is_a_factor_times_another_is_stored_as_the_factor() -> None:
    """Of two blocks ``G`` and ``D = G/ω_ref`` (with round-off in ``D``) only ``G`` is stored;
    ``D`` is read back as the factor times ``G`` as read back, within the bound; a block
    that is not proportional stays (reference: the stack itself)."""
    rng = np.random.default_rng(9)
    k, n, c = 4, 5, 1 / (2 * np.pi * 1000.0)
    G = rng.standard_normal((k, n * n))
    D = c * G * (1 + 1e-16 * rng.standard_normal(G.shape))
    other = rng.standard_normal((k, n * n))
    X = np.hstack([G, D, other])
    scale = np.concatenate([np.full(n * n, np.abs(G).max()), np.full(n * n, np.abs(D).max()),
                            np.full(n * n, np.abs(other).max())])
    allowed = VARYING_TOLERANCE * scale
    base, index, varying = split_varying(X, scale)
    none = np.zeros((2, 0), dtype=np.int64)
    blocks = [(0, n * n), (n * n, 2 * n * n), (2 * n * n, 3 * n * n)]
    i2, v2, m2, scaled = scale_varying(X, base, np.ones(k), index, varying, none, blocks,
                                       allowed)
    np.testing.assert_allclose(scaled, [[n * n, 2 * n * n, 0, c]], rtol=1e-14)
    assert i2.size == index.size - n * n and v2.shape == (k, i2.size) and m2.shape == (2, 0)
    back = ffrf_expand(base, np.ones(k), i2, v2, m2, scaled)
    assert np.all(np.abs(back - X) <= allowed)
    np.testing.assert_array_equal(back[:, 2 * n * n:], other)
