"""The fixed C text of the splice (neweul_py/codegen/c_splice_text.py): the products with the
selection maps ``S_V`` and ``S_V(0)`` along the nonzero span of each row (``SMAP_C``), and
``x S_W`` of the first rows of ``S_W`` so (``WMAP_C``), and the polynomial rows of a
parametric body's mix (``POLY_C``).

Reference: NumPy's dense products ``S_V @ x`` and ``x @ S_W[:k]``, as the NumPy module forms
``y_s`` and the generalized forces — for maps whose zero pattern changes between bindings or
weights, and for an ``x`` with NaN, which the dense product carries into every row or column
(``0 · NaN``); for the mix, the weights of
``ffrf_weights`` times the samples, ``w V``, as ``ffrf_mix`` forms the varying entries.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from compiler import compile_c

from neweul_py.codegen.c_kernel_text import C_DOT
from neweul_py.codegen.c_splice_text import POLY_C, SMAP_C, WMAP_C
from neweul_py.ffrf.parametric import ffrf_weights

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                                reason="no C compiler")

NS, N = 7, 6


def _library(tmp_path, sigma: int):
    src = "\n".join([
        "#include <math.h>", "#include <string.h>", f"#define NW_NS {NS}", f"#define NW_N {N}",
        "static double A0[NW_NS * NW_N], A1[NW_NS * NW_N];", "#define NW_SV A0",
        "#define NW_SV0 A1", f"#define NW_SV_SIGMA {sigma}", "static long nw_binds, nw_wversion;",
        "#define NW_SW A0", "#define NW_SW_SIGMA 0", C_DOT, WMAP_C, SMAP_C,
        "void set(int which, const double *a) { memcpy(which ? A1 : A0, a, sizeof A0); }",
        "void bump(int binds, int weights) { nw_binds += binds; nw_wversion += weights; }",
        "void smap(int which, const double *x, double *y) { nw_smap(which, x, y); }", ""])
    return compile_c(tmp_path, f"smap{sigma}", src,
                     "void set(int which, const double *a); void bump(int binds, int weights);"
                     "void smap(int which, const double *x, double *y);")


def _map(rng: np.random.Generator, edge: float) -> np.ndarray:
    """A selection map: unit rows, a zero row, and node rows dense but for their first and
    last entries (``edge`` there)."""
    A = np.zeros((NS, N))
    A[np.arange(N - 1), np.arange(N - 1)] = 1.0
    A[NS - 1] = rng.normal(size=N)
    A[NS - 1, [0, -1]] = edge
    return A


@pytest.mark.parametrize("sigma", [0, 1])
def test_span_products_equal_the_dense_product_as_the_maps_change(tmp_path, sigma) -> None:
    """``y = S_V x`` and ``S_V(0) x`` equal ``A @ x`` for maps with zero edges, and again
    after the maps gain entries outside the old spans: ``S_V(0)`` at a binding, ``S_V`` at a
    binding or (``NW_SV_SIGMA``) a change of the weights."""
    ffi, lib = _library(tmp_path, sigma)
    rng = np.random.default_rng(5)
    x = rng.normal(size=N)
    y = np.empty(NS)
    maps = [_map(rng, 0.0), _map(rng, 0.0)]
    lib.bump(1, 1)
    for which, A in enumerate(maps):
        lib.set(which, ffi.from_buffer("double[]", A))
        lib.smap(which, ffi.from_buffer("double[]", x), ffi.from_buffer("double[]", y))
        np.testing.assert_allclose(y, A @ x, rtol=1e-15, atol=1e-15)
    for which in (0, 1):
        A = _map(rng, 0.5)                                   # entries outside the spans
        lib.set(which, ffi.from_buffer("double[]", A))
        lib.bump(int(which == 1 or not sigma), int(which == 0 and sigma == 1))
        lib.smap(which, ffi.from_buffer("double[]", x), ffi.from_buffer("double[]", y))
        np.testing.assert_allclose(y, A @ x, rtol=1e-15, atol=1e-15)


def test_span_product_of_a_nan_reaches_every_row(tmp_path) -> None:
    """A NaN in ``x`` outside a row's span makes that row NaN as in ``A @ x`` (the NumPy
    module's schedule then sees NaN and refuses it), not a finite number."""
    ffi, lib = _library(tmp_path, 1)
    rng = np.random.default_rng(6)
    A = _map(rng, 0.0)
    lib.bump(1, 1)
    lib.set(0, ffi.from_buffer("double[]", A))
    x = rng.normal(size=N)
    x[0] = np.nan
    y = np.empty(NS)
    lib.smap(0, ffi.from_buffer("double[]", x), ffi.from_buffer("double[]", y))
    with np.errstate(invalid="ignore"):
        want = A @ x
    assert np.isnan(want).all()
    np.testing.assert_array_equal(np.isnan(y), np.isnan(want))


