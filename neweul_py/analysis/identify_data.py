"""Measured data for parameter identification (docs/howto/identify.md): a frequency response
as ``neweul frf -o`` writes it, or a time history as ``neweul simulate -o`` writes it.

Every problem is one :class:`~neweul_py.errors.DataError` naming the file and the column (and
the line where one is at fault): a file that is not such a CSV (a row with more fields than
the header, as a decimal comma makes), data of the other task, a missing column, a value that
is not a finite number, frequencies or times that do not increase, negative weights. A UTF-8
byte-order mark is skipped. An optional column ``weight`` (≥ 0) weights each row's residuals.
"""

from __future__ import annotations

import csv
import os
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import DataError
from ..files import read_checked

__all__ = ["FrequencyData", "TimeData", "read_frequency_data", "read_time_data"]

#: Largest data file read (a long measurement is far below).
MAX_DATA_BYTES = 256 * 2**20


@dataclass(frozen=True)
class FrequencyData:
    """A measured frequency response of one output to one input.

    Attributes
    ----------
    frequency_hz : ndarray (nf,)
        Increasing, ≥ 0 (``neweul frf`` writes the static response at 0 Hz).
    H : ndarray (nf,) complex
        ``magnitude · exp(j phase)``.
    weight : ndarray (nf,)
        Weights of the rows (ones without a ``weight`` column).
    response, input : str
        The model output and input the data belong to.
    file : str
    """

    frequency_hz: np.ndarray
    H: np.ndarray
    weight: np.ndarray
    response: str
    input: str
    file: str = "<data>"


@dataclass(frozen=True)
class TimeData:
    """A measured time history.

    Attributes
    ----------
    t : ndarray (nt,)
        Increasing times, ≥ 0.
    columns : dict of str to ndarray (nt,)
        The measured signals by name (coordinates, ``d_<coordinate>``, outputs).
    weight : ndarray (nt,)
    file : str
    """

    t: np.ndarray
    columns: dict[str, np.ndarray]
    weight: np.ndarray
    file: str = "<data>"


@dataclass(frozen=True)
class _Table:
    """A CSV file's header and rows, each row with its line number in the file."""

    header: list[str]
    rows: list[list[str]]
    lines: list[int]
    file: str

    def first(self, bad: np.ndarray) -> int:
        """The line of the first row where ``bad`` holds."""
        return self.lines[int(np.flatnonzero(bad)[0])]


def _table(path: str | os.PathLike[str]) -> _Table:
    """Header and rows of a CSV file (one clear error for anything else)."""
    name = os.fspath(path)
    raw = read_checked(path, "data file", MAX_DATA_BYTES, DataError)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise DataError(f"not UTF-8 text ({exc.reason})", file=name) from None
    numbered = [(k + 1, r) for k, r in enumerate(csv.reader(text.splitlines()))
                if r and any(c.strip() for c in r)]
    if len(numbered) < 2:
        raise DataError("expected a CSV file with a header and at least one row of numbers",
                        file=name)
    header = [h.strip() for h in numbered[0][1]]
    if len(set(header)) < len(header):
        raise DataError(f"repeated column names in the header: {', '.join(header)}", file=name)
    for line, row in numbered[1:]:
        if len(row) > len(header):
            raise DataError(f"{len(row)} fields where the header has {len(header)} (a "
                            "decimal comma, or a value without a column?)", file=name,
                            line=line)
    return _Table(header, [r for _, r in numbered[1:]], [k for k, _ in numbered[1:]], name)


def _column(table: _Table, key: str) -> np.ndarray:
    """The finite numbers of column ``key`` (errors name the line)."""
    if key not in table.header:
        raise DataError(f"no column {key!r}; columns are: {', '.join(table.header)}",
                        file=table.file)
    j = table.header.index(key)
    out = np.empty(len(table.rows))
    for i, row in enumerate(table.rows):
        cell = row[j].strip() if j < len(row) else ""
        try:
            value = float(cell)
        except ValueError:
            value = np.nan
        if not np.isfinite(value):
            what = "missing" if not cell else f"{cell!r} is not a finite number"
            raise DataError(f"column {key!r}: {what}", file=table.file, line=table.lines[i])
        out[i] = value
    return out


