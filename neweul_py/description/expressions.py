"""The safe expression language of description files.

A tokenizer and a recursive-descent (precedence-climbing) parser that build sympy expressions
directly from tokens. User text is never handed to ``eval``, ``exec``, sympy's string parser or
Python's ``ast``: the only things that can come out of a string are numbers (converted by this
module from digits it has validated), the symbols of a caller-supplied namespace, ``pi`` and the
fixed list of functions of :mod:`~neweul_py.description.functions`.

Grammar (lowest precedence first)::

    condition   := conjunction ("or" conjunction)*
    conjunction := comparison ("and" comparison)*
    comparison  := expression (("<" | "<=" | ">" | ">=") expression)?
    expression  := term (("+" | "-") term)*
    term        := unary (("*" | "/") unary)*
    unary       := ("+" | "-") unary | power
    power       := atom ("**" unary)?          # right-associative: a**b**c = a**(b**c)
    atom        := NUMBER | NAME | NAME "(" arguments ")" | "(" condition ")"
    arguments   := condition ("," condition)*

so ``-a**2`` is ``-(a**2)`` and ``2**-1`` is ``1/2``, as in Python. A value must be an
expression; a condition (a comparison, ``and``, ``or``) is only allowed where
``piecewise(c1, v1, c2, v2, …, default)`` expects one.

Numbers become exact sympy numbers: ``3`` → ``Integer(3)``, ``0.1`` and ``1e-3`` →
``Rational(1, 10)`` and ``Rational(1, 1000)``; the generated code prints them back as floats.

Bounded work (every input gives a result or one :class:`ExpressionError` quickly):

- sums and products are collected and built once (``sympy.Add(*terms)``,
  ``sympy.Mul(*factors)``), so parsing is linear in the length of the text;
- nesting (parentheses, unary signs, powers, calls) is limited to ``_MAX_DEPTH`` levels;
- an expression has at most :data:`MAX_LENGTH` characters, :data:`MAX_TOKENS` tokens and
  :data:`MAX_CALLS` function calls, counted before it is parsed;
- constants stay within the range of doubles; constant powers and function values are
  evaluated with bounded work (:func:`.functions.constant_power`,
  :func:`.functions.constant_value`) — e.g. ``351**-1e-10`` is evaluated numerically, ``exp(1000)``
  and ``10**400`` are refused.
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
from .functions import FUNCTIONS, ConstantError, constant_power, constant_value, in_float_range

__all__ = [
    "CONSTANTS",
    "FUNCTIONS",
    "MAX_CALLS",
    "MAX_LENGTH",
    "MAX_TOKENS",
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


#: Named constants of the language.
CONSTANTS: Mapping[str, sp.Expr] = {"pi": sp.pi}

_MAX_DEPTH = 100  # nesting depth of parentheses/unary operators/calls
#: Longest expression (characters), most tokens and most function calls of one expression
#: (docs/limits.md): ~100 times the longest of the shipped models (115 tokens). Sympy builds
#: each function call with its assumptions (about 2.5 ms for sin(k*x)), so 20 000 of them
#: took minutes; within these caps parsing takes a few seconds at most.
MAX_LENGTH = 100_000
MAX_TOKENS = 10_000
MAX_CALLS = 1_000
_COUNTED = re.compile(r"(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|([A-Za-z_]\w*)(\s*\()?|\*\*|<=|>=|\S")
_MAX_NUMBER_LENGTH = 1000
_MAX_EXPONENT = 1000  # of a numeric power of a non-constant base
_MAX_ROOT, _MAX_ROOT_POWER = 12, 64  # exact rational exponents p/q: q <= 12, |p| <= 64

# --------------------------------------------------------------------------- tokenizer
_NUMBER = re.compile(r"(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_OPERATORS = ("**", "<=", ">=", "+", "-", "*", "/", "(", ")", ",", "<", ">")
_COMPARISONS = {"<": sp.StrictLessThan, "<=": sp.LessThan, ">": sp.StrictGreaterThan,
                ">=": sp.GreaterThan}
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
    "=": "assignments and == are not allowed (comparisons: < <= > >= inside piecewise())",
    "!": "!= is not allowed (comparisons: < <= > >= inside piecewise())",
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

    ``bool``, NaN, infinities and integers beyond the range of doubles are rejected with
    :class:`ModelError`. Floats are converted through their shortest decimal representation, so
    ``0.1`` becomes ``1/10`` — the same number the parser makes of the text ``"0.1"``.
    """
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ModelError(f"expected a number, got {type(value).__name__} {value!r}", key_path)
    if isinstance(value, int):
        if value.bit_length() > 1024:
            raise ModelError("the integer is outside the range of floating-point numbers",
                             key_path)
        return sp.Integer(value)
    if not math.isfinite(value):
        raise ModelError(f"expected a finite number, got {value!r}", key_path)
    frac = Fraction(repr(value))
    return sp.Rational(frac.numerator, frac.denominator)


