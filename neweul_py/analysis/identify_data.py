"""Measured data for parameter identification (docs/howto/identify.md): a frequency response
as ``neweul frf -o`` writes it, or a time history as ``neweul simulate -o`` writes it.

Every problem is one :class:`~neweul_py.errors.DataError` naming the file and the column (and
the row where one is at fault): a file that is not such a CSV, data of the other task, a
missing column, a value that is not a finite number, frequencies or times that do not
increase, negative weights. An optional column ``weight`` (≥ 0) weights each row's residuals.
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
        Increasing, positive.
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


def _table(path: str | os.PathLike[str]) -> tuple[list[str], list[list[str]], str]:
    """Header and rows of a CSV file (one clear error for anything else)."""
    name = os.fspath(path)
    raw = read_checked(path, "data file", MAX_DATA_BYTES, DataError)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise DataError(f"not UTF-8 text ({exc.reason})", file=name) from None
    rows = [r for r in csv.reader(text.splitlines()) if r and any(c.strip() for c in r)]
    if len(rows) < 2:
        raise DataError("expected a CSV file with a header and at least one row of numbers",
                        file=name)
    header = [h.strip() for h in rows[0]]
    if len(set(header)) < len(header):
        raise DataError(f"repeated column names in the header: {', '.join(header)}", file=name)
    return header, rows[1:], name


def _column(header: list[str], rows: list[list[str]], key: str, file: str) -> np.ndarray:
    """The finite numbers of column ``key`` (errors name the row, counting the header as 1)."""
    if key not in header:
        raise DataError(f"no column {key!r}; columns are: {', '.join(header)}", file=file)
    j = header.index(key)
    out = np.empty(len(rows))
    for i, row in enumerate(rows):
        cell = row[j].strip() if j < len(row) else ""
        try:
            value = float(cell)
        except ValueError:
            value = np.nan
        if not np.isfinite(value):
            what = "missing" if not cell else f"{cell!r} is not a finite number"
            raise DataError(f"column {key!r}: {what}", file=file, line=i + 2)
        out[i] = value
    return out


def _increasing(values: np.ndarray, key: str, file: str) -> None:
    bad = np.flatnonzero(np.diff(values) <= 0)
    if bad.size:
        i = int(bad[0])
        raise DataError(f"column {key!r} must increase: {values[i + 1]:g} follows "
                        f"{values[i]:g}", file=file, line=i + 3)


def _weights(header: list[str], rows: list[list[str]], file: str) -> np.ndarray:
    if "weight" not in header:
        return np.ones(len(rows))
    w = _column(header, rows, "weight", file)
    if np.any(w < 0) or not np.any(w > 0):
        raise DataError("column 'weight' must hold numbers ≥ 0, not all 0", file=file)
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
    header, rows, file = _table(path)
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
    f = _column(header, rows, "frequency_hz", file)
    mag = _column(header, rows, f"magnitude{sfx}", file)
    phase = _column(header, rows, f"phase_deg{sfx}", file)
    if np.any(f <= 0):
        raise DataError("column 'frequency_hz' must be positive", file=file)
    _increasing(f, "frequency_hz", file)
    if np.any(mag <= 0):
        i = int(np.flatnonzero(mag <= 0)[0])
        raise DataError(f"column 'magnitude{sfx}': a magnitude must be positive (its "
                        "logarithm is fitted)", file=file, line=i + 2)
    return FrequencyData(f, mag * np.exp(1j * np.radians(phase)), _weights(header, rows, file),
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
    header, rows, file = _table(path)
    if "t" not in header:
        other = (" (it looks like a frequency response: use --task frf)"
                 if "frequency_hz" in header else "")
        raise DataError(f"not a simulation: no column 't'{other}", file=file)
    t = _column(header, rows, "t", file)
    if np.any(t < 0):
        raise DataError("column 't' must be ≥ 0 (simulations start at t = 0)", file=file)
    _increasing(t, "t", file)
    names = list(columns) if columns else [h for h in header if h not in ("t", "weight")]
    if not names:
        raise DataError("no signal columns besides 't'", file=file)
    return TimeData(t, {n: _column(header, rows, n, file) for n in names},
                    _weights(header, rows, file), file)

