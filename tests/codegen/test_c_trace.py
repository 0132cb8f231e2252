"""Tracing array programs (codegen/c_trace.py) and printing them as C (codegen/c_kernel.py).

Reference: NumPy evaluating the same Python functions on arrays — the traced program, printed
as C, compiled and run, must give NumPy's numbers; operations the tracer cannot record are
refused at once.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from compiler import compile_c

from neweul_py.codegen.c_kernel import KernelPrinter
from neweul_py.codegen.c_kernel_text import C_DOT
from neweul_py.codegen.c_trace import Graph, TArray, TraceError
from neweul_py.ffrf.body import ffrf_omega_products

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                                reason="no C compiler")


def _program(A, B, x, w, c2):
    """The operations the kernel uses: products of every shape, slices, transposes,
    reshapes, new axes, concatenation, ``numpy.ix_`` and fancy rows, assignments to parts,
    packing scalars (``ffrf_omega_products``), scalar factors."""
    y = np.dot(A, x) + 0.5 * (x @ B)                  # 2-D · 1-D, 1-D · 2-D
    C = A @ B.T                                          # 2-D · 2-D with a transpose
    C[1:3, :] += np.dot(A[1:3, :2], B[:2, :])
    C[np.array([0, 3])] -= C[np.array([1, 2])] * 2.0
    outer = (x[:, None] * w).ravel()                     # broadcasting, a new axis
    v = ffrf_omega_products(w, y[:2])
    z = np.concatenate((np.dot(c2.reshape(3, 4, 3)[:, 1, :], w), v, outer[::3]))
    sub = C[np.ix_([0, 2], [1, 3])]
    q = np.dot(x, c2.reshape(3, 4, 3)[:, ::-1, :])      # 1-D · 3-D, a reversed axis
    top = np.concatenate((x[:1] * 0.0, y))
    M = np.vstack((top[None, :], np.hstack((y[:, None], C))))
    M = M.astype(np.result_type(M, A))
    M[0, 0] = 2.5
    M[2:4, 1:3] += sub
    return M, np.concatenate((z, sub.ravel(), q.ravel(), -y))


def _arrays(rng):
    return (rng.normal(size=(4, 4)), rng.normal(size=(4, 4)), rng.normal(size=4),
            rng.normal(size=3), rng.normal(size=36))


def test_traced_program_printed_as_c_gives_numpys_numbers(tmp_path):
    """``_program`` traced (``A``, ``c2`` bound data, ``w`` a schedule-level input, ``B``,
    ``x`` arguments), printed, compiled: its outputs equal NumPy's on the same arrays to
    round-off (the summation order of the products may differ)."""
    rng = np.random.default_rng(3)
    A, B, x, w, c2 = _arrays(rng)
    g = Graph()
    tA, tc2 = g.leaf("A", A.shape, 0), g.leaf("c2", c2.shape, 0)
    tw = g.leaf("w", w.shape, 1)
    tB, tx = g.leaf("B", B.shape, 2), g.leaf("x", x.shape, 2)
    M, v = _program(tA, tB, tx, tw, tc2)
    pr = KernelPrinter(g, ["A", "c2"])
    pr.params[tw.node.id] = "nw_w"
    sigma = pr.schedule_function("sig(void)", [], [M, v])
    fn = pr.function("f(const double *B, const double *x, double *M, double *v)",
                     [("B", tB), ("x", tx)], [("M", M), ("v", v)], direct=True)
    src = "\n".join([
        "#include <complex.h>", "#include <math.h>", "#include <string.h>",
        "static const double *nw_D[2];", "static double nw_w[3];", C_DOT, *pr.static,
        *sigma, *fn,
        "int run(const double *A, const double *c2, const double *w, const double *B,",
        "        const double *x, double *M, double *v)",
        "{", "    nw_D[0] = A; nw_D[1] = c2;", *pr.bind_lines(),
        "    memcpy(nw_w, w, sizeof nw_w); sig(); f(B, x, M, v); return 0;", "}", ""])
    ffi, lib = compile_c(tmp_path, "prog", src,
                         "int run(const double *A, const double *c2, const double *w,"
                         " const double *B, const double *x, double *M, double *v);")
    ref_M, ref_v = _program(A, B, x, w, c2)
    got_M, got_v = np.empty(ref_M.shape), np.empty(ref_v.shape)
    fb = ffi.from_buffer
    lib.run(*(fb("double[]", a) for a in (A, c2, w, B, x, got_M, got_v)))
    np.testing.assert_allclose(got_M, ref_M, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(got_v, ref_v, rtol=1e-13, atol=1e-13)


def _block_program(S, T, X):
    """A mass matrix as the kernel assembles one of a body on a fixed frame: a product whose
    left factor has zero rows, then a block of bound data added (and, transposed, one
    subtracted)."""
    M = S @ T
    M[2:, 1:] += X
    N = S.T @ T.T
    N[1:3, 0:2] -= X[:2, 1:3]
    return M, N


def test_product_and_added_block_print_as_one_pass(tmp_path):
    """``C = A B`` followed by ``C[block] ±= X`` that nothing else reads prints as one
    ``nw_gemm_add`` (zero rows of ``A`` included), whose result equals NumPy's."""
    rng = np.random.default_rng(8)
    S = rng.normal(size=(5, 5)) * np.array([1.0, 0.0, 1.0, 0.0, 0.0])[:, None]
    T, X = rng.normal(size=(5, 5)), rng.normal(size=(3, 4))
    g = Graph()
    tS, tX, tT = g.leaf("S", S.shape, 0), g.leaf("X", X.shape, 0), g.leaf("T", T.shape, 2)
    M, N = _block_program(tS, tT, tX)
    pr = KernelPrinter(g, ["S", "X"])
    fn = pr.function("f(const double *T, double *M, double *N)", [("T", tT)],
                     [("M", M), ("N", N)], direct=True)
    assert sum(line.count("nw_gemm_add(") for line in fn) == 2
    src = "\n".join([
        "#include <math.h>", "#include <string.h>", "static const double *nw_D[2];", C_DOT,
        *pr.static, *fn, "int run(const double *S, const double *X, const double *T,",
        "        double *M, double *N)", "{", "    nw_D[0] = S; nw_D[1] = X;",
        *pr.bind_lines(), "    f(T, M, N); return 0;", "}", ""])
    ffi, lib = compile_c(tmp_path, "block", src,
                         "int run(const double *S, const double *X, const double *T,"
                         " double *M, double *N);")
    ref_M, ref_N = _block_program(S, T, X)
    got_M, got_N = np.full(ref_M.shape, np.nan), np.full(ref_N.shape, np.nan)
    fb = ffi.from_buffer
    lib.run(*(fb("double[]", np.ascontiguousarray(a)) for a in (S, X, T)),
            fb("double[]", got_M), fb("double[]", got_N))
    np.testing.assert_allclose(got_M, ref_M, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(got_N, ref_N, rtol=1e-13, atol=1e-13)


def test_complex_steps_print_as_c99_complex(tmp_path):
    """A complex argument and a complex scalar factor (the complex-step derivatives of the
    kernel): the C99 ``double complex`` loops give NumPy's complex result."""
    rng = np.random.default_rng(5)
    A, x = rng.normal(size=(3, 3)), rng.normal(size=3) + 1j * rng.normal(size=3)
    g = Graph()
    tA, tx = g.leaf("A", A.shape, 0), g.leaf("x", (3,), 2, cplx=True)
    out = np.dot(tA, tx) + 1j * 1e-3 * tx

    def ref(A, x):
        return np.dot(A, x) + 1j * 1e-3 * x

    pr = KernelPrinter(g, ["A"])
    fn = pr.function("f(const double complex *x, double complex *o)", [("x", tx)],
                     [("o", out)])
    src = "\n".join(["#include <complex.h>", "#include <math.h>", "#include <string.h>",
                     "static const double *nw_D[1];", C_DOT, *pr.static, *fn,
                     "int run(const double *A, const double *x, double *o)",
                     "{ nw_D[0] = A; f((const double complex *)x, (double complex *)o); "
                     "return 0; }", ""])
    ffi, lib = compile_c(tmp_path, "cplx", src,
                         "int run(const double *A, const double *x, double *o);")
    got = np.empty(3, dtype=complex)
    xs = np.ascontiguousarray(x)
    lib.run(ffi.from_buffer("double[]", A), ffi.from_buffer("double[]", xs.view(float)),
            ffi.from_buffer("double[]", got.view(float)))
    np.testing.assert_allclose(got, ref(A, x), rtol=1e-14)


def test_what_cannot_be_traced_is_refused():
    """Control flow on traced values, NumPy functions the kernel does not use, complex
    constant arrays and iteration are refused with a TraceError (a GenerationError)."""
    g = Graph()
    t = g.leaf("t", (3,), 2)
    with pytest.raises(TraceError, match="control flow"):
        bool(t)
    with pytest.raises(TraceError, match=r"numpy\.(linalg\.)?inv"):
        np.linalg.inv(g.leaf("A", (3, 3), 2))
    with pytest.raises(TraceError, match="complex constants"):
        t + np.array([1j, 0, 0])
    with pytest.raises(TraceError, match="iterating"):
        list(t)


def test_equal_operations_are_one_node():
    """Hash-consing: the same product of the same values is one node (what two traced
    functions share is computed once); an assignment replaces the array's node."""
    g = Graph()
    A, x = g.leaf("A", (3, 3), 0), g.leaf("x", (3,), 2)
    assert np.dot(A, x).node is np.dot(A, x).node
    y = TArray(g, np.dot(A, x).node)
    before = y.node
    y[0] = x[1]
    assert y.node is not before and y.node.op == "update"