def _number_token(token: _Token, text: str) -> sp.Rational:
    digits = token.text
    exponent = digits.lower().partition("e")[2]
    if exponent and abs(int(exponent)) > 400:
        raise ExpressionError(f"number {digits} is out of range", text, token.column)
    value = sp.Integer(int(digits)) if digits.isdigit() else sp.Rational(
        *Fraction(digits).as_integer_ratio())
    if not in_float_range(value):
        raise ExpressionError(
            f"number {digits} is out of range (outside the range of floating-point numbers)",
            text, token.column,
        )
    return value


def _is_real_number(value: sp.Expr) -> bool:
    """Whether a constant sympy expression is real (numerically, where sympy cannot tell)."""
    if value.is_real is not None:
        return bool(value.is_real)
    imag = sp.im(value).evalf(30)
    return bool(imag.is_zero) or abs(complex(imag)) < 1e-25


def _too_large(base: sp.Expr, exponent: sp.Expr) -> bool:
    """Whether the constant power ``base**exponent`` is refused as out of range."""
    if not (base.is_number and exponent.is_number):
        return False
    try:
        constant_power(base, exponent)
    except ConstantError:
        return True
    return False


def _tame(expr: sp.Expr, exponent: bool = False) -> sp.Expr:
    """``expr`` with the rationals sympy cannot take roots of quickly as floats.

    Under a non-integer power sympy takes exact roots of numeric factors of the base and of
    numeric terms of the exponent — a perfect-power and factor search that does not end for
    30-digit integers (``(999…9*b)**0.5``, ``c**(a - 1/2)``) or root degrees such as 10**10
    (``351**-1e-10``, ``c**(1e-10 - b)``). So in a base, rationals with more than 64-bit
    numerator or denominator become floats, in an exponent non-integers of a denominator above
    12 or a numerator above 64 (the generated code computes in doubles anyway).
    """
    if exponent:
        big = {r for r in expr.atoms(sp.Rational) if not r.is_Integer
               and (r.q > _MAX_ROOT or abs(r.p) > _MAX_ROOT_POWER)}
    else:
        big = {r for r in expr.atoms(sp.Rational)
               if r.p.bit_length() > 64 or r.q.bit_length() > 64}
    if not big:
        return expr
    # through Fraction: sympy's Float(Rational) prints the integers (at most 4300 digits)
    return expr.xreplace({r: sp.Float(float(Fraction(int(r.p), int(r.q))), 17) for r in big})


def _is_expr(value: sp.Basic) -> bool:
    return isinstance(value, sp.Expr)


