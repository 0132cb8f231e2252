"""The cases of a parameter sweep: value lists and ranges, grids, and CSV files of cases.

A *case* is a mapping parameter name → value; a sweep runs one task per case with the
parameter vector changed, never the code: parameters are numbers of the generated module.
"""

from __future__ import annotations

import csv
import itertools
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ..errors import DataError, NeweulError
from ..files import read_text

__all__ = ["MAX_CASES", "MAX_CASES_BYTES", "Case", "grid", "parse_parameter", "parse_values",
           "product", "read_cases"]

Case = dict[str, float]

#: Largest number of cases of one sweep (a grid, a cases file, or their product;
#: docs/limits.md): a million simulations is days of work on a workstation.
MAX_CASES = 1_000_000
#: Largest cases file read (bytes): a million rows of a few parameters.
MAX_CASES_BYTES = 64 * 2**20


def _check_count(count: int, what: str) -> None:
    if count > MAX_CASES:
        raise NeweulError(f"{what}: {count} cases, more than the cap of {MAX_CASES} "
                          "(docs/limits.md)")


def parse_values(text: str, name: str = "") -> np.ndarray:
    """Values of one swept parameter: ``"START:STOP:COUNT"`` (``COUNT`` equally spaced values
    including both ends), ``"1,2,3"`` (a list) or ``"2.5"`` (one value).

    Raises
    ------
    NeweulError
        Naming the parameter and the accepted forms.
    """
    what = f"--param {name}=" if name else ""
    try:
        if ":" in text:
            start, stop, count = text.split(":")
            k = int(count)
            if k < 1:
                raise ValueError
            if k > MAX_CASES:
                raise NeweulError(f"{what}{text!r}: COUNT {k} is more than the cap of "
                                  f"{MAX_CASES} cases (docs/limits.md)")
            values = np.linspace(float(start), float(stop), k)
        else:
            values = np.array([float(v) for v in text.split(",") if v.strip()])
        if values.size == 0 or not np.all(np.isfinite(values)):
            raise ValueError
    except ValueError:
        raise NeweulError(
            f"{what}{text!r}: expected START:STOP:COUNT (e.g. 0.5:2:16), a comma list (1,2,3) "
            "or one number"
        ) from None
    return values


def parse_parameter(text: str) -> tuple[str, np.ndarray]:
    """``"m=0.5:2:16"`` → ``("m", array of 16 values)`` (an argparse-friendly form)."""
    name, sep, values = text.partition("=")
    if not sep or not name.strip():
        raise NeweulError(f"--param {text!r}: expected NAME=VALUES (e.g. m=0.5:2:16 or k=1,2,3)")
    return name.strip(), parse_values(values.strip(), name.strip())


def grid(values: Mapping[str, Sequence[float] | np.ndarray]) -> list[Case]:
    """All combinations of the values of each parameter (the last one varies fastest).

    Examples
    --------
    >>> grid({"m": [1, 2], "k": [10, 20, 30]})[:2]
    [{'m': 1.0, 'k': 10.0}, {'m': 1.0, 'k': 20.0}]
    """
    names = list(values)
    lists = [np.asarray(values[n], dtype=float).reshape(-1) for n in names]
    _check_count(math.prod(len(v) for v in lists), "the grid")
    return [dict(zip(names, map(float, combo), strict=True))
            for combo in itertools.product(*lists)]


def product(a: Sequence[Case], b: Sequence[Case]) -> list[Case]:
    """Every case of ``a`` combined with every case of ``b`` (``b`` wins on a shared name)."""
    if not a:
        return [dict(c) for c in b]
    if not b:
        return [dict(c) for c in a]
    _check_count(len(a) * len(b), "the cases times the grid")
    return [{**x, **y} for x in a for y in b]


def read_cases(path: str | os.PathLike[str]) -> list[Case]:
    """Cases from a CSV file: a header row of parameter names, one case per row.

    Raises
    ------
    DataError
        Naming the file: not a regular UTF-8 file of at most :data:`MAX_CASES_BYTES` bytes
        (:func:`neweul_py.files.read_text`), more than :data:`MAX_CASES` rows, the row and
        column of a value that is not a finite number, or an empty header/body.
    """
    path = Path(path)
    text = read_text(path, "cases file", MAX_CASES_BYTES)
    lines = text.splitlines()
    if len(lines) > MAX_CASES + 1 and sum(
            1 for ln in lines if ln.strip() and not ln.startswith("#")) > MAX_CASES + 1:
        raise DataError(f"more than the cap of {MAX_CASES} cases (docs/limits.md)",
                        file=str(path))
    try:
        rows = [r for r in csv.reader(lines) if r and not r[0].startswith("#")]
    except csv.Error as exc:
        raise DataError(f"not a CSV table ({exc})", file=str(path)) from None
    if len(rows) < 2:
        raise DataError("expected a header row of parameter names and at least one case",
                        file=str(path))
    names = [h.strip() for h in rows[0]]
    if any(not n for n in names) or len(set(names)) != len(names):
        raise DataError(f"the header needs distinct, non-empty names, got {rows[0]}",
                        file=str(path))
    cases = []
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(names):
            raise DataError(f"row {line} has {len(row)} values for {len(names)} columns",
                            file=str(path))
        case = {}
        for n, v in zip(names, row, strict=True):
            try:
                x = float(v)
            except ValueError:
                x = float("nan")
            if not np.isfinite(x):
                raise DataError(f"row {line}, column {n!r}: {v.strip()!r} is not a finite "
                                "number", file=str(path))
            case[n] = x
        cases.append(case)
    return cases
