"""Simulation results and their files (CSV with a units line, NumPy ``.npz``), written
atomically."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..atomic import atomic_savez, atomic_write
from ..errors import DataError, NeweulError

__all__ = ["SUFFIXES", "SimulationResult", "check_output_path", "load_npz"]

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


@dataclass(frozen=True)
class SimulationResult:
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

    # ------------------------------------------------------------------ files
    def to_csv(self, path: str | os.PathLike[str]) -> Path:
        """Write a CSV file: a comment line of units, the header, one row per time.

        Format::

            # units: s, rad, rad/s, m
            t,phi,d_phi,height
            0,0.3,0,-0.477...

        Numbers are printed with 17 significant digits (round-trip exact).
        """
        lines = ["# units: " + ", ".join(self.units), ",".join(self.names)]
        table = self.table
        lines += [",".join(f"{v:.17g}" for v in row) for row in table]
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
    return tuple(str(s) for s in np.atleast_1d(arr)) if arr.size else ()


def load_npz(path: str | os.PathLike[str]) -> SimulationResult:
    """Read a result written by :meth:`SimulationResult.to_npz` (no pickles allowed)."""
    try:
        with np.load(path, allow_pickle=False) as data:
            d = {k: data[k] for k in data.files}
    except (OSError, ValueError) as exc:
        raise DataError(f"cannot read results: {exc}", file=str(path)) from None
    try:
        names: Sequence[str] = _strings(d["parameter_names"])
        return SimulationResult(
            t=d["t"],
            y=d["y"],
            yd=d["yd"],
            outputs=d["outputs"],
            coordinates=_strings(d["coordinates"]),
            output_names=_strings(d["output_names"]),
            coordinate_units=_strings(d["coordinate_units"]),
            output_units=_strings(d["output_units"]),
            model_name=str(d["model_name"]),
            parameters=dict(zip(names, map(float, d["parameter_values"]), strict=True)),
            source_hash=str(d["source_hash"]),
            method=str(d["method"]),
        )
    except KeyError as exc:
        raise DataError(f"missing array {exc.args[0]!r}", file=str(path)) from None
