"""Simulation results and their files (CSV with a units sidecar, NumPy ``.npz``), written
atomically; the notebook display and ``to_dataframe`` shared by every analysis result.

CSV files open anywhere: the first line names the columns (plain names, no units, no comment
line), so ``pandas.read_csv(path)``, ``numpy.genfromtxt(path, names=True, delimiter=",")`` and
``numpy.loadtxt(path, delimiter=",", skiprows=1)`` read them without options. The units go to a
sidecar ``<stem>.units.json`` (``{"t": "s", "phi": "rad", ...}``): units in the header itself
would be mangled differently by each reader (``genfromtxt`` turns ``phi [rad]`` into
``phi_rad``).
"""

from __future__ import annotations

import html
import json
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic import atomic_savez, atomic_write
from ..errors import DataError, NeweulError
from ..files import load_npz as read_npz

__all__ = [
    "SUFFIXES",
    "ResultDisplay",
    "SimulationResult",
    "check_output_path",
    "load_npz",
    "read_units",
    "require_pandas",
    "units_path",
]

#: Rows shown by the notebook display (first and last half).
_PREVIEW_ROWS = 10
#: Columns shown by the notebook display.
_PREVIEW_COLUMNS = 8


def require_pandas() -> Any:
    """The :mod:`pandas` module, or a clear error naming the extra that installs it."""
    try:
        import pandas
    except ImportError:
        raise NeweulError(
            "to_dataframe needs pandas: pip install pandas (or 'neweul-py[dataframe]')"
        ) from None
    return pandas


def units_path(path: str | os.PathLike[str]) -> Path:
    """The units sidecar of a CSV file: ``out/run.csv`` → ``out/run.units.json``."""
    path = Path(path)
    return path.with_name(path.stem + ".units.json")


