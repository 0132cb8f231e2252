"""The safe expression language of description files.

A tokenizer and a recursive-descent (precedence-climbing) parser that build sympy expressions
directly from tokens. User text is never handed to ``eval``, ``exec``, sympy's string parser or
Python's ``ast``: the only things that can come out of a string are numbers (converted by this
module from digits it has validated), the symbols of a caller-supplied namespace, ``pi`` and the
fixed list of functions below.

Grammar (lowest precedence first)::

    expression := term (("+" | "-") term)*
    term       := unary (("*" | "/") unary)*
    unary      := ("+" | "-") unary | power
    power      := atom ("**" unary)?          # right-associative: a**b**c = a**(b**c)
    atom       := NUMBER | NAME | NAME "(" arguments ")" | "(" expression ")"
    arguments  := expression ("," expression)*

so ``-a**2`` is ``-(a**2)`` and ``2**-1`` is ``1/2``, as in Python.

Numbers become exact sympy numbers: ``3`` → ``Integer(3)``, ``0.1`` and ``1e-3`` →
``Rational(1, 10)`` and ``Rational(1, 1000)``; the generated code prints them back as floats.
"""

from __future__ import annotations

import keyword
import math
import re
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from fractions import Fraction

import sympy as sp
from sympy.printing.str import StrPrinter

from ..errors import ModelError

__all__ = [
    "CONSTANTS",
    "FUNCTIONS",
    "ExpressionError",
    "as_expression",
    "format_expression",
    "number",
    "parse_expression",
]


class ExpressionError(ModelError):
    """A string that is not a valid expression of the description language.

    Parameters
    ----------
    message
        What is wrong and what was expected.
    text
        The expression text.
    column
        1-based column of the offending character (``None`` if it concerns the whole text).
    key_path
        Where the expression sits in the model (``bodies.arm.mass``).
    """

    def __init__(
        self, message: str, text: str = "", column: int | None = None, key_path: str = ""
    ) -> None:
        self.text = text
        self.column = column
        self.reason = message
        shown = _excerpt(text, column)
        where = f"column {column} of {shown}" if column is not None else shown
        super().__init__(f"in expression {where}: {message}", key_path)


