"""Reading results to compare: our CSV/NPZ files and result objects, and plain CSV files written
by other tools (Neweul-M², Exudyn, measured data), into one :class:`Table`.

Recognized files:

- ``.npz`` written by neweul-py: simulation results, frequency responses, modes, equilibria;
- CSV with a header row of names (``#`` comment lines are skipped; units in a ``[unit]`` or
  ``(unit)`` suffix of a name are dropped for matching, ``time [s]`` → ``time``):

  - ``name,value`` rows: an equilibrium;
  - ``frequency_hz`` and ``damping_ratio`` columns: modes (``shape_<coordinate>`` columns are
    the mode shapes);
  - a first column named like a frequency (``frequency_hz``, ``frequency``, ``freq``, ``f``,
    ``f_hz``): a frequency response; ``magnitude<sfx>``/``phase_deg<sfx>`` or
    ``real<sfx>``/``imag<sfx>`` (``re``/``im``) column pairs are complex signals named by the
    suffix (``H`` without one), other columns real ones;
  - anything else: a time history, the first column is the time.
"""

from __future__ import annotations

import csv
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DataError, NeweulError
from ..files import load_npz, read_text

__all__ = ["KINDS", "Table", "as_table", "read_table"]

#: Kinds of comparable results.
KINDS: tuple[str, ...] = ("time", "frequency", "equilibrium", "modes")

_FREQUENCY_NAMES = {"frequency_hz", "frequency", "freq", "f", "f_hz", "freq_hz", "frequencies"}
_UNIT_SUFFIX = re.compile(r"\s*[\[(][^\])]*[\])]\s*$")
_PAIRS = (("magnitude", "phase_deg"), ("mag", "phase_deg"), ("real", "imag"), ("re", "im"))


@dataclass(frozen=True)
class Table:
    """Named signals over a common abscissa (or none, for an equilibrium).

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`.
    x : ndarray (n,)
        Times [s] or frequencies [Hz] (strictly increasing); mode numbers for modes; empty
        for an equilibrium.
    signals : dict of str → ndarray
        Values per signal (complex for frequency responses given as magnitude/phase or real/
        imaginary parts; one value each for an equilibrium; natural frequencies ``f_hz`` for
        modes).
    shapes : ndarray (ncoord, nmodes) or None
        Mode shapes (modes only), rows named by ``coordinates``.
    coordinates : tuple of str
    source : str
        File name or object description (for messages).
    x_name : str
        The abscissa's column name.
    units : dict of str → str
        Unit of each signal where known (a ``[unit]`` suffix of a CSV header, the units
        sidecar of our CSV files, the units of a result object).
    """

    kind: str
    x: np.ndarray
    signals: dict[str, np.ndarray]
    shapes: np.ndarray | None = None
    coordinates: tuple[str, ...] = ()
    source: str = ""
    x_name: str = field(default="")
    units: dict[str, str] = field(default_factory=dict)


def _clean(name: str) -> str:
    return _UNIT_SUFFIX.sub("", name.strip())


def _suffix_unit(name: str) -> str:
    """The unit of a ``name [unit]`` or ``name (unit)`` header, ``""`` without one."""
    m = _UNIT_SUFFIX.search(name.strip())
    return m.group(0).strip()[1:-1].strip() if m else ""


def _csv_units(path: Path, raw_header: list[str]) -> dict[str, str]:
    """Units of the columns: the ``[unit]`` suffixes, else our units sidecar."""
    from .results import read_units

    try:
        side = read_units(path)
    except DataError:
        side = {}
    units = {k: v for k, v in side.items() if v and v != "-"}
    units.update({_clean(h): _suffix_unit(h) for h in raw_header if _suffix_unit(h)})
    return units


