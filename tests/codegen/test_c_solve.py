"""The linear solve of the compiled backend (codegen/c_solve.py): dense LU or block
elimination of a constant block of the mass matrix."""

from __future__ import annotations

import hashlib
import types

import numpy as np
import pytest
import sympy as sp
from compiler import needs_c_compiler

from neweul_py.codegen.c_runtime import compiled_library
from neweul_py.codegen.c_solve import c_solver, constant_block
from neweul_py.codegen.c_templates import C_LU
from neweul_py.ffrf import MAX_BLOCK_CONDITION

pytestmark = needs_c_compiler


def _symbolic(a: np.ndarray, varying: set[int]) -> sp.ImmutableMatrix:
    """``a`` as a sympy matrix whose rows and columns ``varying`` hold ``a_ij + 0·x`` with a
    symbol ``x`` (not numbers), the rest plain numbers."""
    x = sp.Symbol("x")
    n = a.shape[0]
    return sp.ImmutableMatrix(n, n, [sp.Float(a[i, j]) + (x if i in varying or j in varying
                                                          else 0)
                                     for i in range(n) for j in range(n)])


def _solver(tmp_path, a_sym, n):
    """``solve(a, m, b)`` (``nw_factor`` and ``nw_factored_solve``, as ``rhs_jacobian``) and
    ``solve1(a, b)`` (``nw_solve1``, as ``rhs``): two libraries, each with one form."""
    head = "#include <math.h>\n#include <string.h>\n" + f"#define NW_N {n}\n" + C_LU
    block = constant_block(a_sym)
    texts = {
        "solve": head + c_solver(block, factored=True)
        + "int solve(double *a, int m, double *b)\n"
          "{ nw_fac f; if (nw_factor(a, &f)) return 1; nw_factored_solve(a, &f, m, b);"
          " return 0; }\n",
        "solve1": head + c_solver(block)
        + "int solve1(double *a, double *b) { return nw_solve1(a, b); }\n",
    }
    cdef = "int solve(double *a, int m, double *b); int solve1(double *a, double *b);"
    libs, ffi = {}, None
    for key, src in texts.items():      # one FFI for both (its buffers are passed to both)
        c_path = tmp_path / f"{key}{n}_{hashlib.sha256(src.encode()).hexdigest()[:8]}.c"
        c_path.write_text(src)
        ffi, libs[key], _ = compiled_library(c_path, hashlib.sha256(src.encode()).hexdigest(),
                                             cdef, tmp_path / "cache", ffi=ffi)
    return ffi, types.SimpleNamespace(**{k: getattr(v, k) for k, v in libs.items()})


@pytest.mark.parametrize(("n", "varying", "diagonal"),
                         [(6, {0, 1}, False), (5, set(), False), (7, {3}, False),
                          (4, {0, 1, 2}, False), (7, {0, 4}, False), (6, {0, 1}, True),
                          (7, {2, 5}, True), (70, set(range(70)), False)])
def test_solve_equals_lapack(n, varying, diagonal, tmp_path):
    """Reference: numpy.linalg.solve (LAPACK gesv) on random unsymmetric matrices, several
    right-hand sides and one (``nw_solve1``): the block elimination (constant rows/columns
    outside ``varying``; all constant; a constant block split by a varying coordinate;
    ``R`` not one range; a diagonal constant block, whose inverse is stored as a diagonal)
    and the dense LU (one constant coordinate only; 70 unknowns, whose elimination and
    substitutions take the vectorized ``nw_lu_rows`` and ``nw_dotn``) give the same solution."""
    rng = np.random.default_rng(n)
    a = rng.standard_normal((n, n)) + n * np.eye(n)
    if diagonal:
        const = [j for j in range(n) if j not in varying]
        d = a[np.ix_(const, const)]
        a[np.ix_(const, const)] = np.diag(np.diag(d))
    b = rng.standard_normal((n, 3))
    block = constant_block(_symbolic(a, varying))
    assert (block is None) == (n - len(varying) < 2)
    if block is not None:
        assert block.block == tuple(j for j in range(n) if j not in varying)
    ffi, lib = _solver(tmp_path, _symbolic(a, varying), n)
    c_text = c_solver(constant_block(_symbolic(a, varying)))
    assert ("NW_DD" in c_text) == (diagonal and block is not None)
    aa, bb = a.copy(), b.copy()
    assert lib.solve(ffi.from_buffer("double[]", aa), 3, ffi.from_buffer("double[]", bb)) == 0
    np.testing.assert_allclose(bb, np.linalg.solve(a, b), rtol=1e-12, atol=1e-12)
    aa, b1 = a.copy(), b[:, 0].copy()
    assert lib.solve1(ffi.from_buffer("double[]", aa), ffi.from_buffer("double[]", b1)) == 0
    np.testing.assert_allclose(b1, np.linalg.solve(a, b[:, 0]), rtol=1e-12, atol=1e-12)