def _excerpt(text: str, column: int | None, width: int = 60) -> str:
    """``repr`` of ``text``, shortened around ``column`` when it is long."""
    if len(text) <= width:
        return repr(text)
    center = (column or 1) - 1
    start = max(0, min(center - width // 2, len(text) - width))
    piece = text[start:start + width]
    return ("…" if start > 0 else "") + repr(piece) + ("…" if start + width < len(text) else "")


@dataclass(frozen=True)
class _Function:
    min_args: int
    max_args: int | None  # None: any number >= min_args
    build: Callable[..., sp.Expr]

    def arity(self) -> str:
        if self.max_args == self.min_args:
            return f"{self.min_args} argument{'s' if self.min_args != 1 else ''}"
        if self.max_args is None:
            return f"at least {self.min_args} arguments"
        return f"{self.min_args} to {self.max_args} arguments"


#: The functions of the language: name → (argument count, sympy constructor).
FUNCTIONS: Mapping[str, _Function] = {
    "sin": _Function(1, 1, sp.sin),
    "cos": _Function(1, 1, sp.cos),
    "tan": _Function(1, 1, sp.tan),
    "asin": _Function(1, 1, sp.asin),
    "acos": _Function(1, 1, sp.acos),
    "atan": _Function(1, 1, sp.atan),
    "atan2": _Function(2, 2, sp.atan2),
    "sinh": _Function(1, 1, sp.sinh),
    "cosh": _Function(1, 1, sp.cosh),
    "tanh": _Function(1, 1, sp.tanh),
    "exp": _Function(1, 1, sp.exp),
    "log": _Function(1, 1, sp.log),
    "sqrt": _Function(1, 1, sp.sqrt),
    "abs": _Function(1, 1, sp.Abs),
    "sign": _Function(1, 1, sp.sign),
    "min": _Function(2, None, sp.Min),
    "max": _Function(2, None, sp.Max),
    "heaviside": _Function(1, 1, sp.Heaviside),
}

#: Named constants of the language.
CONSTANTS: Mapping[str, sp.Expr] = {"pi": sp.pi}

_MAX_DEPTH = 100  # nesting depth of parentheses/unary operators/calls
_MAX_NUMBER_LENGTH = 1000
_MAX_DIGITS = 1000  # of number**number, to keep sympy from building astronomic integers

# --------------------------------------------------------------------------- tokenizer
_NUMBER = re.compile(r"(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_OPERATORS = ("**", "+", "-", "*", "/", "(", ")", ",")
_HINTS = {
    ".": "attribute access is not allowed",
    "'": "strings are not allowed",
    '"': "strings are not allowed",
    "[": "brackets/indexing are not allowed; use ( ) for grouping",
    "]": "brackets/indexing are not allowed; use ( ) for grouping",
    "{": "braces are not allowed",
    "}": "braces are not allowed",
    "^": "use ** for powers",
    ":": "lambdas, slices and annotations are not allowed",
    "=": "assignments and comparisons are not allowed",
    ";": "only a single expression is allowed",
}


@dataclass(frozen=True)
class _Token:
    kind: str  # "number", "name", an operator, or "end"
    text: str
    column: int  # 1-based


def _tokenize(text: str) -> Iterator[_Token]:
    """Yield the tokens of ``text`` lazily, so errors come in reading order."""
    pos = 0
    n = len(text)
    while pos < n:
        ch = text[pos]
        if ch in " \t\r\n":
            pos += 1
            continue
        m = _NUMBER.match(text, pos)
        if m:
            end = m.end()
            if end < n and (text[end].isalnum() or text[end] in "_."):
                raise ExpressionError(
                    f"malformed number {text[pos:end + 1]!r}", text, pos + 1
                )
            if end - pos > _MAX_NUMBER_LENGTH:
                raise ExpressionError("number literal is too long", text, pos + 1)
            yield _Token("number", m.group(), pos + 1)
            pos = end
            continue
        m = _NAME.match(text, pos)
        if m:
            yield _Token("name", m.group(), pos + 1)
            pos = m.end()
            continue
        for op in _OPERATORS:
            if text.startswith(op, pos):
                yield _Token(op, op, pos + 1)
                pos += len(op)
                break
        else:
            hint = _HINTS.get(ch, "expected a number, a name, an operator (+ - * / **), "
                                  "a parenthesis or a comma")
            raise ExpressionError(f"unexpected character {ch!r}; {hint}", text, pos + 1)
    yield _Token("end", "", n + 1)


def _describe(token: _Token) -> str:
    if token.kind == "end":
        return "end of expression"
    if token.kind == "number":
        return f"number {token.text}"
    if token.kind == "name":
        return f"name {token.text!r}"
    return repr(token.text)


# --------------------------------------------------------------------------- numbers
def number(value: object, key_path: str = "") -> sp.Rational:
    """Convert a Python ``int``/``float`` (e.g. from YAML) into an exact sympy number.

    ``bool``, NaN and infinities are rejected with :class:`ModelError`. Floats are converted
    through their shortest decimal representation, so ``0.1`` becomes ``1/10`` — the same
    number the parser makes of the text ``"0.1"``.
    """
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ModelError(f"expected a number, got {type(value).__name__} {value!r}", key_path)
    if isinstance(value, int):
        return sp.Integer(value)
    if not math.isfinite(value):
        raise ModelError(f"expected a finite number, got {value!r}", key_path)
    frac = Fraction(repr(value))
    return sp.Rational(frac.numerator, frac.denominator)


def _number_token(token: _Token, text: str) -> sp.Rational:
    digits = token.text
    if all(c.isdigit() for c in digits):
        return sp.Integer(int(digits))
    exponent = digits.lower().partition("e")[2]
    if (exponent and abs(int(exponent)) > 400) or not math.isfinite(float(digits)):
        raise ExpressionError(f"number {digits} is out of range", text, token.column)
    frac = Fraction(digits)
    return sp.Rational(frac.numerator, frac.denominator)


def _is_real_number(value: sp.Expr) -> bool:
    """Whether a constant sympy expression is real (numerically, where sympy cannot tell)."""
    if value.is_real is not None:
        return bool(value.is_real)
    imag = sp.im(value).evalf(30)
    return bool(imag.is_zero) or abs(complex(imag)) < 1e-25


def _too_large(base: sp.Expr, exponent: sp.Expr) -> bool:
    """Whether the exact number ``base**exponent`` would have more than ``_MAX_DIGITS`` digits
    (or leading zeros)."""
    if not (base.is_Rational and exponent.is_Rational) or base.is_zero or abs(base) == 1:
        return False
    if abs(exponent) > 10**6:
        return True
    digits = abs(math.log10(abs(base.p)) - math.log10(base.q))
    return float(abs(exponent)) * digits > _MAX_DIGITS


# --------------------------------------------------------------------------- parser
class _Parser:
    def __init__(
        self,
        text: str,
        namespace: Mapping[str, sp.Expr],
        unavailable: Mapping[str, str],
    ) -> None:
        self.text = text
        self._tokens = _tokenize(text)
        self.token = next(self._tokens)
        self.namespace = namespace
        self.unavailable = unavailable
        self.depth = 0

    # helpers
    def advance(self) -> _Token:
        tok = self.token
        self.token = next(self._tokens)
        return tok

    def error(self, message: str, token: _Token | None = None) -> ExpressionError:
        token = token or self.token
        return ExpressionError(message, self.text, token.column)

    def enter(self) -> None:
        self.depth += 1
        if self.depth > _MAX_DEPTH:
            raise self.error(f"expression is nested more than {_MAX_DEPTH} levels deep")

    # grammar
    def parse(self) -> sp.Expr:
        if self.token.kind == "end":
            raise ExpressionError("empty expression; expected a number, a name or '('", self.text)
        result = self.expression()
        if self.token.kind != "end":
            tok = self.token
            if tok.kind == ")":
                raise self.error("unbalanced ')': no matching '('")
            if tok.kind == "name" and keyword.iskeyword(tok.text):
                raise self.error(f"Python keyword {tok.text!r} is not allowed")
            raise self.error(
                f"expected an operator (+ - * / **) or end of expression, found {_describe(tok)}"
            )
        return result

    def expression(self) -> sp.Expr:
        result = self.term()
        while self.token.kind in ("+", "-"):
            op = self.advance().kind
            rhs = self.term()
            result = result + rhs if op == "+" else result - rhs
        return result

    def term(self) -> sp.Expr:
        result = self.unary()
        while self.token.kind in ("*", "/"):
            op = self.advance()
            rhs = self.unary()
            if op.kind == "*":
                result = result * rhs
            else:
                if rhs.is_zero:
                    raise self.error("division by zero", op)
                result = result / rhs
        return result

    def unary(self) -> sp.Expr:
        if self.token.kind in ("+", "-"):
            op = self.advance().kind
            self.enter()
            operand = self.unary()
            self.depth -= 1
            return -operand if op == "-" else operand
        return self.power()

    def power(self) -> sp.Expr:
        base = self.atom()
        if self.token.kind != "**":
            return base
        op = self.advance()
        self.enter()
        exponent = self.unary()
        self.depth -= 1
        if base.is_Number and exponent.is_Number:
            if base.is_zero and exponent.is_negative:
                raise self.error("division by zero (0 to a negative power)", op)
            if _too_large(base, exponent):
                raise self.error(f"the power {base}**{exponent} is too large or too small", op)
        return self.checked(lambda: base**exponent, op)

    def atom(self) -> sp.Expr:
        tok = self.token
        if tok.kind == "number":
            self.advance()
            return _number_token(tok, self.text)
        if tok.kind == "(":
            self.advance()
            if self.token.kind == ")":
                raise self.error("empty parentheses '()' are not allowed (no tuples or calls)")
            self.enter()
            inner = self.expression()
            self.depth -= 1
            if self.token.kind != ")":
                raise self.error(
                    f"expected ')' to close the '(' at column {tok.column}, "
                    f"found {_describe(self.token)}"
                )
            self.advance()
            return inner
        if tok.kind == "name":
            if keyword.iskeyword(tok.text):
                raise self.error(f"Python keyword {tok.text!r} is not allowed")
            self.advance()
            if self.token.kind == "(":
                return self.call(tok)
            return self.name(tok)
        if tok.kind == ")":
            raise self.error("unbalanced ')': no matching '('")
        raise self.error(f"expected a number, a name or '(', found {_describe(tok)}")

    def call(self, name: _Token) -> sp.Expr:
        func = FUNCTIONS.get(name.text)
        if func is None:
            if name.text in self.namespace or name.text in CONSTANTS:
                raise self.error(f"{name.text!r} is not a function", name)
            raise self.error(
                f"unknown function {name.text!r}; functions are: {', '.join(sorted(FUNCTIONS))}",
                name,
            )
        open_paren = self.advance()
        self.enter()
        args: list[sp.Expr] = []
        if self.token.kind != ")":
            args.append(self.expression())
            while self.token.kind == ",":
                self.advance()
                args.append(self.expression())
        if self.token.kind != ")":
            raise self.error(
                f"expected ',' or ')' to close the call of {name.text} at column "
                f"{open_paren.column}, found {_describe(self.token)}"
            )
        self.advance()
        self.depth -= 1
        if len(args) < func.min_args or (func.max_args is not None and len(args) > func.max_args):
            raise self.error(
                f"{name.text}() takes {func.arity()}, got {len(args)}", name
            )
        return self.checked(lambda: func.build(*args), name)

    def checked(self, build: Callable[[], sp.Expr], token: _Token) -> sp.Expr:
        """Build a power or function value; reject constant values that are not real."""
        try:
            result = build()
        except (ValueError, TypeError, ArithmeticError) as exc:
            raise self.error(f"invalid value: {exc}", token) from None
        if result.has(sp.zoo, sp.nan, sp.oo, -sp.oo):
            raise self.error(f"the value {result} is not finite", token)
        if result.is_number and not _is_real_number(result):
            raise self.error(f"the value {result} is not real", token)
        return result

    def name(self, tok: _Token) -> sp.Expr:
        name = tok.text
        if name in CONSTANTS:
            return CONSTANTS[name]
        if name in self.namespace:
            return self.namespace[name]
        if name in FUNCTIONS:
            raise self.error(f"function {name!r} must be called, e.g. {name}(x)", tok)
        allowed = ", ".join(sorted(self.namespace)) or "(none)"
        if name in self.unavailable:
            raise self.error(
                f"{name!r} is {self.unavailable[name]}, which is not allowed here; "
                f"allowed names are: {allowed}",
                tok,
            )
        raise self.error(f"unknown name {name!r}; allowed names are: {allowed}", tok)


def parse_expression(
    text: str,
    namespace: Mapping[str, sp.Expr] | None = None,
    *,
    key_path: str = "",
    unavailable: Mapping[str, str] | None = None,
) -> sp.Expr:
    """Parse ``text`` of the description language into a sympy expression.

    Parameters
    ----------
    text
        The expression, e.g. ``"-m*g*l*sin(phi)"``.
    namespace
        The names allowed here and the sympy objects they stand for (``pi`` and the functions
        of :data:`FUNCTIONS` are always available).
    key_path
        Where the expression is in the model; carried by the error.
    unavailable
        Names that exist in the model but may not be used here, mapped to what they are
        (``{"phi": "a coordinate"}``); only used for a more helpful error message.

    Returns
    -------
    sympy.Expr
        The expression, built from the tokens with sympy's constructors.

    Raises
    ------
    ExpressionError
        With the column, what was expected and, for unknown names, the allowed names.

    Examples
    --------
    >>> import sympy as sp
    >>> a, b = sp.symbols("a b")
    >>> parse_expression("-a**2 + 2*b", {"a": a, "b": b})
    -a**2 + 2*b
    """
    if not isinstance(text, str):
        raise ExpressionError(f"expected a string, got {type(text).__name__}", repr(text))
    try:
        result = _Parser(text, namespace or {}, unavailable or {}).parse()
    except ExpressionError as exc:
        exc.key_path = key_path
        exc.args = (exc._format(),)
        raise
    except RecursionError:
        raise ExpressionError("expression is nested too deeply", text, key_path=key_path) from None
    if result.has(sp.zoo, sp.nan, sp.oo, -sp.oo):
        raise ExpressionError("expression is not finite", text, key_path=key_path)
    if result.has(sp.I):
        raise ExpressionError("expression is not real", text, key_path=key_path)
    return result


def as_expression(
    value: object,
    namespace: Mapping[str, sp.Expr] | None = None,
    *,
    key_path: str = "",
    unavailable: Mapping[str, str] | None = None,
) -> sp.Expr:
    """Turn a number, an expression string or a sympy expression into a sympy expression.

    Numbers go through :func:`number` (no bool, NaN or inf), strings through
    :func:`parse_expression`; sympy expressions are returned unchanged (their symbols are
    checked by :class:`~neweul_py.model.System`).

    Raises
    ------
    ModelError
        For any other type, with ``key_path``.
    """
    if isinstance(value, str):
        return parse_expression(value, namespace, key_path=key_path, unavailable=unavailable)
    if isinstance(value, sp.Basic):
        if isinstance(value, sp.MatrixBase):
            raise ModelError("expected a single expression, not a matrix", key_path)
        return value
    if isinstance(value, int | float) and not isinstance(value, bool):
        return number(value, key_path)
    raise ModelError(
        f"expected a number or an expression string, got {type(value).__name__} {value!r}",
        key_path,
    )


class _LanguagePrinter(StrPrinter):
    """sympy's str printer, with the spellings of the description language."""

    def _print_Abs(self, expr: sp.Expr) -> str:
        return f"abs({self._print(expr.args[0])})"

    def _print_Heaviside(self, expr: sp.Expr) -> str:
        return f"heaviside({self._print(expr.args[0])})"

    def _print_Exp1(self, expr: sp.Expr) -> str:
        return "exp(1)"

    def _print_MinMax(self, expr: sp.Expr, name: str) -> str:
        return f"{name}({', '.join(self._print(a) for a in expr.args)})"

    def _print_Min(self, expr: sp.Expr) -> str:
        return self._print_MinMax(expr, "min")

    def _print_Max(self, expr: sp.Expr) -> str:
        return self._print_MinMax(expr, "max")


def format_expression(expr: sp.Expr) -> str:
    """Print a sympy expression in the description language (inverse of the parser).

    ``parse_expression(format_expression(e), ns) == e`` for expressions of the language
    (floats are printed with full precision and read back as exact rationals).
    """
    return _LanguagePrinter({"full_prec": True}).doprint(expr)