# --------------------------------------------------------------------------- parser
class _Parser:
    """Recursive descent over the token stream; each grammar rule is one method."""

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

    def value(self, result: sp.Basic, token: _Token) -> sp.Expr:
        """``result`` if it is a value (not a condition)."""
        if not _is_expr(result):
            raise self.error(
                "a comparison (<, <=, >, >=, and, or) is only allowed as a condition of "
                "piecewise(cond, value, default)", token)
        return result

    def constant(self, result: sp.Expr, token: _Token) -> sp.Expr:
        """Refuse a rational constant — or the numeric coefficient or term of a product or
        sum (sympy keeps it first) — outside the range of doubles."""
        number = result.args[0] if (result.is_Mul or result.is_Add) else result
        if number.is_Rational and not in_float_range(number):
            raise self.error("the constant is outside the range of floating-point numbers",
                             token)
        return result

    # grammar
    def parse(self) -> sp.Expr:
        if self.token.kind == "end":
            raise ExpressionError("empty expression; expected a number, a name or '('", self.text)
        first = self.token
        result = self.condition()
        if self.token.kind != "end":
            tok = self.token
            if tok.kind == ")":
                raise self.error("unbalanced ')': no matching '('")
            if tok.kind == "name" and keyword.iskeyword(tok.text):
                raise self.error(f"Python keyword {tok.text!r} is not allowed")
            raise self.error(
                f"expected an operator (+ - * / **) or end of expression, found {_describe(tok)}"
            )
        return self.value(result, first)

    def condition(self) -> sp.Basic:
        first = self.token
        result = self.conjunction()
        if not (self.token.kind == "name" and self.token.text == "or"):
            return result
        operands = [self.boolean(result, first)]
        while self.token.kind == "name" and self.token.text == "or":
            self.advance()
            tok = self.token
            operands.append(self.boolean(self.conjunction(), tok))
        return sp.Or(*operands)

    def conjunction(self) -> sp.Basic:
        first = self.token
        result = self.comparison()
        if not (self.token.kind == "name" and self.token.text == "and"):
            return result
        operands = [self.boolean(result, first)]
        while self.token.kind == "name" and self.token.text == "and":
            self.advance()
            tok = self.token
            operands.append(self.boolean(self.comparison(), tok))
        return sp.And(*operands)

    def boolean(self, result: sp.Basic, token: _Token) -> sp.Basic:
        if _is_expr(result):
            raise self.error("'and'/'or' join comparisons (a < b and b < c), not values", token)
        return result

    def comparison(self) -> sp.Basic:
        first = self.token
        left = self.expression()
        if self.token.kind not in _COMPARISONS:
            return left
        op = self.advance()
        right_token = self.token
        right = self.value(self.expression(), right_token)
        self.value(left, first)
        if self.token.kind in _COMPARISONS:
            raise self.error("chained comparisons are not allowed; use 'and'")
        for side in (left, right):
            if side.has(sp.Piecewise):
                raise self.error("a comparison may not contain piecewise(); compare the "
                                 "branches in separate conditions instead", op)
        try:
            return _COMPARISONS[op.kind](left, right)
        except TypeError as exc:  # sympy cannot decide a comparison of constants
            raise self.error(f"invalid comparison: {exc}", op) from None

    def expression(self) -> sp.Basic:
        first = self.token
        result = self.term()
        if self.token.kind not in ("+", "-"):
            return result
        terms = [self.value(result, first)]
        while self.token.kind in ("+", "-"):
            op = self.advance()
            tok = self.token
            rhs = self.value(self.term(), tok)
            terms.append(rhs if op.kind == "+" else -rhs)
        return self.constant(sp.Add(*terms), first)

    def term(self) -> sp.Basic:
        first = self.token
        result = self.unary()
        if self.token.kind not in ("*", "/"):
            return result
        factors = [self.value(result, first)]
        while self.token.kind in ("*", "/"):
            op = self.advance()
            tok = self.token
            rhs = self.value(self.unary(), tok)
            if op.kind == "*":
                factors.append(rhs)
            else:
                if rhs.is_zero:
                    raise self.error("division by zero", op)
                factors.append(sp.Pow(rhs, -1))
        return self.constant(sp.Mul(*factors), first)

    def unary(self) -> sp.Basic:
        if self.token.kind in ("+", "-"):
            op = self.advance()
            self.enter()
            tok = self.token
            operand = self.value(self.unary(), tok)
            self.depth -= 1
            return -operand if op.kind == "-" else operand
        return self.power()

    def power(self) -> sp.Basic:
        first = self.token
        base = self.atom()
        if self.token.kind != "**":
            return base
        base = self.value(base, first)
        op = self.advance()
        self.enter()
        tok = self.token
        exponent = self.value(self.unary(), tok)
        self.depth -= 1
        if base.is_number and exponent.is_number:
            return self.checked(lambda: constant_power(base, exponent), op)
        shift = exponent.as_coeff_Add()[0] if base.is_number else exponent
        if shift.is_Rational and abs(shift) > _MAX_EXPONENT:
            # sympy distributes integer powers over products, (1e-300*b)**10**30, and splits
            # off integer terms of exponents, c**(x + 10**30): it would compute them exactly
            raise self.error(f"the exponent {shift} is too large (at most {_MAX_EXPONENT} in "
                             "magnitude for a power of a variable, or as a term of a variable "
                             "exponent)", op)
        if not exponent.is_Integer:
            base, exponent = _tame(base), _tame(exponent, exponent=True)
        return self.checked(lambda: base**exponent, op)

    def atom(self) -> sp.Basic:
        tok = self.token
        if tok.kind == "number":
            self.advance()
            return _number_token(tok, self.text)
        if tok.kind == "(":
            self.advance()
            if self.token.kind == ")":
                raise self.error("empty parentheses '()' are not allowed (no tuples or calls)")
            self.enter()
            inner = self.condition()
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
        args: list[tuple[_Token, sp.Basic]] = []
        if self.token.kind != ")":
            args.append((self.token, self.condition()))  # type: ignore[arg-type]
            while self.token.kind == ",":
                self.advance()
                args.append((self.token, self.condition()))  # type: ignore[arg-type]
        if self.token.kind != ")":
            raise self.error(
                f"expected ',' or ')' to close the call of {name.text} at column "
                f"{open_paren.column}, found {_describe(self.token)}"
            )
        self.advance()
        self.depth -= 1
        n = len(args)
        if n < func.min_args or (func.max_args is not None and n > func.max_args) or (
                func.conditions and n % 2 == 0):
            expected = "an odd number of arguments (cond, value, …, default), at least 3" \
                if func.conditions else func.arity()
            raise self.error(f"{name.text}() takes {expected}, got {n}", name)
        values: list[sp.Basic] = []
        for k, (tok, arg) in enumerate(args):  # type: ignore[misc]
            if func.conditions and k % 2 == 0 and k < n - 1:
                if _is_expr(arg):
                    raise self.error(
                        f"argument {k + 1} of piecewise() must be a condition such as t < T",
                        tok)
                values.append(arg)
            else:
                values.append(self.value(arg, tok))
        if func.numeric is not None and all(v.is_number for v in values):
            return self.checked(lambda: constant_value(func.numeric, tuple(values)), name)
        if func.build is sp.sqrt:
            values = [_tame(v) for v in values]
        return self.checked(lambda: func.build(*values), name)

    def checked(self, build: Callable[[], sp.Expr], token: _Token) -> sp.Expr:
        """Build a power or function value; reject constant values that are not real."""
        try:
            result = build()
        except ConstantError as exc:
            raise self.error(str(exc), token) from None
        except (ValueError, TypeError, ArithmeticError) as exc:
            raise self.error(f"invalid value: {exc}", token) from None
        if result.has(sp.zoo, sp.nan, sp.oo, -sp.oo):
            raise self.error(f"the value {result} is not finite", token)
        if result.is_number and not _is_real_number(result):
            raise self.error(f"the value {result} is not real", token)
        return self.constant(result, token)

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