def test_inverse_drops_only_entries_below_the_products_rounding_error(tmp_path):
    """Reference: the exact inverses and numpy.linalg.solve — the inverse of ``D = I + E``
    with off-diagonal ``|E_ij| ≈ 1e-16`` (the constant ``Mee`` of mass-normalized modes)
    becomes diagonal (its off-diagonal entries are below ``n·ε·√(X_ii X_jj)``), an entry of
    1e-6 stays, and a badly scaled block (``S (I + F) S``, ``S = diag(1, 0.1, 3)``,
    ``cond`` ≈ 1e3) keeps every entry: its solve equals LAPACK's; so does ``diag(1, 9e3)``,
    at the largest condition number accepted (``MAX_BLOCK_CONDITION`` = 1e4, shared with
    the NumPy kernel)."""
    rng = np.random.default_rng(0)
    n = 20
    d = np.eye(n) + 1e-16 * rng.standard_normal((n, n))
    block = constant_block(_symbolic(d, set()))
    assert np.count_nonzero(block.inverse - np.diag(np.diag(block.inverse))) == 0
    d[3, 5] = 1e-6
    block = constant_block(_symbolic(d, set()))
    assert block.inverse[3, 5] != 0.0
    s = np.diag([1.0, 0.1, 3.0, 1.0])
    a = s @ (np.eye(4) + 0.3 * rng.standard_normal((4, 4))) @ s
    a[:, 3] = a[3, :] = [0.2, 0.1, 0.3, 5.0]   # coordinate 3 varying (the rest R)
    block = constant_block(_symbolic(a, {3}))
    exact = np.linalg.inv(a[:3, :3])
    assert np.count_nonzero(block.inverse) == np.count_nonzero(exact) == 9
    assert np.linalg.cond(a[:3, :3]) > 100.0
    edge = constant_block(_symbolic(np.diag([1.0, 9e3]), set()))   # cond 9e3 ≤ 1e4
    np.testing.assert_array_equal(edge.inverse, np.diag([1.0, 1 / 9e3]))
    ffi, lib = _solver(tmp_path, _symbolic(a, {3}), 4)
    b = rng.standard_normal(4)
    aa, bb = a.copy(), b.copy()
    assert lib.solve1(ffi.from_buffer("double[]", aa), ffi.from_buffer("double[]", bb)) == 0
    np.testing.assert_allclose(bb, np.linalg.solve(a, b), rtol=1e-10)


def test_singular_schur_complement_is_reported(tmp_path):
    """Reference: a matrix whose Schur complement ``M[R,R] − B D⁻¹ C`` is zero (rank 2 of 3):
    the solve returns 1 (singular), like the dense LU."""
    a = np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    a_sym = _symbolic(a, {0})
    assert constant_block(a_sym).rest == (0,)
    ffi, lib = _solver(tmp_path, a_sym, 3)
    assert lib.solve(ffi.from_buffer("double[]", a.copy()), 1,
                     ffi.from_buffer("double[]", np.ones(3))) == 1


def test_ill_conditioned_or_symbolic_blocks_stay_dense():
    """Reference: the documented limits — a constant block worse conditioned than
    ``MAX_BLOCK_CONDITION`` (1e4, the NumPy kernel's bound too) or entries that are
    expressions are not inverted explicitly."""
    assert MAX_BLOCK_CONDITION == 1e4
    a = np.diag([1.0, 1e-12, 1.0])
    assert constant_block(_symbolic(a, set())) is None
    assert constant_block(_symbolic(np.diag([1.0, 2e4]), set())) is None
    assert constant_block(_symbolic(np.eye(3), {0, 1})) is None
    m, k = sp.symbols("m k")
    assert constant_block(sp.ImmutableMatrix([[m, 0], [0, k]])) is None
