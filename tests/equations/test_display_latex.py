"""The equations in notebooks (equations/display.py, ``Equations._repr_latex_``).

Reference: the derived ``M`` and ``q − k`` themselves — the named intermediates substituted
back give them exactly — and the LaTeX text's own structure (every named quantity defined
before it is used, velocities as dotted coordinates).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import sympy as sp

from neweul_py.api import derive
from neweul_py.equations.display import MAX_LATEX, equations_latex, named_form

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize(("name", "form"), [("double_pendulum", "closed"),
                                            ("double_pendulum", "recursive"),
                                            ("four_bar", "auto")])
def test_named_quantities_give_back_the_equations(name, form):
    eq, _ = derive(EXAMPLES / f"{name}.yaml", form)
    assignments, mass, force = named_form(eq)
    assert assignments, "no quantity was named"
    values: dict[sp.Symbol, sp.Expr] = {}
    for s, e in assignments:
        assert e.free_symbols - set(values) - set(eq.coordinates) - set(eq.velocities) - set(
            eq.parameters) - set(eq.inputs) - {sp.Symbol("t", real=True)} <= set(), s
        values[s] = e.xreplace(values)
    expanded = eq.substituted()
    for got, want in ((mass, expanded.mass_matrix), (force, expanded.force_vector)):
        diff = (got.xreplace(values) - sp.ImmutableMatrix(want)).applyfunc(sp.expand)
        assert diff == sp.zeros(*diff.shape)


def test_latex_defines_before_use_and_dots_the_velocities():
    eq, _ = derive(EXAMPLES / "four_bar.yaml")
    text = eq._repr_latex_()
    assert text.startswith("$$\\begin{aligned}") and text.endswith("\\end{aligned}$$")
    defined = []
    for line in text.splitlines():
        for used in re.findall(r"\\xi_\{(\d+)\}", line.split("&=")[-1]):
            assert used in defined, line
        head = re.match(r"\\xi_\{(\d+)\} &=", line)
        if head:
            defined.append(head.group(1))
    assert defined and "\\dot{\\phi_{1}}" in text and "g(y, t) &=" in text
    assert "M &= \\left[\\begin{matrix}" in text


def test_repr_is_one_line_and_long_equations_show_their_size():
    """The dataclass dump (4.7 KB for the double pendulum) is a one-line summary now."""
    eq, _ = derive(EXAMPLES / "double_pendulum.yaml")
    assert repr(eq) == ("<Equations of double_pendulum: 2 coordinates, closed form, 0 inputs, "
                        "4 outputs>")
    short = equations_latex(eq, max_length=100)
    assert "too long to show" in short and len(short) < 200
    assert len(eq._repr_latex_()) < MAX_LATEX