def _wlibrary(tmp_path, sigma: int):
    src = "\n".join([
        "#include <math.h>", "#include <string.h>", f"#define NW_NS {NS}", f"#define NW_N {N}",
        "static double A0[NW_NS * NW_N];", "#define NW_SW A0", f"#define NW_SW_SIGMA {sigma}",
        "static long nw_binds, nw_wversion;", C_DOT, WMAP_C,
        "void set(const double *a) { memcpy(A0, a, sizeof A0); }",
        "void bump(int binds, int weights) { nw_binds += binds; nw_wversion += weights; }",
        "void wmap(int k, const double *x, long sx, double *y) { nw_wmap(k, x, sx, y); }", ""])
    return compile_c(tmp_path, f"wmap{sigma}", src,
                     "void set(const double *a); void bump(int binds, int weights);"
                     "void wmap(int k, const double *x, long sx, double *y);")


@pytest.mark.parametrize("sigma", [0, 1])
def test_weighted_rows_equal_the_dense_product_as_the_map_changes(tmp_path, sigma) -> None:
    """``y = x S_W[:k]`` (all rows, the first rows, a strided ``x``) equals ``x @ A[:k]`` for a
    map with zero edges, and again after the map gains entries outside the old spans: at a
    binding, or (``NW_SW_SIGMA``) at a change of the weights."""
    ffi, lib = _wlibrary(tmp_path, sigma)
    rng = np.random.default_rng(8)
    x = rng.normal(size=2 * NS)
    y = np.empty(N)
    lib.bump(1, 1)
    for edge, bump in ((0.0, (0, 0)), (0.5, (int(not sigma), sigma))):
        A = _map(rng, edge)
        A[NS - 2] = 0.0                                       # a zero row
        lib.set(ffi.from_buffer("double[]", A))
        lib.bump(*bump)
        for k, stride in ((NS, 1), (3, 1), (NS, 2)):
            xs = x[:stride * k:stride]
            lib.wmap(k, ffi.from_buffer("double[]", x), stride, ffi.from_buffer("double[]", y))
            np.testing.assert_allclose(y, xs @ A[:k], rtol=1e-15, atol=1e-15)


def test_weighted_rows_of_a_nan_reach_every_column(tmp_path) -> None:
    """A NaN in ``x`` at a unit row makes every column NaN as in ``x @ A`` (the NumPy module's
    forces then carry it), not one column."""
    ffi, lib = _wlibrary(tmp_path, 0)
    rng = np.random.default_rng(9)
    A = _map(rng, 0.0)
    lib.bump(1, 0)
    lib.set(ffi.from_buffer("double[]", A))
    x = rng.normal(size=NS)
    x[0] = np.nan
    y = np.empty(N)
    lib.wmap(NS, ffi.from_buffer("double[]", x), 1, ffi.from_buffer("double[]", y))
    with np.errstate(invalid="ignore"):
        want = x @ A
    assert np.isnan(want).all()
    np.testing.assert_array_equal(np.isnan(y), np.isnan(want))


def test_polynomial_rows_give_the_weights_times_the_samples(tmp_path) -> None:
    """``pw P`` of ``nw_poly`` equals ``ffrf_weights(σ) V`` to round-off at schedules in
    several intervals, at breakpoints and the ends, back in an interval seen before, and
    after a new binding with other samples (``P`` made again although the schedule stays in
    the interval of the last call)."""
    nb, nd, ncol, nv = 6, 4, 9, 1100                 # two blocks of NW_MIXB and a rest
    src = "\n".join([
        "#include <string.h>", "#define NW_MIXB 512", "static long nw_binds;", C_DOT,
        POLY_C, f"static double P[{nd * nv}], pw[{nd}]; static long at = -1;",
        "void poly(double x, const double *b, const double *c, const double *V, int bind,",
        "          double *out)",
        "{", "    nw_binds += bind;",
        f"    nw_poly(x, b, c, {nb}, {nd}, {ncol}, V, {nv}, P, pw, &at);",
        f"    memset(out, 0, {nv} * sizeof(double));",
        f"    for (int m = 0; m < {nd}; ++m)",
        f"        for (long i = 0; i < {nv}; ++i) out[i] += pw[m] * P[m * {nv} + i];",
        "}", ""])
    ffi, lib = compile_c(tmp_path, "poly", src,
                         "void poly(double x, const double *b, const double *c, const double *V,"
                         " int bind, double *out);")
    rng = np.random.default_rng(7)
    b = np.cumsum(rng.uniform(0.5, 2.0, size=nb)) - 3.0
    c = rng.normal(size=(nd, nb - 1, ncol))
    c[:, :, ::3] = 0.0                               # weights that vanish on every interval
    fb = ffi.from_buffer
    out = np.empty(nv)
    for bind, V in ((1, rng.normal(size=(ncol, nv))), (1, rng.normal(size=(ncol, nv)))):
        for x in (b[1] + 0.3, b[3] + 0.1, b[3] + 0.2, b[2], b[-1], b[0], b[1] + 0.2):
            lib.poly(x, fb("double[]", b), fb("double[]", c), fb("double[]", V), bind, fb(
                "double[]", out))
            bind = 0
            want = ffrf_weights(b, c, x, "duct") @ V
            np.testing.assert_allclose(out, want, rtol=1e-12, atol=1e-13 * np.abs(want).max())
