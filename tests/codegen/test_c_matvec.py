"""``M a`` pushed into the traced operations that form ``M`` (codegen/c_matvec.py).

Reference: NumPy's ``M @ a`` of the same Python program evaluated on arrays. The traced
product, printed as C, compiled and run, must give those numbers, and where every operation
that forms ``M`` has a rule, no matrix-valued product of the call's arguments may be left.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from compiler import compile_c

from neweul_py.codegen.c_kernel import KernelPrinter
from neweul_py.codegen.c_kernel_text import C_DOT
from neweul_py.codegen.c_matvec import matvec
from neweul_py.codegen.c_trace import Graph, TArray

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                                reason="no C compiler")


def _mass(S, T, X, Y, Z):
    """A matrix formed as the kernel forms a mass matrix: products, a difference, blocks
    added to and subtracted from parts (a product among them, and rows taken backwards), a
    block set where the matrix is zero (``Z``, a zero matrix of the program's kind)."""
    M = S @ T
    M[2:, 1:] += X
    M = M - S.T @ S
    M[0:2, 0:2] -= Y @ T[1:3, 3:5]
    M[::-2, :] += S[:3]
    Z[1:4, 2:5] = X[:3, :3]
    return M + Z


def _fancy(S, T, X, Y, Z):
    """Parts assigned through fancy rows and a block replaced outright: no rule applies and
    the product is taken with the matrix."""
    M = _mass(S, T, X, Y, Z)
    M[np.array([0, 3])] += S[np.array([1, 2])]
    M[1:3, 1:3] = Y
    return M


def _arrays(rng):
    return (rng.normal(size=(5, 5)), rng.normal(size=(5, 5)), rng.normal(size=(3, 4)),
            rng.normal(size=(2, 2)), rng.normal(size=5))


def _matrices(node, seen=None) -> list:
    """The 2-D products, sums and assignments ``node`` is computed from."""
    seen = set() if seen is None else seen
    if node.id in seen:
        return []
    seen.add(node.id)
    own = [node] if node.op in ("dot", "ew", "update") and len(node.shape) == 2 else []
    return own + [m for a in node.args for m in _matrices(a, seen)]


def _run(tmp_path, program, S, T, X, Y, a):
    g = Graph()
    tS, tX, tY = g.leaf("S", S.shape, 0), g.leaf("X", X.shape, 0), g.leaf("Y", Y.shape, 0)
    tT, ta = g.leaf("T", T.shape, 2), g.leaf("a", a.shape, 2)
    r = matvec(program(tS, tT, tX, tY, TArray(g, g.zeros((5, 5)))), ta)
    pr = KernelPrinter(g, ["S", "X", "Y"])
    fn = pr.function("f(const double *T, const double *a, double *r)",
                     [("T", tT), ("a", ta)], [("r", r)], direct=True)
    src = "\n".join([
        "#include <math.h>", "#include <string.h>", "static const double *nw_D[3];", C_DOT,
        *pr.static, *fn, "int run(const double *S, const double *X, const double *Y,",
        "        const double *T, const double *a, double *r)", "{",
        "    nw_D[0] = S; nw_D[1] = X; nw_D[2] = Y;", *pr.bind_lines(), "    f(T, a, r);",
        "    return 0;", "}", ""])
    ffi, lib = compile_c(tmp_path, "matvec", src,
                         "int run(const double *S, const double *X, const double *Y,"
                         " const double *T, const double *a, double *r);")
    got = np.full(5, np.nan)
    fb = ffi.from_buffer
    lib.run(*(fb("double[]", np.ascontiguousarray(v)) for v in (S, X, Y, T, a)),
            fb("double[]", got))
    return got, r, tT


@pytest.mark.parametrize("program", [_mass, _fancy])
def test_pushed_product_gives_numpys_matrix_times_vector(tmp_path, program):
    """Printed as C, ``matvec(M, a)`` equals NumPy's ``M @ a`` to round-off, whether the
    rules apply (``_mass``) or the product falls back to the matrix (``_fancy``)."""
    rng = np.random.default_rng(11)
    S, T, X, Y, a = _arrays(rng)
    got, _r, _t = _run(tmp_path, program, S, T, X, Y, a)
    ref = program(S, T, X, Y, np.zeros((5, 5))) @ a
    np.testing.assert_allclose(got, ref, rtol=1e-13, atol=1e-13 * np.abs(ref).max())


def test_matrix_is_not_formed_where_every_step_has_a_rule(tmp_path):
    """With the rules of the module docstring, ``M a`` of ``_mass`` is built from products
    with vectors only: no matrix that depends on the argument ``T`` is computed, while the
    fallback (``_fancy``) keeps the matrix."""
    rng = np.random.default_rng(12)
    S, T, X, Y, a = _arrays(rng)
    _got, r, tT = _run(tmp_path, _mass, S, T, X, Y, a)

    def uses_t(node) -> bool:
        return node is tT.node or any(uses_t(x) for x in node.args)

    assert not [m for m in _matrices(r.node) if uses_t(m)]
    _got, r, tT = _run(tmp_path, _fancy, S, T, X, Y, a)
    assert [m for m in _matrices(r.node) if uses_t(m)]


def test_shapes_that_do_not_multiply_are_refused():
    """A product of a matrix with a vector of another length is an error at generation."""
    g = Graph()
    with pytest.raises(ValueError, match="matvec of shapes"):
        matvec(g.leaf("M", (3, 4), 2), g.leaf("a", (3,), 2))
