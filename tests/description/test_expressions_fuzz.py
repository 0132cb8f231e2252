"""Fuzzing the expression parser: for any text, ``parse_expression`` returns a sympy
expression or raises one ``ExpressionError`` with a one-line message — never another exception
(RecursionError, OverflowError, sympy's AttributeError …) and never a hang.

The inputs are token soups from the language's own vocabulary plus hostile pieces (huge and tiny
numbers, deep nesting, comparisons in the wrong place, Python syntax), so that most of them get
deep into the parser. ``NEWEUL_FUZZ_LONG=1`` runs 20 000 examples instead of the CI's 1 500
(``benchmarks/bench_parser.py`` also runs ≥ 20 000 and prints the count).
"""

from __future__ import annotations

import os

import sympy as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from neweul_py.description import ExpressionError, parse_expression
from neweul_py.model import symbol, time

NS = {"a": symbol("a"), "b": symbol("b"), "t": time, "d_a": symbol("d_a")}
EXAMPLES = 20_000 if os.environ.get("NEWEUL_FUZZ_LONG") else 1_500

NUMBERS = ["0", "1", "2", "0.5", "1e-10", "-1e-10", "351", "10", "400", "1e308", "1e-308",
           "1e309", "9" * 40, "1e400", ".5", "3.", "2.5E+2", "1e-320", "0.0", "7"]
NAMES = ["a", "b", "t", "d_a", "pi", "x", "E", "lambda", "and", "or", "not", "__class__"]
FUNCS = ["sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "exp",
         "log", "sqrt", "abs", "sign", "min", "max", "heaviside", "step", "piecewise", "foo"]
OPS = ["+", "-", "*", "/", "**", "(", ")", ",", "<", "<=", ">", ">=", "==", "!", "^", ".",
       "[", "'", ";", "=", ":", "@"]
TOKEN = st.one_of(
    st.sampled_from(NUMBERS), st.sampled_from(NAMES), st.sampled_from(FUNCS).map(lambda f: f + "("),
    st.sampled_from(OPS), st.sampled_from(OPS), st.text(max_size=2),
)


@st.composite
def token_soup(draw) -> str:
    tokens = draw(st.lists(TOKEN, max_size=40))
    sep = draw(st.sampled_from(["", " "]))
    return sep.join(tokens)


@st.composite
def nested(draw) -> str:
    """Well-formed-looking deep or wide expressions with extreme constants."""
    depth = draw(st.integers(0, 160))
    inner = draw(st.sampled_from([*NUMBERS, "a", "t"]))
    kind = draw(st.sampled_from(["paren", "call", "pow", "neg", "sum", "piecewise"]))
    if kind == "paren":
        return "(" * depth + inner + ")" * depth
    if kind == "call":
        f = draw(st.sampled_from(FUNCS[:13]))
        return f"{f}(" * depth + inner + ")" * depth
    if kind == "pow":
        return "**".join([draw(st.sampled_from([*NUMBERS, "a"])) for _ in range(depth % 12 + 2)])
    if kind == "neg":
        return "-" * depth + inner
    if kind == "sum":
        return " + ".join([inner] * (depth + 1))
    cond = draw(st.sampled_from(["t < 1", "a >= b and t > 0", "a < 1 or b < 2", "1 < 2",
                                 "piecewise(t < 1, t, 1) < 0.5", "abs(a) <= 1"]))
    return "piecewise(" * (depth % 30) + f"{cond}, {inner}, 0" + ")" * (depth % 30)


LEAVES = st.sampled_from(["0", "1", "2", "0.5", "1e-10", "351", "1e308", "1e-300", "9" * 30,
                          "a", "b", "t", "pi"])


def _extend(children):
    binary = st.tuples(children, st.sampled_from(["+", "-", "*", "/", "**"]), children).map(
        lambda x: f"({x[0]}){x[1]}({x[2]})")
    call = st.tuples(st.sampled_from(["sin", "exp", "log", "sqrt", "acos", "abs", "sign", "step"]),
                     children).map(lambda x: f"{x[0]}({x[1]})")
    pair = st.tuples(st.sampled_from(["atan2", "min", "max"]), children, children).map(
        lambda x: f"{x[0]}({x[1]}, {x[2]})")
    case = st.tuples(children, st.sampled_from(["<", "<=", ">", ">="]), LEAVES, children,
                     children).map(lambda x: f"piecewise({x[0]} {x[1]} {x[2]}, {x[3]}, {x[4]})")
    return st.one_of(binary, call, pair, case, children.map(lambda c: f"-{c}"))


#: Random expressions of the grammar with extreme constants (found the distributed powers
#: ``(1e-300*b)**10**30`` that bench_parser's fuzz run caught).
GRAMMAR = st.recursive(LEAVES, _extend, max_leaves=12)


def _check(text: str) -> None:
    try:
        result = parse_expression(text, NS, key_path="outputs.y")
    except ExpressionError as exc:
        message = str(exc)
        assert "\n" not in message and message.startswith("outputs.y: "), message
        return
    assert isinstance(result, sp.Expr), (text, result)
    assert not result.has(sp.nan, sp.zoo, sp.oo, -sp.oo, sp.I), (text, result)


FUZZ = settings(max_examples=EXAMPLES, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])


@FUZZ
@given(token_soup())
def test_token_soup_gives_an_expression_or_one_error_line(text: str) -> None:
    """Property: a sympy expression or one ExpressionError line, nothing else."""
    _check(text)


@settings(max_examples=max(EXAMPLES // 5, 300), deadline=None, database=None)
@given(nested())
def test_deep_and_extreme_expressions_give_an_expression_or_one_error_line(text: str) -> None:
    """Property: nesting beyond the depth limit, towers of powers and out-of-range constants
    are refused with one line (never RecursionError/OverflowError)."""
    _check(text)


@settings(max_examples=max(EXAMPLES // 3, 300), deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(GRAMMAR)
def test_grammar_trees_give_an_expression_or_one_error_line(text: str) -> None:
    """Property: well-formed expressions with extreme constants and powers give an expression
    or one error line quickly."""
    _check(text)
