"""Mutators of user inputs for the fuzzing tests (tests/*/test_*fuzz*) and benchmarks/bench_fuzz.py.

Each mutator takes a :class:`random.Random` (hypothesis draws it with ``st.randoms()``, the
benchmark seeds its own) and returns a mutated copy of a valid input: a description (as a YAML tree
or as text), the lines of a text data file (SID, Matrix Market), the arrays and metadata of an
``.npz`` file, or a command line. The property every consumer checks: a
:class:`~neweul_py.errors.NeweulError` with one line, or a result — never another exception, a hang
or a partial file (:func:`outcome`).
"""

from __future__ import annotations

import copy
import json
import random
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from neweul_py.errors import NeweulError

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
#: Small shipped descriptions: derivation and generation take well under a second each.
SEED_DESCRIPTIONS = ("pendulum", "double_pendulum", "cart_pendulum", "quarter_car",
                     "slider_crank")

#: Replacement values: wrong types, non-finite and huge numbers, bad expressions, names.
VALUES: tuple[Any, ...] = (
    None, True, 0, -1, 1, 2.5, 1e308, -1e308, 10**400, float("nan"), float("inf"), "", "x",
    "nan", "inf", "1e400", "-1", "m", "phi", "t", "2*pi", "sin(", "1/0", "exp(1000)",
    "sqrt(-1)", "m**m", "__import__('os')", "l + ", "ISYS", "d_phi", [], [1], [1, 2, 3],
    [[1, 0, 0], [0, 1, 0], [0, 0, 1]], ["y", "phi"], [["y", "phi"]], {}, {"a": 1},
    {"diag": [1, 1, 1]}, {"type": "spring_damper"}, {"type": ["force"]}, ["force"],
    "pend\n", "a b", "é",
)


#: Replacement values that often keep a description valid (so that the mutation reaches
#: derivation, code generation and evaluation).
PLAUSIBLE: tuple[Any, ...] = (
    0, 1, -1, 2.5, 1e-300, 1e300, 1e308, "2*pi", "m*l", "sqrt(2)", "exp(1000)", "-m",
    "sin(phi)", "t", [0, 0, 0], [1, 0, 0], 0.0, "1/m",
)


def seed_trees() -> dict[str, Any]:
    """The parsed YAML trees of :data:`SEED_DESCRIPTIONS`."""
    return {name: yaml.safe_load((EXAMPLES / f"{name}.yaml").read_text())
            for name in SEED_DESCRIPTIONS}


def _paths(tree: Any, prefix: tuple = ()) -> list[tuple]:
    out = [prefix]
    if isinstance(tree, dict):
        for k, v in tree.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(tree, list):
        for i, v in enumerate(tree):
            out += _paths(v, (*prefix, i))
    return out


def _get(tree: Any, path: tuple) -> Any:
    for k in path:
        tree = tree[k]
    return tree


def mutate_tree(tree: Any, rng: random.Random, steps: int | None = None,
                plausible: bool = False) -> Any:
    """A copy of a description tree with 1–3 random edits: a value replaced (by one of
    :data:`VALUES` or by another node of the tree), a key deleted, renamed or added, a list
    entry duplicated or dropped, or a deep nesting inserted. With ``plausible``: one leaf
    replaced by one of :data:`PLAUSIBLE`."""
    tree = copy.deepcopy(tree)
    if plausible:
        leaves = [p for p in _paths(tree) if p and not isinstance(_get(tree, p), dict | list)]
        if leaves:
            path = rng.choice(leaves)
            _get(tree, path[:-1])[path[-1]] = copy.deepcopy(rng.choice(PLAUSIBLE))
        return tree
    for _ in range(steps or rng.randint(1, 3)):
        paths = _paths(tree)
        path = rng.choice(paths)
        if not path:
            continue
        parent, key = _get(tree, path[:-1]), path[-1]
        op = rng.random()
        if op < 0.55:
            value = rng.choice(VALUES) if rng.random() < 0.8 else copy.deepcopy(
                _get(tree, rng.choice(paths)))
            parent[key] = copy.deepcopy(value)
        elif op < 0.7 and isinstance(parent, dict):
            del parent[key]
        elif op < 0.8 and isinstance(parent, dict):
            parent[rng.choice(["zz", "type", "mass", "frame", "d_x", "ISYS", "t"])] = \
                copy.deepcopy(parent[key])
        elif op < 0.9 and isinstance(parent, list):
            if rng.random() < 0.5:
                parent.append(copy.deepcopy(parent[key]))
            else:
                del parent[key]
        else:
            deep: Any = 1
            for _ in range(rng.choice([3, 70, 300])):
                deep = [deep]
            parent[key] = deep
    return tree


def dump(tree: Any) -> str:
    """YAML text of a tree (non-finite floats and big ints as YAML writes them)."""
    return yaml.safe_dump(tree, sort_keys=False, allow_unicode=True, width=10**6)


