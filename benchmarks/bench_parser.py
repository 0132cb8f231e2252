#!/usr/bin/env python3
"""Expression-parser benchmarks: linear-time sums, bounded constants, and a long fuzz.

Measured in one run:

1. parse time of an n-term sum ``Σ (i+2)*x_i*sin(x_i) - x_i/3`` for growing n, by our parser
   (``neweul_py.description.parse_expression``) and by sympy's ``parse_expr`` (the peer: it
   evaluates Python code, which is why the package never uses it), with the ratio and the growth
   factor per 4× terms (4 = linear, 16 = quadratic);
2. time to the answer (value or one-line error) of the issue-12 reproducers;
3. a fuzz run of ≥ 20 000 random token soups (``--fuzz N``) through the parser: it prints the
   count, how many parsed / were refused, and every other exception (there must be none).

Usage::

    python benchmarks/bench_parser.py            # sizes 500, 2000, 8000; 20 000 fuzz cases
    python benchmarks/bench_parser.py --quick    # sizes 250, 1000; 2 000 fuzz cases

Nothing here asserts a time: the script prints figures and ratios.
"""

from __future__ import annotations

import argparse
import random
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import sympy as sp  # noqa: E402
from sympy.parsing.sympy_parser import parse_expr  # noqa: E402

from neweul_py.description import ExpressionError, parse_expression  # noqa: E402
from neweul_py.model import symbol  # noqa: E402
from neweul_py.model import time as model_time  # noqa: E402

REPRODUCERS = ["351**-1e-10", "10**400", "acos(sin(10**400))", "acos(sin(10**300))",
               "exp(1000)", "(" * 2000 + "1" + ")" * 2000, "-" * 5000 + "1",
               "2**" * 300 + "2", "min(" * 40 + "t" + ", 1)" * 40]
VOCABULARY = (["0", "1", "2", "0.5", "1e-10", "351", "1e308", "1e309", "1e400", "9" * 40,
               "a", "b", "t", "pi", "x", "and", "or", "lambda", "__class__"]
              + [f + "(" for f in ("sin", "cos", "exp", "log", "sqrt", "acos", "atan2", "abs",
                                   "min", "max", "step", "piecewise", "foo")]
              + ["+", "-", "*", "/", "**", "(", ")", ",", "<", "<=", ">", ">=", "==", "^",
                 ".", "[", "'", ";", "@", " "])


PEER_MAX = 2000


def _sum_text(n: int) -> str:
    return " + ".join(f"{i + 2}*x{i}*sin(x{i}) - x{i}/3" for i in range(n))


def bench_sums(sizes: list[int]) -> None:
    print("1. n-term sums: parse time [s]")
    print(f"{'n':>6} {'kB':>6} {'ours':>8} {'parse_expr':>11} {'peer/ours':>10} {'growth':>7}")
    previous = None
    for n in sizes:
        text = _sum_text(n)
        names = {f"x{i}": symbol(f"x{i}") for i in range(n)}
        sp.core.cache.clear_cache()
        t0 = time.perf_counter()
        ours = parse_expression(text, names)
        t_ours = time.perf_counter() - t0
        growth = f"{t_ours / previous:7.1f}" if previous else " " * 7
        if n > PEER_MAX:  # parse_expr is quadratic: minutes beyond
            print(f"{n:>6} {len(text) / 1e3:>6.1f} {t_ours:>8.3f} {'–':>11} {'–':>10} {growth}")
            previous = t_ours
            continue
        sp.core.cache.clear_cache()
        t0 = time.perf_counter()
        try:
            peer = parse_expr(text, local_dict=names)
        except (RecursionError, ValueError) as exc:  # Python's compiler gives up
            failure = type(exc.__cause__ or exc).__name__
            print(f"{n:>6} {len(text) / 1e3:>6.1f} {t_ours:>8.3f} {'fails':>11} {'–':>10} "
                  f"{growth}   (parse_expr: {type(exc).__name__}/{failure})")
            previous = t_ours
            continue
        t_peer = time.perf_counter() - t0
        assert sp.expand(ours - peer) == 0
        print(f"{n:>6} {len(text) / 1e3:>6.1f} {t_ours:>8.3f} {t_peer:>11.3f} "
              f"{t_peer / t_ours:>10.1f} {growth}")
        previous = t_ours


