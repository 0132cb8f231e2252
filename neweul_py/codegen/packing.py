"""Packed array fills and the small dense solve of generated NumPy modules.

A generated function computes Python floats (``_math`` scalars). Filling a NumPy array entry
by entry costs about 60 ns per ``M[i, j] = v``; packing all values at once with
``struct.Struct(f"{k}d").pack`` into a ``bytearray`` and viewing it with
``numpy.frombuffer`` costs about 9 ns per value (and ``numpy.array`` of a tuple about 20 ns).
The right-hand side packs ``(ẏ, q − k, M column by column)`` into one buffer and solves in
place with LAPACK (``dposv``, Cholesky, for symmetric mass matrices; ``dgesv``, LU, else)
through SciPy's wrappers (imported at the first solve) — about 1 µs at n = 10 against about
5 µs for ``numpy.linalg.solve``, whose Python wrapper dominates for small systems. Without
SciPy, or when ``dposv`` finds M not positive definite, or ``dgesv`` finds it singular,
``numpy.linalg.solve`` is used (and raises ``numpy.linalg.LinAlgError`` as before).

When the equations give the mass matrix as weighted rank-one terms ``M = Σ_r w_r g_r g_rᵀ``
(``Equations.mass_factors``, recursive form), the weights and the rows ``G`` are packed
instead of M and ``M = Gᵀ diag(w) G`` is one matrix product (:func:`factored_definitions`):
at N = 10 about 330 packed values and 2 µs against the 1 100 scalar operations of the
column-by-column recursion (about 10 µs in Python).
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy as sp

from .blocks import Context

__all__ = ["IMPORTS", "LAPACK_LOADER", "factored_definitions", "factored_mass", "factored_rhs",
           "factored_sizes", "pack_definition", "pack_name", "packed_matrix", "packed_parts",
           "packed_rhs", "solver_definition"]

#: Import lines of a module that uses packed fills and the LAPACK solve.
IMPORTS = (
    "import math as _math",
    "import struct as _struct",
    "",
    "import numpy as _np",
)

#: The lazy import of SciPy's LAPACK wrappers (``scipy.linalg`` costs ~0.2 s of import: at the
#: first solve, not when the module is imported). ``None``: not tried yet; ``False``: no SciPy.
LAPACK_LOADER = (
    "_dgesv = _dposv = None",
    "",
    "",
    "def _load_lapack():",
    '    """SciPy\'s ``dgesv``/``dposv`` (the small dense solve without numpy.linalg\'s',
    '    overhead), or ``False`` without SciPy (then numpy.linalg.solve)."""',
    "    global _dgesv, _dposv",
    "    try:",
    "        from scipy.linalg.lapack import dgesv as _dgesv, dposv as _dposv",
    "    except ImportError:  # NumPy only",
    "        _dgesv = _dposv = False",
)


def pack_name(k: int) -> str:
    """Name of the module-level ``struct`` packer of ``k`` float64 values."""
    return f"_pack{k}"


def pack_definition(k: int) -> str:
    """The module-level definition of :func:`pack_name` ``(k)``."""
    return f'{pack_name(k)} = _struct.Struct("{k}d").pack'


def solver_definition(symmetric: bool) -> tuple[str, ...]:
    """Source of ``_solve_packed(b, n)``: ``[ẏ, M⁻¹ (q − k)]`` from the packed bytes ``b``
    of ``(ẏ, q − k, M column by column)``, solved in place (one buffer, one LAPACK call)."""
    lapack = "_dposv" if symmetric else "_dgesv"
    return (
        *LAPACK_LOADER,
        "",
        "",
        "def _solve_packed(b, n):",
        '    """``[ẏ, M⁻¹ f]`` from the float64 bytes ``b`` of (ẏ, f, M column by column)."""',
        f"    if {lapack} is None:",
        "        _load_lapack()",
        f"    if {lapack}:",
        "        a = _np.frombuffer(bytearray(b))",
        f"        r = {lapack}(a[2 * n:].reshape(n, n, order='F'), a[n:2 * n], "
        "overwrite_a=1, overwrite_b=1)",
        "        if r[-1] == 0:",
        "            return a[:2 * n]",
        "    a = _np.frombuffer(b)",
        "    return _np.concatenate((a[:n], _np.linalg.solve(a[2 * n:].reshape(n, n, "
        "order='F'), a[n:2 * n])))",
    )


