"""The fixed C helpers of the compiled libraries (neweul_py/codegen/c_templates.py): the dot
product ``nw_dot8`` of the products and substitutions, and the AVX2 clones (``NW_CLONES``)
chosen at load time.

References: the dot product computed in exact rational arithmetic (``fractions.Fraction``),
with the bound of a sum in floating point, ``|fl(a·b) − a·b| ≤ γ_n Σ|a_i b_i|`` (Higham,
*Accuracy and Stability of Numerical Algorithms*, §3.1); and the same text built
without the clone, whose results the clone must reproduce bit for bit (the same operations
in the same order), so that a model gives the same numbers on every x86-64 machine.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from compiler import compile_c, needs_c_compiler

from neweul_py.codegen.c_templates import C_CLONES, C_DOT8

pytestmark = needs_c_compiler

LENGTHS = (0, 1, 3, 7, 8, 9, 15, 16, 17, 64, 371, 372)

_SRC = C_CLONES + C_DOT8 + r"""
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define NW_AVX2 __attribute__((target("avx2")))
#else
#define NW_AVX2
#endif
__attribute__((optimize("O3"))) NW_CLONES double dot_clones(int n, const double *a,
                                                            const double *b)
{
    return nw_dot8(n, a, b);
}
__attribute__((optimize("O3"))) double dot_plain(int n, const double *a, const double *b)
{
    return nw_dot8(n, a, b);
}
__attribute__((optimize("O3"))) NW_AVX2 double dot_avx2(int n, const double *a,
                                                        const double *b)
{
    return nw_dot8(n, a, b);
}
int has_avx2(void)
{
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
#else
    return 0;
#endif
}
"""
_CDEF = """
double dot_clones(int n, const double *a, const double *b);
double dot_plain(int n, const double *a, const double *b);
double dot_avx2(int n, const double *a, const double *b);
int has_avx2(void);
"""


def test_dot8_is_within_the_floating_point_bound_and_the_same_in_every_build(tmp_path):
    """``nw_dot8`` of random vectors of lengths around its blocks of eight (and of none) lies
    within ``γ_n Σ|a_i b_i|`` of the exact dot product; the build chosen at load time, the
    build without clones and, where the processor has it, the AVX2 build give the same
    bits."""
    ffi, lib = compile_c(tmp_path, "dot8", _SRC, _CDEF)
    rng = np.random.default_rng(3)
    eps = np.finfo(float).eps / 2
    for n in LENGTHS:
        for _ in range(5):
            a = rng.standard_normal(n) * 10.0 ** rng.integers(-3, 4, n)
            b = rng.standard_normal(n)
            pa, pb = ffi.from_buffer("double[]", a), ffi.from_buffer("double[]", b)
            got = lib.dot_clones(n, pa, pb)
            exact = sum((Fraction(x) * Fraction(y) for x, y in zip(a, b, strict=True)),
                         Fraction(0))
            bound = n * eps / (1 - n * eps) * float(np.abs(a * b).sum())
            assert abs(Fraction(got) - exact) <= Fraction(bound), n
            assert got == lib.dot_plain(n, pa, pb), n
            if lib.has_avx2():
                assert got == lib.dot_avx2(n, pa, pb), n