def bench_reproducers() -> None:
    print("\n2. issue-12 reproducers: time to the answer")
    for text in REPRODUCERS:
        t0 = time.perf_counter()
        try:
            value = str(parse_expression(text, {"t": model_time}))
        except ExpressionError as exc:
            value = "error: " + exc.reason
        shown = text if len(text) <= 24 else text[:21] + "…"
        print(f"  {time.perf_counter() - t0:7.4f} s  {shown:<25} → {value[:70]}")


_LEAVES = ["0", "1", "2", "0.5", "1e-10", "351", "1e308", "1e-300", "9" * 30, "a", "b", "t",
           "pi"]
_CALLS = {"sin": 1, "cos": 1, "exp": 1, "log": 1, "sqrt": 1, "acos": 1, "atan2": 2, "abs": 1,
          "sign": 1, "min": 3, "max": 2, "step": 1}


def _tree(rng: random.Random, depth: int) -> str:
    """A random expression of the language (mostly valid; extreme constants on purpose)."""
    if depth == 0 or rng.random() < 0.25:
        return rng.choice(_LEAVES)
    kind = rng.random()
    if kind < 0.4:
        op = rng.choice(["+", "-", "*", "/", "**"])
        return f"({_tree(rng, depth - 1)}){op}({_tree(rng, depth - 1)})"
    if kind < 0.5:
        return f"-{_tree(rng, depth - 1)}"
    if kind < 0.85:
        name = rng.choice(sorted(_CALLS))
        args = ", ".join(_tree(rng, depth - 1) for _ in range(_CALLS[name]))
        return f"{name}({args})"
    cond = f"{_tree(rng, depth - 1)} {rng.choice(['<', '<=', '>', '>='])} {_tree(rng, 1)}"
    if rng.random() < 0.3:
        cond += f" and t > {rng.choice(_LEAVES)}"
    return f"piecewise({cond}, {_tree(rng, depth - 1)}, {_tree(rng, depth - 1)})"


def _case(rng: random.Random) -> str:
    """Half grammar trees (a third of them mutated by a random token), half token soups."""
    if rng.random() < 0.5:
        return "".join(rng.choice(VOCABULARY) for _ in range(rng.randint(0, 30)))
    text = _tree(rng, rng.randint(1, 5))
    if rng.random() < 0.33:
        k = rng.randint(0, len(text))
        text = text[:k] + rng.choice(VOCABULARY) + text[k + rng.randint(0, 2):]
    return text


def fuzz(count: int, seed: int = 12) -> None:
    rng = random.Random(seed)
    names = {"a": symbol("a"), "b": symbol("b"), "t": model_time}
    parsed = refused = 0
    other: list[tuple[str, str]] = []
    t0 = time.perf_counter()
    for _ in range(count):
        text = _case(rng)
        try:
            parse_expression(text, names)
            parsed += 1
        except ExpressionError as exc:
            refused += 1
            if "\n" in str(exc):
                other.append((text, "multi-line message"))
        except Exception as exc:
            other.append((text, f"{type(exc).__name__}: {exc}"))
    elapsed = time.perf_counter() - t0
    print(f"\n3. fuzz: {count} expressions in {elapsed:.1f} s ({count / elapsed:.0f}/s): "
          f"{parsed} parsed, {refused} refused with one line, {len(other)} other exceptions")
    for text, what in other[:10]:
        print(f"   {text!r}: {what}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--fuzz", type=int, default=None, help="fuzz cases (default 20 000)")
    args = parser.parse_args()
    bench_sums([250, 1000] if args.quick else [500, 2000, 8000])
    bench_reproducers()
    fuzz(args.fuzz or (2000 if args.quick else 20_000))


if __name__ == "__main__":
    main()