def read_units(path: str | os.PathLike[str]) -> dict[str, str]:
    """Column → unit from the sidecar of the CSV file ``path`` (``{}`` when there is none)."""
    side = units_path(path)
    if not side.is_file():
        return {}
    try:
        data = json.loads(side.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise DataError(f"cannot read the units sidecar: {exc}", file=str(side)) from None
    if not isinstance(data, dict) or not all(isinstance(v, str) for v in data.values()):
        raise DataError("the units sidecar must map column names to unit strings",
                        file=str(side))
    return {str(k): v for k, v in data.items()}


def _cell(value: Any) -> str:
    if isinstance(value, float | np.floating):
        return f"{float(value):.6g}"
    if isinstance(value, complex | np.complexfloating):
        return f"{complex(value):.4g}"
    return str(value)


class ResultDisplay:
    """Mixin of the analysis results: a short ``repr``, rich notebook display and
    :meth:`to_dataframe`, all built from :meth:`columns` (named 1-D columns of equal length)
    and :meth:`summary` (one line). Subclasses are dataclasses declared with ``repr=False``."""

    def columns(self) -> dict[str, np.ndarray]:
        """Named columns of the result's table (what the CSV file holds)."""
        raise NotImplementedError

    def summary(self) -> str:
        """One line describing the result (its ``repr``)."""
        raise NotImplementedError

    def column_units(self) -> dict[str, str]:
        """Unit of each column where known (shown in the notebook tables' headers)."""
        return {}

    def to_dataframe(self) -> Any:
        """The table as a :class:`pandas.DataFrame` (pandas is optional: a clear error when it
        is missing)."""
        pd = require_pandas()
        return pd.DataFrame({k: np.asarray(v) for k, v in self.columns().items()})

    def __repr__(self) -> str:
        return self.summary()

    def _preview(self) -> tuple[list[str], list[list[str]], bool, bool]:
        cols = self.columns()
        names = list(cols)
        more_cols = len(names) > _PREVIEW_COLUMNS
        names = names[:_PREVIEW_COLUMNS]
        nrows = len(next(iter(cols.values()))) if cols else 0
        half = _PREVIEW_ROWS // 2
        idx = list(range(nrows)) if nrows <= _PREVIEW_ROWS else [
            *range(half), *range(nrows - half, nrows)]
        rows = [[_cell(np.asarray(cols[n])[i]) for n in names] for i in idx]
        units = self.column_units()
        names = [f"{n} [{units[n]}]" if units.get(n) else n for n in names]
        return names, rows, nrows > _PREVIEW_ROWS, more_cols

    def _repr_markdown_(self) -> str:
        names, rows, cut_rows, cut_cols = self._preview()
        lines = [f"**{self.summary()}**", ""]
        if names:
            lines += ["| " + " | ".join(names) + (" | …" if cut_cols else "") + " |",
                      "|" + "---|" * (len(names) + cut_cols)]
            half = _PREVIEW_ROWS // 2
            for k, row in enumerate(rows):
                if cut_rows and k == half:
                    lines.append("| " + " | ".join("⋮" for _ in names) + (" |" if not cut_cols
                                                                          else " | |"))
                lines.append("| " + " | ".join(row) + (" | …" if cut_cols else "") + " |")
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        names, rows, cut_rows, cut_cols = self._preview()
        esc = html.escape
        head = "".join(f"<th>{esc(n)}</th>" for n in names) + ("<th>…</th>" if cut_cols else "")
        body = []
        half = _PREVIEW_ROWS // 2
        for k, row in enumerate(rows):
            if cut_rows and k == half:
                body.append("<tr>" + "<td>⋮</td>" * (len(names) + cut_cols) + "</tr>")
            body.append("<tr>" + "".join(f"<td>{esc(c)}</td>" for c in row)
                        + ("<td>…</td>" if cut_cols else "") + "</tr>")
        table = (f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"
                 if names else "")
        return f"<div><p><b>{esc(self.summary())}</b></p>{table}</div>"

#: Suffixes of simulation-result files (:meth:`SimulationResult.save`).
SUFFIXES: tuple[str, ...] = (".csv", ".npz")


def check_output_path(
    path: str | os.PathLike[str], suffixes: Sequence[str], what: str = "results"
) -> Path:
    """``path`` if its suffix is one of ``suffixes`` (e.g. ``(".csv", ".npz")``), else an error.

    Raises
    ------
    NeweulError
        Naming the file and the accepted suffixes, e.g.
        ``"x.txt: results are written as .csv or .npz, not .txt"``.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in suffixes:
        accepted = " or ".join(suffixes)
        raise NeweulError(f"{path}: {what} are written as {accepted}, not {suffix or '(none)'}")
    return path


@dataclass(frozen=True, repr=False)
class SimulationResult(ResultDisplay):
    """A time history of a generated model.

    Attributes
    ----------
    t : ndarray (nt,)
        Times [s].
    y, yd : ndarray (nt, n)
        Coordinates and their velocities.
    outputs : ndarray (nt, ny)
        The model's outputs.
    coordinates, output_names : tuple of str
        Column names.
    coordinate_units, output_units : tuple of str
        SI units where known (``""`` unknown); velocity units are derived (``rad`` → ``rad/s``).
    model_name : str
        ``MODEL_NAME`` of the module.
    parameters : dict
        The parameter values used, by name.
    source_hash : str
        ``SOURCE_HASH`` of the module.
    method, message : str
        Integrator and its final message.
    nfev : int
        Number of right-hand-side evaluations.
    """

    t: np.ndarray
    y: np.ndarray
    yd: np.ndarray
    outputs: np.ndarray
    coordinates: tuple[str, ...]
    output_names: tuple[str, ...]
    coordinate_units: tuple[str, ...] = ()
    output_units: tuple[str, ...] = ()
    model_name: str = ""
    parameters: dict[str, float] = field(default_factory=dict)
    source_hash: str = ""
    method: str = ""
    message: str = ""
    nfev: int = 0

    # ------------------------------------------------------------------ columns
    @property
    def names(self) -> list[str]:
        """Column names: ``t``, coordinates, ``d_<coordinate>``, outputs."""
        return [
            "t",
            *self.coordinates,
            *(f"d_{c}" for c in self.coordinates),
            *self.output_names,
        ]

    @property
    def units(self) -> list[str]:
        """Unit of each column of :attr:`names` (``-`` where unknown)."""
        cu = list(self.coordinate_units) or [""] * len(self.coordinates)
        ou = list(self.output_units) or [""] * len(self.output_names)
        vel = [f"{u}/s" if u else "" for u in cu]
        return [u or "-" for u in ["s", *cu, *vel, *ou]]

    @property
    def table(self) -> np.ndarray:
        """All columns as one (nt, 1 + 2n + ny) array."""
        return np.column_stack([self.t, self.y, self.yd, self.outputs])

    def column(self, name: str) -> np.ndarray:
        """One column by name (``t``, a coordinate, ``d_<coordinate>`` or an output)."""
        names = self.names
        if name not in names:
            raise NeweulError(f"no column {name!r}; columns are: {', '.join(names)}")
        return self.table[:, names.index(name)]

    def columns(self) -> dict[str, np.ndarray]:
        """Column name → values (the CSV columns)."""
        return dict(zip(self.names, self.table.T, strict=True))

    def column_units(self) -> dict[str, str]:
        """Column name → unit (those known, :attr:`units`)."""
        return {n: u for n, u in zip(self.names, self.units, strict=True) if u != "-"}

    def summary(self) -> str:
        """One line: model, times, sizes, integrator."""
        span = f"t = {self.t[0]:g} … {self.t[-1]:g} s" if self.t.size else "no times"
        how = f"; {self.method}, {self.nfev} rhs evaluations" if self.method else ""
        return (f"SimulationResult({self.model_name or 'model'}: {self.t.size} times, {span}, "
                f"{len(self.coordinates)} coordinates, {len(self.output_names)} outputs{how})")

    # ------------------------------------------------------------------ files
    def to_csv(self, path: str | os.PathLike[str]) -> Path:
        """Write a CSV file (header of names, one row per time) and its units sidecar.

        Format::

            t,phi,d_phi,height
            0,0.3,0,-0.477...

        and ``<stem>.units.json``: ``{"t": "s", "phi": "rad", "d_phi": "rad/s", ...}``
        (:func:`units_path`; ``-`` where unknown). Numbers are printed with 17 significant
        digits (round-trip exact). Both files are written atomically, the sidecar first.
        """
        lines = [",".join(self.names)]
        table = self.table
        lines += [",".join(f"{v:.17g}" for v in row) for row in table]
        units = dict(zip(self.names, self.units, strict=True))
        atomic_write(units_path(path), json.dumps(units, indent=1, ensure_ascii=False) + "\n")
        return atomic_write(path, ("\n".join(lines) + "\n").encode("utf-8"))

    def to_npz(self, path: str | os.PathLike[str]) -> Path:
        """Write an uncompressed ``.npz`` (no pickles): arrays ``t``, ``y``, ``yd``,
        ``outputs``, and string arrays ``coordinates``, ``output_names``, ``names``, ``units``,
        plus ``parameter_names``/``parameter_values``, ``model_name``, ``source_hash``."""
        return atomic_savez(
            path,
            t=self.t,
            y=self.y,
            yd=self.yd,
            outputs=self.outputs,
            coordinates=np.array(self.coordinates, dtype=str),
            output_names=np.array(self.output_names, dtype=str),
            coordinate_units=np.array(self.coordinate_units, dtype=str),
            output_units=np.array(self.output_units, dtype=str),
            names=np.array(self.names, dtype=str),
            units=np.array(self.units, dtype=str),
            parameter_names=np.array(list(self.parameters), dtype=str),
            parameter_values=np.array(list(self.parameters.values()), dtype=float),
            model_name=np.array(self.model_name),
            source_hash=np.array(self.source_hash),
            method=np.array(self.method),
        )

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write CSV or NPZ according to the suffix of ``path``."""
        path = check_output_path(path, SUFFIXES, "results")
        return self.to_npz(path) if path.suffix.lower() == ".npz" else self.to_csv(path)


def _strings(arr: np.ndarray) -> tuple[str, ...]:
    """Names from a string array of an ``.npz`` file."""
    return tuple(str(s) for s in np.atleast_1d(arr)) if arr.size else ()


def load_npz(path: str | os.PathLike[str]) -> SimulationResult:
    """Read a result written by :meth:`SimulationResult.to_npz` (no pickles allowed).

    Raises
    ------
    DataError
        The file is not a valid ``.npz`` (:func:`neweul_py.files.load_npz`), lacks an array,
        or its arrays do not fit together (times, states and outputs of one run; one name per
        column, one value per parameter).
    """
    d = read_npz(path, "results file")
    try:
        names: Sequence[str] = _strings(d["parameter_names"])
        t = np.asarray(d["t"], dtype=float)
        y, yd = np.asarray(d["y"], dtype=float), np.asarray(d["yd"], dtype=float)
        outputs = np.asarray(d["outputs"], dtype=float)
        coordinates, output_names = _strings(d["coordinates"]), _strings(d["output_names"])
        nt = t.size
        if (t.ndim != 1 or y.shape != (nt, len(coordinates)) or yd.shape != y.shape
                or outputs.shape != (nt, len(output_names))):
            raise ValueError(f"t {t.shape}, y {y.shape}, yd {yd.shape}, outputs "
                             f"{outputs.shape} do not fit {len(coordinates)} coordinates and "
                             f"{len(output_names)} outputs")
        return SimulationResult(
            t=t, y=y, yd=yd, outputs=outputs, coordinates=coordinates,
            output_names=output_names,
            coordinate_units=_strings(d["coordinate_units"]),
            output_units=_strings(d["output_units"]),
            model_name=str(d["model_name"]),
            parameters=dict(zip(names, map(float, d["parameter_values"]), strict=True)),
            source_hash=str(d["source_hash"]),
            method=str(d["method"]),
        )
    except KeyError as exc:
        raise DataError(f"missing array {exc.args[0]!r}", file=str(path)) from None
    except (ValueError, TypeError) as exc:
        raise DataError(f"not a simulation result: {exc}", file=str(path)) from None