def _numbers(rows: list[list[str]], names: list[str], path: str, first_line: int,
             skip: frozenset[str] = frozenset()) -> dict[str, np.ndarray]:
    """Columns as floats; NaN, inf or text → one error naming the row and column."""
    out: dict[str, np.ndarray] = {}
    for j, name in enumerate(names):
        if name in skip:
            continue
        col = np.empty(len(rows))
        for i, row in enumerate(rows):
            cell = row[j].strip() if j < len(row) else ""
            try:
                col[i] = float(cell)
            except ValueError:
                col[i] = np.nan
            if not np.isfinite(col[i]):
                raise DataError(f"column {name!r}, line {first_line + i}: "
                                f"{cell or '(empty)'!r} is not a finite number", file=path)
        out[name] = col
    return out


def _check_abscissa(x: np.ndarray, name: str, path: str, first_line: int) -> None:
    bad = np.flatnonzero(np.diff(x) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise DataError(f"the first column {name!r} must increase strictly: {x[i]:g} at line "
                        f"{first_line + i} follows {x[i - 1]:g}", file=path)


def _frequency_signals(cols: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    signals: dict[str, np.ndarray] = {}
    used: set[str] = set()
    for a, b in _PAIRS:
        for name in cols:
            if not name.startswith(a) or name in used:
                continue
            sfx = name[len(a):]
            partner = b + sfx
            if partner not in cols:
                continue
            key = sfx.lstrip("_:") or "H"
            key = key.replace("/", "__")
            if a in ("magnitude", "mag"):
                signals[key] = cols[name] * np.exp(1j * np.radians(cols[partner]))
            else:
                signals[key] = cols[name] + 1j * cols[partner]
            used |= {name, partner}
    signals.update({n: v for n, v in cols.items() if n not in used})
    return signals


def _read_csv(path: Path) -> Table:
    src = str(path)
    text = read_text(path, "table")
    lines = [(k + 1, r) for k, r in enumerate(csv.reader(text.splitlines()))
             if r and not r[0].lstrip().startswith("#") and any(c.strip() for c in r)]
    if len(lines) < 2:
        raise DataError("expected a header row of names and at least one row of numbers",
                        file=src)
    header = [_clean(h) for h in lines[0][1]]
    if len(set(header)) != len(header):
        raise DataError(f"repeated column names in the header: {lines[0][1]}", file=src)
    rows = [r for _, r in lines[1:]]
    first = lines[1][0]
    if header == ["name", "value"]:
        values = _numbers(rows, header, src, first, frozenset({"name"}))["value"]
        return Table("equilibrium", np.zeros(0),
                     {r[0].strip(): np.array([v]) for r, v in zip(rows, values, strict=True)},
                     source=src)
    if "frequency_hz" in header and "damping_ratio" in header:
        text_cols = frozenset(h for h in header if h in ("dominant_coordinate", "kind"))
        cols = _numbers(rows, header, src, first, text_cols)
        shape_cols = [h for h in header if h.startswith("shape_")]
        shapes = np.array([cols[h] for h in shape_cols]) if shape_cols else None
        return Table("modes", np.arange(1, len(rows) + 1, dtype=float),
                     {"f_hz": cols["frequency_hz"]}, shapes=shapes,
                     coordinates=tuple(h[len("shape_"):] for h in shape_cols), source=src)
    cols = _numbers(rows, header, src, first)
    x_name = header[0]
    x = cols.pop(x_name)
    _check_abscissa(x, x_name, src, first)
    if not cols:
        raise DataError(f"no signal columns besides {x_name!r}", file=src)
    units = _csv_units(path, lines[0][1])
    if x_name.lower() in _FREQUENCY_NAMES:
        return Table("frequency", x, _frequency_signals(cols), source=src, x_name=x_name)
    return Table("time", x, cols, source=src, x_name=x_name,
                 units={k: v for k, v in units.items() if k in cols})


def _read_npz(path: Path) -> Table:
    arrays = load_npz(path, "result file")
    keys = set(arrays)
    if {"t", "y", "names"} <= keys:
        from .results import load_npz as load_results

        return as_table(load_results(path), str(path))
    if {"H", "frequency_hz"} <= keys:
        from .frf import FrequencyResponse

        return as_table(FrequencyResponse.load(path), str(path))
    if "eigenvalues" in keys:
        from .modes import ModalResult

        return as_table(ModalResult.load(path), str(path))
    if {"y", "lambda_", "coordinates", "constraints"} <= keys:
        f = arrays
        try:
            names = [*map(str, f["coordinates"]), *(f"lambda_{c}" for c in f["constraints"])]
            values = np.concatenate([f["y"], f["lambda_"]])
        except (ValueError, TypeError) as exc:
            raise DataError(f"cannot read an equilibrium: {exc}", file=str(path)) from None
        return Table("equilibrium", np.zeros(0),
                     {n: np.array([v]) for n, v in zip(names, values, strict=True)},
                     source=str(path))
    raise DataError("not a neweul-py result (.npz of a simulation, frequency response, modes "
                    "or equilibrium)", file=str(path))


def read_table(path: str | os.PathLike[str]) -> Table:
    """Read a result file (``.csv`` or ``.npz``) into a :class:`Table` (see module docstring).

    Raises
    ------
    DataError
        A missing or unreadable file, a value that is not a finite number (row and column),
        a first column that does not increase strictly, an unknown ``.npz``.
    """
    path = Path(path)
    return _read_npz(path) if path.suffix.lower() == ".npz" else _read_csv(path)


def as_table(obj: Any, source: str = "") -> Table:
    """A :class:`Table` of a file path, a result object (``SimulationResult``,
    ``FrequencyResponse``, ``EquilibriumResult``, ``ModalResult``), a ``Table``, or a mapping
    ``{"t": times, "phi": values, ...}`` whose first entry is the abscissa (time; a first key
    named like a frequency makes it a frequency response)."""
    if isinstance(obj, Table):
        return obj
    if isinstance(obj, str | os.PathLike):
        return read_table(obj)
    from .equilibrium import EquilibriumResult
    from .frf import FrequencyResponse
    from .modes import ModalResult
    from .results import SimulationResult

    src = source or type(obj).__name__
    if isinstance(obj, SimulationResult):
        names = obj.names
        return Table("time", np.asarray(obj.t, dtype=float),
                     {n: obj.table[:, k] for k, n in enumerate(names) if k},
                     source=src, x_name="t", units=obj.column_units())
    if isinstance(obj, FrequencyResponse):
        single = len(obj.outputs) == 1 and len(obj.inputs) == 1
        sig = {("H" if single else f"{o}__{u}"): obj.H[:, i, j]
               for i, o in enumerate(obj.outputs) for j, u in enumerate(obj.inputs)}
        return Table("frequency", np.asarray(obj.frequency_hz, dtype=float), sig, source=src,
                     x_name="frequency_hz")
    if isinstance(obj, EquilibriumResult):
        return Table("equilibrium", np.zeros(0),
                     {k: np.array([v]) for k, v in obj.as_dict().items()}, source=src)
    if isinstance(obj, ModalResult):
        osc = obj.oscillating
        return Table("modes", np.arange(1, int(osc.sum()) + 1, dtype=float),
                     {"f_hz": np.asarray(obj.frequency_hz)[osc]}, shapes=obj.shapes[:, osc],
                     coordinates=tuple(obj.coordinates), source=src)
    if isinstance(obj, Mapping) and obj:
        keys = list(obj)
        x = np.asarray(obj[keys[0]], dtype=float).reshape(-1)
        sig = {k: np.asarray(obj[k]).reshape(-1) for k in keys[1:]}
        kind = "frequency" if keys[0].lower() in _FREQUENCY_NAMES else "time"
        for k, v in sig.items():
            if v.shape != x.shape or not np.all(np.isfinite(v)):
                raise DataError(f"signal {k!r} must be {x.size} finite values", file=src)
        if np.any(np.diff(x) <= 0):
            raise DataError(f"{keys[0]!r} must increase strictly", file=src)
        return Table(kind, x, sig, source=src or "mapping", x_name=keys[0])
    raise NeweulError(f"cannot compare a {type(obj).__name__}: give a .csv/.npz path, a result "
                      "object or a mapping of arrays")
