"""Reading the elastic data of a description's ``elastic_bodies`` (``docs/equations.md`` §2).

The symbolic layers (``description``, ``equations``) read elastic bodies only through this
function: it returns the flat ``name → array`` form of
:class:`~neweul_py.elastic.bodies.invariants.Invariants`
(:meth:`~neweul_py.elastic.bodies.invariants.Invariants.to_flat`, NumPy arrays only), whatever the
source file was.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from ...errors import DataError
from ...files import check_regular_file
from ..bodies.invariants import FLAT_FORMAT, Invariants, body_invariants
from .body_files import PARAMETRIC_BODY_FORMAT, load_parametric_body, load_reduced_body
from .npz import json_from_uint8, load_npz
from .sid import invariants_from_sid, read_sid

__all__ = ["IO_KEYS", "PARAMETRIC_KEYS", "read_elastic_data"]

#: Keys of the body's own FE inputs and outputs (reduced-body and parametric files):
#: ``io.B`` (nq, ni) the modal loads ``Wᵀ B`` per unit input, ``io.C`` (no, nq) the output rows
#: ``C V``, ``io.inputs``, ``io.outputs`` their names (in the coordinates of the invariants,
#: after a mode selection). Descriptions use them through ``elastic_bodies.NAME.inputs`` and
#: ``.outputs`` (docs/description-format.md).
IO_KEYS = ("io.B", "io.C", "io.inputs", "io.outputs")

#: Keys of the result for a parametric body: ``parametric.values`` (k,) sample values,
#: ``parametric.interpolation``, ``parametric.parameter``, and per sample ``i`` its flat
#: invariants under ``sample{i}/<key>``; with an interpolation coordinate also
#: ``parametric.coordinate`` (2, n) and ``parametric.coordinate_name``; with sample slopes
#: (Hermite weights, equations.md §4.2) the slope of every float array of sample ``i``
#: under ``slope{i}/<key>`` (its other entries those of the sample), and with sample
#: curvatures (quintic Hermite weights) their curvatures under ``curvature{i}/<key>``.
PARAMETRIC_KEYS = ("parametric.values", "parametric.interpolation", "parametric.parameter")


def read_elastic_data(
    path: str | os.PathLike[str], modes: int | Sequence[int] | None = None
) -> dict[str, np.ndarray]:
    """The floating-frame invariants of an elastic body file, as flat arrays.

    Parameters
    ----------
    path
        A reduced-body file (``.npz`` with the invariants slot filled, two-sided or
        one-sided), a bare invariants ``.npz`` (``np.savez(path, **inv.to_flat())``, the
        content of that slot) or a SID text file (``.SID_FEM``, ``.sid``; one-sided).
    modes
        ``None``: all modes; an int ``r``: the first ``r``; a sequence: these mode numbers
        (1-based, in this order).

    Returns
    -------
    dict
        :meth:`Invariants.to_flat` of the (selected) modes.

    Raises
    ------
    DataError
        Unreadable file, a SID syntax error (with its line), a reduced body without
        invariants, a mode selection out of range.
    """
    p = Path(path)
    file = os.fspath(p)
    check_regular_file(p, "elastic-body data file")  # /dev/zero, a FIFO: refused at once
    try:
        if p.suffix.lower() == ".npz":
            arrays = load_npz(p)
            if _is_parametric(arrays, file):
                return _parametric(p, modes, file)
            if _is_flat(arrays):
                inv = Invariants.from_flat(arrays)
            else:
                body = load_reduced_body(p)
                inv = body_invariants(body)
                if inv is None:
                    raise DataError("the reduced body holds no floating-frame invariants "
                                    "(fill them with elastic.invariants.attach_invariants)",
                                    file=file, item="invariants")
                io = _io(body.B, body.C, body.input_names, body.output_names, inv.nq, modes,
                         file)
        else:
            inv = invariants_from_sid(read_sid(p))
    except DataError as exc:  # errors of the invariants' own checks name no file
        if exc.file is not None:
            raise
        raise DataError(exc.message, file, exc.item, exc.line) from None
    if modes is not None:
        inv = _select(inv, modes, file)
    flat = inv.to_flat()
    if p.suffix.lower() == ".npz" and not _is_flat(arrays):
        flat.update(io)
    return flat


def _io(B: np.ndarray, C: np.ndarray, inputs: Sequence[str], outputs: Sequence[str], nq: int,
        modes: int | Sequence[int] | None, file: str) -> dict[str, np.ndarray]:
    """The :data:`IO_KEYS` arrays of a body (the selected modes only)."""
    B, C = np.asarray(B, dtype=np.float64), np.asarray(C, dtype=np.float64)
    if B.shape[0] != nq or C.shape[1] != nq:
        raise DataError(f"B {B.shape} / C {C.shape} do not match the {nq} elastic "
                        "coordinates of the invariants", file=file, item="B")
    idx = _mode_index(modes, nq, file) if modes is not None else list(range(nq))
    return {"io.B": B[idx].copy(), "io.C": C[:, idx].copy(),
            "io.inputs": np.array(list(inputs), dtype=str),
            "io.outputs": np.array(list(outputs), dtype=str)}


def _is_parametric(arrays: dict[str, np.ndarray], file: str) -> bool:
    if "meta" not in arrays or arrays["meta"].dtype != np.uint8:
        return False
    meta = json_from_uint8(arrays["meta"], file)
    return isinstance(meta, dict) and meta.get("format") == PARAMETRIC_BODY_FORMAT


def _parametric(p: Path, modes: int | Sequence[int] | None, file: str) -> dict[str, np.ndarray]:
    """The samples of a parametric body (equations.md §4), each as flat invariants."""
    body = load_parametric_body(p)
    if body.invariants is None:
        raise DataError("the parametric body holds no floating-frame invariants (interpolate "
                        "reduced bodies that have them: neweul reduce --invariants)",
                        file=file, item="invariants")
    out: dict[str, np.ndarray] = {
        "parametric.values": np.asarray(body.samples, dtype=np.float64),
        "parametric.interpolation": np.array(body.interpolation),
        "parametric.parameter": np.array(body.parameter),
    }
    if body.coordinate is not None:
        out["parametric.coordinate"] = np.array(body.coordinate, dtype=np.float64)
        out["parametric.coordinate_name"] = np.array(body.coordinate_name)
    sets = [("sample", lambda k, a, i: a[i], body.B, body.C)]
    for prefix, data in (("slope", body.slopes), ("curvature", body.curvatures)):
        if data is not None:
            sets.append((prefix, lambda k, a, i, data=data: data["invariants/" + k][i],
                         data["B"], data["C"]))
    for prefix, value, B, C in sets:
        for i in range(body.n_samples):
            flat = {k: (value(k, a, i) if a.dtype.kind == "f" else a[0])
                    for k, a in body.invariants.items()}
            inv = Invariants.from_flat(flat)
            io = _io(B[i], C[i], body.input_names, body.output_names, inv.nq, modes, file)
            if modes is not None:
                inv = _select(inv, modes, file)
            out.update({f"{prefix}{i}/{k}": v for k, v in {**inv.to_flat(), **io}.items()})
    return out


def _is_flat(arrays: dict[str, np.ndarray]) -> bool:
    """A bare invariants file (``np.savez(path, **inv.to_flat())``), not a reduced body."""
    fmt = arrays.get("format")
    return fmt is not None and fmt.dtype.kind == "U" and str(fmt) == FLAT_FORMAT


def _select(inv: Invariants, modes: int | Sequence[int], file: str) -> Invariants:
    nq = inv.nq
    idx = _mode_index(modes, nq, file)
    R = np.eye(nq)[:, idx]
    names = tuple(inv.names[i] for i in idx)
    out = inv.transformed(right=R, left=R.T if inv.two_sided else None)
    return replace(out, names=names)


def _mode_index(modes: int | Sequence[int], nq: int, file: str) -> list[int]:
    """0-based indices of a mode selection (a count or 1-based mode numbers)."""
    if isinstance(modes, bool):
        raise DataError(f"modes must be a count or a list of mode numbers, got {modes!r}",
                        file=file, item="modes")
    if isinstance(modes, int):
        if not 1 <= modes <= nq:
            raise DataError(f"{modes} modes requested, the body has {nq}", file=file,
                            item="modes")
        idx = list(range(modes))
    else:
        idx = []
        for k in modes:
            if isinstance(k, bool) or not isinstance(k, int) or not 1 <= k <= nq:
                raise DataError(f"mode number {k!r} out of range 1…{nq}", file=file,
                                item="modes")
            idx.append(k - 1)
        if len(set(idx)) != len(idx) or not idx:
            raise DataError("mode numbers must be distinct and not empty", file=file,
                            item="modes")
    return idx