def _float_text(ctx: Context, value: sp.Expr) -> str:
    """The printed value, numbers as float literals (``struct`` packs Python ints about 6×
    slower than floats)."""
    return repr(float(value)) if value.is_Number else ctx.pr(value)


def _entries(ctx: Context, n: int, reduced: Sequence[sp.Expr],
             where: Sequence[Sequence[tuple[int, int]]], column_major: bool
             ) -> tuple[list[str], list[str]]:
    """Lines naming the shared non-atomic values, and the n·n entry texts in order."""
    lines: list[str] = []
    at: dict[tuple[int, int], str] = {}
    for k, (value, places) in enumerate(zip(reduced, where, strict=True)):
        text = _float_text(ctx, value)
        if len(places) > 1 and not value.is_Atom:
            lines.append(f"_mv{k} = {text}")
            text = f"_mv{k}"
        for ij in places:
            at[ij] = text
    order = ([(i, j) for j in range(n) for i in range(n)] if column_major
             else [(i, j) for i in range(n) for j in range(n)])
    return lines, [at.get(ij, "0.0") for ij in order]


def packed_matrix(ctx: Context, target: str, n: int, reduced: Sequence[sp.Expr],
                  where: Sequence[Sequence[tuple[int, int]]]) -> list[str]:
    """``target`` = the (n, n) matrix of the reduced entries (a writable, C-ordered array)."""
    lines, items = _entries(ctx, n, reduced, where, column_major=False)
    return [*lines, f"{target} = _np.frombuffer(bytearray({pack_name(n * n)}("
            f"{', '.join(items)}))).reshape({n}, {n})"]


def packed_rhs(ctx: Context, yd_names: Sequence[str], f_values: Sequence[sp.Expr], n: int,
               reduced: Sequence[sp.Expr], where: Sequence[Sequence[tuple[int, int]]]
               ) -> list[str]:
    """The closing lines of ``rhs``: pack ``(ẏ, q − k, M)`` and solve (``_solve_packed``)."""
    lines, items = _entries(ctx, n, reduced, where, column_major=True)
    values = [*yd_names, *(_float_text(ctx, v) for v in f_values), *items]
    return [*lines, f"return _solve_packed({pack_name(len(values))}({', '.join(values)}), {n})"]


def factored_definitions(n: int, values: Sequence[sp.Expr]) -> tuple[str, ...]:
    """Source of ``_factored_mass(b, n, r)`` and ``_solve_factored(b, n, r)``: ``M = Gᵀ
    diag(w) G`` from the packed ``(w, variable entries of G)``, and ``[ẏ, M⁻¹ f]`` from the
    packed ``(ẏ, f, w, variable entries of G)`` (LAPACK ``dposv`` on the symmetric product,
    in place). ``values`` are the weights, then G row by row; the entries of G that are
    numbers (zeros, the ones of rotation Jacobians) are the module constant ``_G0`` and the
    others are scattered into a copy of it at the indices ``_GI`` — about half of the chain's
    G is constant, and every value not packed saves ~13 ns."""
    r = len(values) // (n + 1)
    g = values[r:]
    template = tuple(float(v) if v.is_Number else 0.0 for v in g)
    index = tuple(k for k, v in enumerate(g) if not v.is_Number)
    return (
        f"_G0 = _np.array({template!r})",
        f"_GI = _np.array({index!r}, dtype=_np.intp)",
        "",
        "",
        *LAPACK_LOADER,
        "",
        "",
        "def _factored_mass(b, n, r):",
        '    """``M = Gᵀ diag(w) G`` from the float64 bytes ``b`` of (w, G[_GI])."""',
        "    a = _np.frombuffer(b)",
        "    g = _G0.copy()",
        "    g[_GI] = a[r:]",
        "    g = g.reshape(r, n)",
        "    return (g.T * a[:r]) @ g",
        "",
        "",
        "def _solve_factored(b, n, r):",
        '    """``[ẏ, M⁻¹ f]``, ``M = Gᵀ diag(w) G``, from the float64 bytes ``b`` of'
        ' (ẏ, f, w, G[_GI])."""',
        "    a = _np.frombuffer(b)",
        "    g = _G0.copy()",
        "    g[_GI] = a[2 * n + r:]",
        "    g = g.reshape(r, n)",
        "    m = (g.T * a[2 * n:2 * n + r]) @ g",
        "    x = a[:2 * n].copy()",
        "    if _dposv is None:",
        "        _load_lapack()",
        "    if _dposv:",
        "        if _dposv(m.T, x[n:], overwrite_a=1, overwrite_b=1)[-1] == 0:",
        "            return x",
        "        m = (g.T * a[2 * n:2 * n + r]) @ g",
        "    x[n:] = _np.linalg.solve(m, a[n:2 * n])",
        "    return x",
    )


