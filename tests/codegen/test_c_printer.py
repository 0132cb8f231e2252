"""The C printer (codegen/c_printer.py): long linear combinations as rows of a table."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
import sympy as sp
from compiler import needs_c_compiler

from neweul_py.codegen.c_printer import CPrinter, DotRows
from neweul_py.codegen.c_runtime import compiled_library

pytestmark = needs_c_compiler


def test_linear_combinations_print_as_table_rows_with_the_same_value(tmp_path):
    """Reference: the expression evaluated by sympy at random numbers — a sum with a long
    combination of ``y`` (one row), a long one of ``ẏ`` times a common factor (a second row),
    a short one (printed term by term) and other terms gives the same value compiled, the
    rows computed as one product per array at the top (``DotRows.batch``)."""
    n = 12
    y, yd = sp.symbols(f"y0:{n}"), sp.symbols(f"yd0:{n}")
    p0 = sp.Symbol("p0")
    rng = np.random.default_rng(1)
    c = [sp.Float(v) for v in rng.standard_normal(3 * n)]
    expr = (sp.Add(*(c[i] * y[i] for i in range(n)))
            + p0 * sp.cos(y[0]) * sp.Add(*(c[n + i] * yd[i] for i in range(1, n)))
            + sp.Add(*(c[2 * n + i] * y[i] * y[0] for i in range(3))) + sp.sin(p0))
    names = {s: f"y[{i}]" for i, s in enumerate(y)} | {s: f"yd[{i}]" for i, s in enumerate(yd)}
    dots = DotRows(n)
    text = CPrinter(names | {p0: "p[0]"}, dots).doprint_expr(expr)
    assert text.count("nw_dot(") == 2 and len(dots.rows) == 2
    body = dots.batch([f"return {text};"])
    assert "nw_dot(" not in "".join(body) and sum("nw_rows(" in b for b in body) == 2
    src = "\n".join(["#include <math.h>", *dots.helper(),
                     "double f(const double *y, const double *yd, const double *p)",
                     "{", *body, "}", ""])
    c_path = tmp_path / "dots.c"
    c_path.write_text(src)
    ffi, lib, _ = compiled_library(c_path, hashlib.sha256(src.encode()).hexdigest(),
                                   "double f(const double *, const double *, const double *);",
                                   tmp_path / "cache")
    yv, ydv, pv = rng.standard_normal(n), rng.standard_normal(n), rng.standard_normal(1)
    values = {**dict(zip(y, yv, strict=True)), **dict(zip(yd, ydv, strict=True)), p0: pv[0]}
    ref = float(expr.subs(values))
    got = lib.f(ffi.from_buffer("double[]", yv), ffi.from_buffer("double[]", ydv),
                ffi.from_buffer("double[]", pv))
    assert got == pytest.approx(ref, rel=1e-13, abs=1e-13)
