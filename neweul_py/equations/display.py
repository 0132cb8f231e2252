"""The equations of motion as LaTeX for notebooks (``Equations._repr_latex_``).

``M(y, t) ÿ = q − k`` (docs/equations.md §1) is shown as the mass matrix ``M`` and the force
vector ``q − k``, preceded by the intermediate quantities they are written with: the
intermediates of the recursive form under their own names (``c_{link1,0} = cos φ₁``, the
absolute kinematics and body terms of docs/equations.md §1.3), or, in closed form, the
subexpressions that occur more than once (``ξ₀, ξ₁ …``, found by sympy's common-subexpression
elimination). Velocities ``d_<y>`` print as ``\\dot{y}``.
"""

from __future__ import annotations

from typing import Any

import sympy as sp

__all__ = ["MAX_LATEX", "MIN_OPERATIONS", "equations_latex", "equations_summary", "named_form"]

#: Fewest operations of a repeated subexpression of the closed form that gets a name.
MIN_OPERATIONS = 3

#: Longest LaTeX text shown (characters); longer equations show their sizes only.
MAX_LATEX = 60_000


def _symbol_names(eq: Any) -> dict[sp.Symbol, str]:
    names: dict[sp.Symbol, str] = {}
    for y, yd in zip(eq.coordinates, eq.velocities, strict=True):
        base = sp.latex(y)
        names[y] = base
        names[yd] = rf"\dot{{{base}}}"
    for s, _ in eq.intermediates:
        head, _, rest = s.name.lstrip("_").partition("_")
        rest = rest.replace("_", ",")
        names[s] = rf"{head}_{{\mathrm{{{rest}}}}}" if rest else head
    return names


def equations_summary(eq: Any) -> str:
    """One line: the model, its coordinates and the form of its equations."""
    form = "closed form" if not eq.intermediates else (
        f"recursive form, {len(eq.intermediates)} intermediates")
    parts = [f"{eq.n} coordinates", form, f"{len(eq.inputs)} inputs",
             f"{len(eq.outputs)} outputs"]
    if eq.constraints is not None and len(eq.constraints.names):
        parts.append(f"{len(eq.constraints.names)} constraints")
    if eq.elastic is not None:
        parts.append("elastic bodies spliced in numerically")
    return f"{eq.system.name}: " + ", ".join(parts)


def named_form(eq: Any) -> tuple[list[tuple[sp.Symbol, sp.Expr]], sp.ImmutableMatrix,
                                  sp.ImmutableMatrix]:
    """``(assignments, M, q − k)``: the intermediate quantities in order (each may use the
    earlier ones) and ``M``, ``q − k`` written with them — the recursive form's own
    intermediates, or the closed form's repeated subexpressions of at least
    :data:`MIN_OPERATIONS` operations (symbols ``_xi<k>``)."""
    mass = sp.ImmutableMatrix(eq.mass_matrix)
    force = sp.ImmutableMatrix(eq.force_vector)
    assignments = [(s, e) for s, e in eq.intermediates]
    if assignments:
        return assignments, mass, force
    found, reduced = sp.cse([*mass, *force], symbols=sp.numbered_symbols("_cse"),
                            optimizations=None)
    # name only what is worth a name: a subexpression of a few operations is inlined
    inline: dict[sp.Symbol, sp.Expr] = {}
    for s, e in found:
        e = e.xreplace(inline)
        if sp.count_ops(e) < MIN_OPERATIONS:
            inline[s] = e
            continue
        xi = sp.Symbol(f"_xi{len(assignments)}")
        assignments.append((xi, e))
        inline[s] = xi
    reduced = [e.xreplace(inline) for e in reduced]
    return (assignments, sp.ImmutableMatrix(mass.shape[0], mass.shape[1], reduced[:len(mass)]),
            sp.ImmutableMatrix(force.shape[0], 1, reduced[len(mass):]))


def equations_latex(eq: Any, max_length: int = MAX_LATEX) -> str:
    """``$$\\begin{aligned} … \\end{aligned}$$`` of the intermediates, ``M``, ``q − k``
    (:func:`named_form`) and the constraints ``g``.

    Parameters
    ----------
    eq
        :class:`~neweul_py.equations.Equations`.
    max_length
        Longer texts are replaced by the sizes of the equations (:func:`equations_summary`).
    """
    names = _symbol_names(eq)
    assignments, mass, force = named_form(eq)
    for s, _ in assignments:
        if s.name.startswith("_xi"):
            names[s] = rf"\xi_{{{s.name.removeprefix('_xi')}}}"

    def tex(e: Any) -> str:
        return sp.latex(e, symbol_names=names)

    y = sp.ImmutableMatrix(eq.coordinates)
    lines = [rf"\text{{{_escape(equations_summary(eq))}}}"]
    lines += [rf"{names[s]} &= {tex(e)}" for s, e in assignments]
    lines.append(rf"M &= {tex(mass)}")
    lines.append(rf"q - k &= {tex(force)}")
    lines.append(rf"M\,\ddot{{y}} &= q - k, \quad y = {tex(y)}")
    if eq.constraints is not None and len(eq.constraints.names):
        g = sp.ImmutableMatrix(eq.constraints.g)
        lines.append(rf"g(y, t) &= {tex(g)} = 0")
    if eq.elastic is not None:
        lines.append(r"&\text{(the elastic bodies' terms are added numerically, "
                     r"equations.md \S 2)}")
    text = "$$\\begin{aligned}\n" + " \\\\\n".join(lines) + "\n\\end{aligned}$$"
    if len(text) > max_length:
        return (rf"$$\text{{{_escape(equations_summary(eq))}: {len(text)} characters of "
                r"LaTeX, too long to show}$$")
    return text


def _escape(text: str) -> str:
    """Text for ``\\text{…}``."""
    for a, b in (("\\", r"\backslash "), ("_", r"\_"), ("{", r"\{"), ("}", r"\}"),
                 ("%", r"\%"), ("&", r"\&"), ("#", r"\#"), ("$", r"\$")):
        text = text.replace(a, b)
    return text