def factored_sizes(n: int, values: Sequence[sp.Expr]) -> tuple[int, int]:
    """The numbers of values ``mass_matrix`` and ``rhs`` pack in the factored form."""
    r = len(values) // (n + 1)
    k = r + sum(1 for v in values[r:] if not v.is_Number)
    return k, k + 2 * n


def _factored_items(ctx: Context, n: int, values: Sequence[sp.Expr]) -> tuple[int, list[str]]:
    r = len(values) // (n + 1)
    return r, [*(_float_text(ctx, w) for w in values[:r]),
               *(ctx.pr(g) for g in values[r:] if not g.is_Number)]


def factored_mass(ctx: Context, n: int, values: Sequence[sp.Expr]) -> list[str]:
    """The closing line of ``mass_matrix`` from the factored form (``values``: w, then G)."""
    r, items = _factored_items(ctx, n, values)
    return [f"return _factored_mass({pack_name(len(items))}({', '.join(items)}), {n}, {r})"]


def factored_rhs(ctx: Context, yd_names: Sequence[str], f_values: Sequence[sp.Expr], n: int,
                 values: Sequence[sp.Expr]) -> list[str]:
    """The closing line of ``rhs`` from the factored form (``values``: w, then G)."""
    r, fac = _factored_items(ctx, n, values)
    items = [*yd_names, *(_float_text(ctx, v) for v in f_values), *fac]
    return [f"return _solve_factored({pack_name(len(items))}({', '.join(items)}), {n}, {r})"]


def packed_parts(ctx: Context, out_values: Sequence[sp.Expr], f_values: Sequence[sp.Expr],
                 n: int, mass: Sequence[sp.Expr],
                 where: Sequence[Sequence[tuple[int, int]]] | None) -> tuple[int, list[str]]:
    """The closing lines of a function returning ``(out, M, q − k)``: all values packed into
    one buffer (one ``struct`` call instead of three arrays), ``out`` and ``q − k`` views of
    it, ``M`` from the factored form (``where`` is ``None``: ``mass`` holds w, then G;
    ``_factored_mass``) or the (n, n) view of its unique entries ``mass`` at ``where``
    (row-major; read-only, as the other two). Returns the number of packed values too."""
    if where is None:
        r, items = _factored_items(ctx, n, mass)
        m_text = f"_factored_mass(a[{len(out_values) + n}:], {n}, {r})"
        lines: list[str] = []
    else:
        lines, items = _entries(ctx, n, mass, where, column_major=False)
        m_text = f"a[{len(out_values) + n}:].reshape({n}, {n})"
    values = [*(_float_text(ctx, v) for v in (*out_values, *f_values)), *items]
    k, ny = len(values), len(out_values)
    if not k:
        return 0, ["return _np.zeros(0), _np.zeros((0, 0)), _np.zeros(0)"]
    if not n:
        m_text = "_np.zeros((0, 0))"
    return k, [*lines, f"a = _np.frombuffer({pack_name(k)}({', '.join(values)}))",
               f"return a[:{ny}], {m_text}, a[{ny}:{ny + n}]"]
