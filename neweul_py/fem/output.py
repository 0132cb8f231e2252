"""Atomic output of a pressure sweep: FE models, static results (CSV), manifest, pictures.

Everything is written into a temporary directory next to the target, which then replaces the
target in one rename — an interrupted or failed sweep leaves nothing half-written.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..elastic.fe_model import FEModel
from ..errors import DataError

__all__ = [
    "MANIFEST",
    "check_output_dir",
    "write_directory_atomically",
    "write_model",
    "write_static_csv",
]

#: Name of the manifest that marks a directory as a sweep output.
MANIFEST = "sweep.json"


def write_model(fe: FEModel, path: Path) -> None:
    """Write an FE model as ``.npz`` with the writer of :mod:`neweul_py.elastic` (the
    ``neweul-fe`` format); a minimal writer of the same layout is the fallback."""
    try:
        from ..elastic.fe_io import write_fe_model
    except ImportError:  # pragma: no cover - before the elastic I/O landed
        write_fe_model = None
    if write_fe_model is not None:
        write_fe_model(fe, path)
        return
    meta = {  # pragma: no cover
        "format": "neweul-fe",
        "version": 1,
        "name": fe.name,
        "kind": fe.kind,
        "density": fe.density,
        "inputs": {k: [list(p) for p in v] for k, v in fe.inputs.items()},
        "outputs": {k: [list(p) for p in v] for k, v in fe.outputs.items()},
    }
    arrays: dict[str, np.ndarray] = {
        "meta": np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    }
    for key in ("M", "K", "D"):
        a = getattr(fe, key)
        if a is not None:
            arrays[f"{key}_data"] = a.data
            arrays[f"{key}_indices"] = a.indices.astype(np.int64)
            arrays[f"{key}_indptr"] = a.indptr.astype(np.int64)
            arrays[f"{key}_shape"] = np.asarray(a.shape, dtype=np.int64)
    arrays.update(nodes=fe.nodes, dof_node=fe.dof_node, dof_kind=fe.dof_kind.astype("U2"))
    np.savez(path, **arrays)


def write_static_csv(rows: Sequence[Mapping[str, float]], path: Path) -> None:
    """Static results, one row per working point; the header names columns with units."""
    keys = list(rows[0])
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(keys)
        for r in rows:
            w.writerow([repr(float(r[k])) if isinstance(r[k], float) else r[k] for k in keys])


def check_output_dir(out_dir: str | os.PathLike) -> Path:
    """Refuse an output path that is a file or a non-empty directory of other data.

    Raises
    ------
    DataError
        ``out_dir`` exists and holds other data, or is not a directory.
    """
    out = Path(out_dir)
    if out.exists():
        if not out.is_dir():
            raise DataError("output path exists and is not a directory", str(out))
        if any(out.iterdir()) and not (out / MANIFEST).is_file():
            raise DataError(
                f"output directory is not empty and holds no {MANIFEST} (not overwriting)",
                str(out),
            )
    return out


def write_directory_atomically(
    out_dir: str | os.PathLike, fill: Callable[[Path], Mapping[str, Any]]
) -> Path:
    """Create ``out_dir`` with the content ``fill(tmp)`` writes into a temporary directory.

    ``fill`` returns the manifest (written last as :data:`MANIFEST`). An existing ``out_dir``
    is replaced only if it is empty or a previous sweep output (it holds :data:`MANIFEST`).

    Raises
    ------
    DataError
        ``out_dir`` exists and holds other data, or is not a directory.
    """
    out = check_output_dir(out_dir)
    parent = out.parent if str(out.parent) else Path(".")
    parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".tmp", dir=parent))
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o777 & ~umask)  # mkdtemp makes it private; the result is an ordinary dir
    try:
        manifest = fill(tmp)
        with open(tmp / MANIFEST, "w") as fh:
            json.dump(manifest, fh, indent=2, sort_keys=False)
            fh.write("\n")
        old = None
        if out.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".old", dir=parent))
            os.rmdir(old)
            os.replace(out, old)
        os.replace(tmp, out)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out