def _check_size(text: str, key_path: str) -> None:
    """Refuse an expression beyond :data:`MAX_LENGTH` characters, :data:`MAX_TOKENS` tokens
    or :data:`MAX_CALLS` function calls, counted before anything is built."""
    def fail(what: str) -> ExpressionError:
        return ExpressionError(f"the expression has {what} (docs/limits.md)", text,
                               key_path=key_path)

    if len(text) > MAX_LENGTH:
        raise fail(f"{len(text)} characters, more than the cap of {MAX_LENGTH}")
    tokens = calls = 0
    for m in _COUNTED.finditer(text):
        tokens += 1
        calls += m.group(2) is not None
    if tokens > MAX_TOKENS:
        raise fail(f"{tokens} tokens, more than the cap of {MAX_TOKENS}")
    if calls > MAX_CALLS:
        raise fail(f"{calls} function calls, more than the cap of {MAX_CALLS}")


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
    _check_size(text, key_path)
    try:
        result = _Parser(text, namespace or {}, unavailable or {}).parse()
    except ExpressionError as exc:
        exc.key_path = key_path
        exc.args = (exc._format(),)
        raise
    except RecursionError:
        raise ExpressionError("expression is nested too deeply", text, key_path=key_path) from None
    except (ValueError, ArithmeticError, MemoryError) as exc:
        # a safety net under the bounds above: sympy refusing its own numbers (an integer of
        # more than 4300 digits, an overflow) is a property of the text, not a bug
        raise ExpressionError(f"cannot evaluate the numbers of this expression "
                              f"({type(exc).__name__})", text, key_path=key_path) from None
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

    def _print_Piecewise(self, expr: sp.Piecewise) -> str:
        parts = []
        for k, (value, cond) in enumerate(expr.args):
            if k == len(expr.args) - 1:
                parts.append(self._print(value))  # the default (its condition is True)
            else:
                parts += [self._print(cond), self._print(value)]
        if len(expr.args) == 1:
            return parts[0]
        return f"piecewise({', '.join(parts)})"

    def _print_And(self, expr: sp.Basic) -> str:
        return " and ".join(
            f"({self._print(a)})" if isinstance(a, sp.Or) else self._print(a) for a in expr.args
        )

    def _print_Or(self, expr: sp.Basic) -> str:
        return " or ".join(self._print(a) for a in expr.args)

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
    (floats are printed with full precision and read back as exact rationals; a
    ``Piecewise`` whose last condition is not ``True`` prints its last value as the default).
    """
    return _LanguagePrinter({"full_prec": True}).doprint(expr)