def _increasing(values: np.ndarray, key: str, table: _Table) -> None:
    bad = np.flatnonzero(np.diff(values) <= 0)
    if bad.size:
        i = int(bad[0])
        raise DataError(f"column {key!r} must increase: {values[i + 1]:g} follows "
                        f"{values[i]:g}", file=table.file, line=table.lines[i + 1])


def _weights(table: _Table) -> np.ndarray:
    if "weight" not in table.header:
        return np.ones(len(table.rows))
    w = _column(table, "weight")
    if np.any(w < 0):
        raise DataError("column 'weight' must hold numbers ≥ 0", file=table.file,
                        line=table.first(w < 0))
    if not np.any(w > 0):
        raise DataError("column 'weight' is 0 in every row", file=table.file)
    return w


def read_frequency_data(path: str | os.PathLike[str], response: str | None = None,
                        input: str | None = None) -> FrequencyData:
    """A frequency response written by ``neweul frf -o FILE.csv``.

    One pair: columns ``frequency_hz``, ``magnitude``, ``phase_deg`` (``response`` and
    ``input`` name the model's output and input). Several pairs: ``magnitude__Y__U``,
    ``phase_deg__Y__U``, chosen by ``response`` and ``input``.

    Raises
    ------
    DataError
        As the module docstring says.
    """
    table = _table(path)
    header, file = table.header, table.file
    if "frequency_hz" not in header:
        other = " (it looks like a simulation: use --task simulate)" if "t" in header else ""
        raise DataError(f"not a frequency response: no column 'frequency_hz'{other}",
                        file=file)
    pairs = sorted({h.split("__", 1)[1] for h in header if h.startswith("magnitude__")})
    if pairs:
        if response is None or input is None:
            raise DataError("the file holds several output/input pairs "
                            f"({', '.join(p.replace('__', '/') for p in pairs)}): name the "
                            "response and the input", file=file)
        sfx = f"__{response}__{input}"
    else:
        sfx = ""
    f = _column(table, "frequency_hz")
    mag = _column(table, f"magnitude{sfx}")
    phase = _column(table, f"phase_deg{sfx}")
    if np.any(f < 0):
        raise DataError("column 'frequency_hz' must be ≥ 0", file=file, line=table.first(f < 0))
    _increasing(f, "frequency_hz", table)
    if np.any(mag <= 0):
        raise DataError(f"column 'magnitude{sfx}': a magnitude must be positive (its "
                        "logarithm is fitted)", file=file, line=table.first(mag <= 0))
    return FrequencyData(f, mag * np.exp(1j * np.radians(phase)), _weights(table),
                         response or "", input or "", file)


def read_time_data(path: str | os.PathLike[str],
                   columns: Sequence[str] | None = None) -> TimeData:
    """A time history written by ``neweul simulate -o FILE.csv`` (column ``t`` and the
    signals); ``columns`` selects signals (default: all but ``t`` and ``weight``).

    Raises
    ------
    DataError
        As the module docstring says.
    """
    table = _table(path)
    header, file = table.header, table.file
    if "t" not in header:
        other = (" (it looks like a frequency response: use --task frf)"
                 if "frequency_hz" in header else "")
        raise DataError(f"not a simulation: no column 't'{other}", file=file)
    t = _column(table, "t")
    if np.any(t < 0):
        raise DataError("column 't' must be ≥ 0 (simulations start at t = 0)", file=file,
                        line=table.first(t < 0))
    _increasing(t, "t", table)
    names = list(columns) if columns else [h for h in header if h not in ("t", "weight")]
    if not names:
        raise DataError("no signal columns besides 't'", file=file)
    return TimeData(t, {n: _column(table, n) for n in names}, _weights(table), file)