def mutate_lines(lines: list[str], rng: random.Random) -> list[str]:
    """A copy of a text file's lines with 1–4 edits: a line dropped, duplicated, truncated, a
    word replaced by a bad number or keyword, a token appended."""
    lines = list(lines)
    words = ["nan", "-1", "1e400", "0", "x", "99999999999", "-0.5", "3", "end", "new", "1e308",
             "1000000000"]
    for _ in range(rng.randint(1, 4)):
        if not lines:
            break
        i = rng.randrange(len(lines))
        op = rng.randint(0, 5)
        if op == 0:
            del lines[i]
        elif op == 1:
            lines.insert(i, lines[rng.randrange(len(lines))])
        elif op == 2:
            w = lines[i].split()
            if w:
                w[rng.randrange(len(w))] = rng.choice(words)
                lines[i] = " ".join(w)
        elif op == 3:
            lines[i] = lines[i][: rng.randrange(len(lines[i]) + 1)]
        elif op == 4:
            lines[i] = lines[i].replace("=", " = = ")
        else:
            lines[i] += " 7"
    return lines


def mutate_bytes(data: bytes, rng: random.Random) -> bytes:
    """A copy of a text file's bytes with 1–3 byte-level edits: bytes that are not UTF-8 (a
    Latin-1 ``é``, a lone continuation byte), a NUL, a byte-order mark, a very long field, a
    cut in the middle, CR line ends, a quote that never closes."""
    data = bytearray(data)
    inserts = [b"\xe9", b"\x80", b"\x00", b"\xef\xbb\xbf", b"9" * 5000, b",", b"\r\n",
               b'"', b"\n\n\n", b"#", b"1e400", b"nan"]
    for _ in range(rng.randint(1, 3)):
        i = rng.randrange(len(data) + 1)
        op = rng.randint(0, 2)
        if op == 0:
            data[i:i] = rng.choice(inserts)
        elif op == 1:
            del data[i:i + rng.randint(1, 8)]
        else:
            data = data[:i]
    return bytes(data)


def mutate_npz(arrays: dict[str, np.ndarray], rng: random.Random,
               meta_key: str = "meta") -> dict[str, np.ndarray]:
    """A copy of an ``.npz``'s arrays with 1–3 edits to the JSON metadata (a field replaced by
    a value of another type) or to an array (strings, truncated, empty, NaN, huge, dropped)."""
    arrays = dict(arrays)
    meta = json.loads(arrays[meta_key].tobytes()) if meta_key in arrays else {}
    meta_values = [None, 1, -1, 2.5, "x", [], [1], ["a"], {}, {"a": 1}, True, 1e308, [[1]], "",
                   {"f": [[1, 1.0]]}, {"f": [["a", 1]]}, ["x"] * 40]
    for _ in range(rng.randint(1, 3)):
        if meta and rng.random() < 0.5:
            key = rng.choice(list(meta))
            if isinstance(meta[key], dict) and meta[key] and rng.random() < 0.5:
                meta[key][rng.choice(list(meta[key]))] = copy.deepcopy(rng.choice(meta_values))
            else:
                meta[key] = copy.deepcopy(rng.choice(meta_values))
            continue
        keys = [k for k in arrays if k != meta_key]
        if not keys:
            continue
        key = rng.choice(keys)
        a = arrays[key]
        op = rng.randint(0, 5)
        if op == 0:
            arrays[key] = a.astype(str)
        elif op == 1:
            arrays[key] = a.ravel()[: max(0, a.size - 1)]
        elif op == 2:
            arrays[key] = np.array([])
        elif op == 3 and a.dtype.kind == "f":
            with np.errstate(all="ignore"):
                arrays[key] = np.where(rng.random() < 0.5, np.nan, a * 1e300)
        elif op == 4 and a.dtype.kind in "iu":
            arrays[key] = a + 10**9
        else:
            del arrays[key]
    if meta_key in arrays or meta:
        arrays[meta_key] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8).copy()
    return arrays


def outcome(call: Callable[[], Any]) -> str:
    """``"ok"`` or ``"error"`` (a :class:`NeweulError` with a one-line message); any other
    exception propagates (a bug: the fuzzing property fails)."""
    try:
        call()
    except NeweulError as exc:
        text = str(exc)
        assert text and "\n" not in text.strip(), f"not one line: {text!r}"
        return "error"
    return "ok"


def examples(n: int) -> int:
    """``max_examples`` for a fuzz test: ``n`` in CI, 20 n with ``NEWEUL_FUZZ_LONG=1``."""
    import os

    return n * 20 if os.environ.get("NEWEUL_FUZZ_LONG") == "1" else n


def fuzz_settings(n: int):
    """Hypothesis settings of a fuzz test: :func:`examples` (n) cases, reproducible
    (derandomized, no example database), no deadline (no wall-clock limit in tests)."""
    from hypothesis import HealthCheck, settings

    return settings(max_examples=examples(n), deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))
