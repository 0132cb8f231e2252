"""Reading and writing FE models: a JSON manifest with Matrix Market / Harwell–Boeing files and
CSV tables, or a single ``.npz``.

Manifest (``"format": "neweul-fe"``, ``"version": 1``)::

    {
      "format": "neweul-fe", "version": 1, "name": "duct",
      "kind": "up-coupled", "density": 1.2,
      "matrices": {"M": "duct.M.mtx", "K": "duct.K.mtx", "D": "duct.D.mtx"},
      "symmetric": {"M": false, "K": false},
      "nodes": "duct.nodes.csv",          # header id,x,y,z
      "dofs": "duct.dofs.csv",            # header index,node,kind (index 0-based)
      "inputs": {"force": [[0, 1.0]]},
      "outputs": {"p_end": [[12, 1.0]]}
    }

Matrix files: ``.mtx`` (Matrix Market, :func:`scipy.io.mmread`) or Harwell–Boeing
(``.hb``, ``.rua``, ``.rsa``, :func:`scipy.io.hb_read`); ``"D"`` is optional. Paths are
relative to the manifest. Every error is a :class:`~neweul_py.errors.DataError` naming the file
and the matrix or table.

The ``.npz`` form holds the CSR arrays ``<X>_data``, ``<X>_indices``, ``<X>_indptr``,
``<X>_shape`` for X in M, K (and D), ``nodes``, ``dof_node``, ``dof_kind`` (unicode) and
``meta`` (UTF-8 JSON as uint8: format, version, name, kind, density, symmetric, inputs,
outputs). It is read with ``allow_pickle=False``. Version 2 (written now) stores indices as
int32 where they fit, deflates the members and may be a *delta* file: only what differs from
a complete base file, which its ``meta`` names with its SHA-256
(:mod:`~neweul_py.elastic.io.fe_delta`; ``docs/fe-file-format.md``); the same model gives the
same bytes. Version-1 files read; newer versions are refused.

Optional groups (read by :func:`read_node_sets` and :func:`read_stiffening`; the FE model
itself ignores them):

* **node sets** – ``"node_sets": {"root": [1, 2, 3], …}`` in the manifest or in the ``.npz``
  ``meta`` JSON: named lists of node ids (interfaces, averaged frames);
* **stiffening** – the geometric stiffness ``K_G,c`` (n×n) of the unit inertia load cases
  ``c`` of :data:`~neweul_py.elastic.bodies.invariants.LOAD_CASES` (``ax … alphaz, wxx … wxz``),
  for models whose element formulation is not known here: in the manifest
  ``"stiffening": {"wzz": "beam.KG.wzz.mtx", …}`` (Matrix Market / Harwell–Boeing files,
  relative to the manifest), in the ``.npz`` the CSR arrays ``KG.<c>_data``,
  ``KG.<c>_indices``, ``KG.<c>_indptr``, ``KG.<c>_shape``. Missing cases have no stiffening.
  ``write_fe_model(…, stiffening=…)`` writes them to ``.npz`` files; with them the ``.npz``
  may hold ``UG.<c>`` (n,), the static response ``u_c`` of the same case (support clamped),
  which spans the second-order displacement field of the stiffened body
  (:func:`read_stiffening_responses`; ``docs/equations.md`` §2.3).

Writers are atomic: a single file is written to a temp file and moved with ``os.replace``. A
manifest's companion files carry a content hash in their names (``<stem>.<hash>.M.mtx``,
``<stem>.<hash>.nodes.csv``, …); they are written and moved in first, the manifest that names
them replaces the old one atomically, and the old manifest's companions are removed last, so
a reader never sees a manifest naming a mix of old and new files.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import scipy.io
import scipy.sparse as sps

from ...errors import DataError
from ...files import check_regular_file, read_checked
from ..bodies.invariants import LOAD_CASES
from ..fe_model import FEModel
from .fe_delta import merge_delta, write_fe_arrays
from .npz import atomic_write, json_from_uint8, json_to_uint8, load_npz

__all__ = ["FE_FORMAT", "FE_VERSION", "LOSS_KEYS", "csr_arrays", "fe_arrays", "load_fe_arrays",
           "loss_group", "read_fe_model", "read_node_sets", "read_stiffening",
           "read_stiffening_responses", "write_fe_model"]

FE_FORMAT = "neweul-fe"
#: The version written; every version from 1 up to it reads (docs/fe-file-format.md).
FE_VERSION = 2
_HB_SUFFIXES = (".hb", ".rua", ".rsa", ".hb.txt")


# ---------------------------------------------------------------------- public API
def read_fe_model(path: str | os.PathLike) -> FEModel:
    """Read an FE model from a JSON manifest (``.json``) or a single ``.npz``.

    Parameters
    ----------
    path
        The manifest or ``.npz`` file.

    Returns
    -------
    FEModel
        Validated; ``source`` is ``str(path)``.

    Raises
    ------
    DataError
        Naming the file and the matrix/table at fault.
    """
    path = Path(path)
    if path.suffix.lower() == ".npz":
        return _read_npz(path)
    return _read_manifest(path)


def write_fe_model(fe: FEModel, path: str | os.PathLike, matrix_format: str = "mtx", *,
                   node_sets: dict[str, Any] | None = None,
                   stiffening: dict[str, Any] | None = None,
                   stiffening_responses: dict[str, Any] | None = None,
                   base: str | os.PathLike | None = None) -> None:
    """Write ``fe`` as a manifest (``.json``, with ``matrix_format`` files) or ``.npz``.

    Parameters
    ----------
    fe
        The model.
    path
        Target; the suffix picks the form (``.npz`` or ``.json``). Companion files of a
        manifest are named ``<stem>.<hash>.M.mtx``, ``<stem>.<hash>.nodes.csv``, … next to
        it (``<hash>``: 16 hex digits of the content's SHA-256); when a manifest written by
        this function is overwritten, its old companions are removed after the new manifest
        is in place (files of other names are never touched).
    matrix_format
        ``"mtx"`` (Matrix Market) or ``"hb"`` (Harwell–Boeing, written as ``.rua``).
    node_sets, stiffening, stiffening_responses
        Optional groups (module docstring): name → node ids, load case → n×n ``K_G,c``,
        load case → (n,) static response ``u_c`` (stiffening: ``.npz`` only).
    base
        A complete ``.npz`` FE file in the same or a sibling directory: ``path`` is written as
        a delta file holding only what differs from it (``.npz`` only; module
        :mod:`~neweul_py.elastic.io.fe_delta`). Best for models of one mesh and pattern.
    """
    path = Path(path)
    if fe.G is not None and path.suffix.lower() != ".npz":
        raise DataError("the loss group (hysteretic matrix G) is written to .npz files only",
                        str(path), "G")
    if base is not None and path.suffix.lower() != ".npz":
        raise DataError("delta files (a base) are .npz files only", str(path), "base")
    extra = _optional_groups(fe, node_sets, stiffening, path, stiffening_responses)
    if path.suffix.lower() == ".npz":
        write_fe_arrays(path, fe_arrays(fe, extra), base)
    else:
        _write_manifest(fe, path, matrix_format, extra)


# ---------------------------------------------------------------------- manifest
def _meta(fe: FEModel) -> dict[str, Any]:
    return {
        "format": FE_FORMAT,
        "version": FE_VERSION,
        "name": fe.name,
        "kind": fe.kind,
        "density": fe.density,
        "symmetric": dict(fe.symmetric),
        "inputs": {k: [list(p) for p in v] for k, v in fe.inputs.items()},
        "outputs": {k: [list(p) for p in v] for k, v in fe.outputs.items()},
    }


def _check_header(meta: Any, file: str) -> None:
    if not isinstance(meta, dict):
        raise DataError("top level must be a JSON object", file, "manifest")
    if meta.get("format") != FE_FORMAT:
        raise DataError(f"\"format\" must be {FE_FORMAT!r}, got {meta.get('format')!r}", file,
                        "format")
    version = meta.get("version")
    if isinstance(version, int) and not isinstance(version, bool) and version > FE_VERSION:
        raise DataError(f"version {version} is newer than this reader (versions 1 … "
                        f"{FE_VERSION}): update neweul-py", file, "version")
    if not (isinstance(version, int) and 1 <= version <= FE_VERSION):
        raise DataError(f"unsupported version {version!r} (this reader: 1 … {FE_VERSION})",
                        file, "version")
    for key in ("inputs", "outputs", "symmetric"):
        if not isinstance(meta.get(key, {}), dict):
            raise DataError("must be an object", file, key)
    for key in ("name", "kind"):
        if key in meta and not isinstance(meta[key], str):
            raise DataError(f"must be a string, got {meta[key]!r}", file, key)


def _read_manifest(path: Path) -> FEModel:
    file = str(path)
    try:
        text = read_checked(path, "FE manifest", 64 * 2**20).decode("utf-8")
    except DataError as exc:
        raise DataError("file not found" if "not found" in exc.message else exc.message,
                        file) from None
    except UnicodeDecodeError as exc:
        raise DataError(f"cannot read ({exc})", file) from None
    try:
        meta = json.loads(text)
    except RecursionError:
        raise DataError("the manifest is nested too deeply", file, "manifest") from None
    except json.JSONDecodeError as exc:
        raise DataError(f"invalid JSON: {exc.msg}", file, "manifest", exc.lineno) from None
    _check_header(meta, file)
    mats = meta.get("matrices")
    if not isinstance(mats, dict) or "M" not in mats or "K" not in mats:
        raise DataError("needs \"matrices\" with at least \"M\" and \"K\" file names", file,
                        "matrices")
    unknown = set(mats) - {"M", "K", "D"}
    if unknown:
        raise DataError(f"unknown matrices {sorted(unknown)}", file, "matrices")
    base = path.parent
    matrices = {key: _read_matrix(base, mats[key], key, file) for key in mats}
    for key, a in matrices.items():
        if a.shape[0] != a.shape[1] or a.shape != matrices["M"].shape:
            raise DataError(f"shape {a.shape} does not match M's {matrices['M'].shape} "
                            "(must be square n×n)", str(base / mats[key]), key)
    for key in ("nodes", "dofs"):
        if not isinstance(meta.get(key), str):
            raise DataError("needs a CSV file name", file, key)
    nodes = _read_nodes(base / meta["nodes"])
    index, dof_node, dof_kind = _read_dofs(base / meta["dofs"])
    n = matrices["M"].shape[0]
    dfile = str(base / meta["dofs"])
    if np.sort(index).tolist() != list(range(index.size)):
        raise DataError("the index column must be a permutation of 0 … n−1", dfile, "dofs")
    if index.size != n:
        what = "the table lists no DOFs" if index.size == 0 else f"{index.size} DOFs listed"
        raise DataError(f"{what} but the matrices are {n}×{n}", dfile, "dofs")
    order = np.argsort(index)
    files = {key: str(base / mats[key]) for key in matrices}
    files.update(nodes=str(base / meta["nodes"]), dofs=dfile)
    return _build(file, meta, matrices, nodes, dof_node[order], dof_kind[order], files)


def _build(file: str, meta: dict, matrices: dict, nodes, dof_node, dof_kind,
           files: dict[str, str] | None = None,
           loss: tuple[sps.csr_matrix, float] | None = None) -> FEModel:
    """Construct (and so validate, once) the model, with the loss group ``(G, f_ref)``
    where given; errors about a matrix or table name the companion file that holds it
    (``files``: item → file; ``G`` is the ``.npz`` member ``loss_G``), others the
    manifest."""
    kind = meta.get("kind", "structural")
    G, f_ref = loss if loss is not None else (None, None)
    try:
        return FEModel(
            M=matrices["M"], K=matrices["K"], D=matrices.get("D"),
            nodes=nodes, dof_node=dof_node, dof_kind=dof_kind,
            inputs=meta.get("inputs", {}), outputs=meta.get("outputs", {}),
            kind=kind, density=meta.get("density"),
            name=str(meta.get("name", Path(file).stem)),
            symmetric=meta.get("symmetric", {}), source=file,
            G=G, loss_reference_frequency=f_ref,
        )
    except DataError as exc:
        if loss is not None and exc.file == file and exc.item == "G":
            raise DataError(exc.message, file, "loss_G") from None
        where = (files or {}).get(exc.item or "")
        if where is None or exc.file != file:
            raise
        raise DataError(exc.message, where, exc.item, exc.line) from None


def _read_matrix(base: Path, name: Any, key: str, manifest: str) -> sps.csr_matrix:
    if not isinstance(name, str):
        raise DataError("matrix entry must be a file name", manifest, key)
    path = base / name
    file = str(path)
    if not path.exists():
        raise DataError("matrix file not found", file, key)
    size = check_regular_file(path, "matrix file").stat().st_size
    if not path.name.lower().endswith(_HB_SUFFIXES):
        check_mtx_header(path, size, key)
    try:
        if path.name.lower().endswith(_HB_SUFFIXES):
            a = scipy.io.hb_read(file)
        else:
            a = scipy.io.mmread(file)
    except Exception as exc:  # the readers raise many kinds of errors on bad files
        text = " ".join(str(exc).split())  # scipy's messages may span lines: one line
        raise DataError(f"cannot read matrix ({type(exc).__name__}: {text})", file,
                        key) from None
    if not sps.issparse(a):
        a = sps.csr_matrix(np.asarray(a))
    if a.dtype.kind == "c":
        raise DataError("complex matrices are not supported", file, key)
    a = sps.csr_matrix(a, dtype=np.float64)
    if not np.all(np.isfinite(a.data)):
        raise DataError(f"matrix has {np.count_nonzero(~np.isfinite(a.data))} NaN/Inf "
                        "entries", file, key)
    return a


#: Largest matrix dimension accepted from a file header (``NEWEUL_MAX_DOFS``; docs/limits.md).
MAX_DOFS = int(os.environ["NEWEUL_MAX_DOFS"]) if os.environ.get(
    "NEWEUL_MAX_DOFS", "").isdigit() else 20_000_000


def check_mtx_header(path: Path, size: int, key: str) -> None:
    """Refuse a Matrix Market header whose dimensions the file cannot hold: more than
    :data:`MAX_DOFS` rows or columns, more entries than the file has room for (an entry needs at
    least 4 bytes, ``"i j\\n"``), or a dense array larger than the file — before
    :func:`scipy.io.mmread` allocates anything."""
    file = str(path)
    try:
        with open(path, "rb") as fh:
            banner = fh.readline(1024).decode("ascii", "replace").lower().split()
            line = b"%"
            while line.startswith(b"%"):
                line = fh.readline(1024)
                if not line:
                    break
                line = line.strip() or b"%"
    except OSError as exc:
        raise DataError(f"cannot read ({exc.strerror})", file, key) from None
    words = line.split()
    try:
        dims = [int(w) for w in words]
    except ValueError:
        return  # mmread reports the syntax error
    dense = len(banner) > 2 and banner[2] == "array"
    if len(dims) < 2 or any(d < 0 for d in dims):
        return
    rows, cols = dims[0], dims[1]
    if max(rows, cols) > MAX_DOFS:
        raise DataError(f"the header declares a {rows}×{cols} matrix; more than the cap of "
                        f"{MAX_DOFS} rows or columns (NEWEUL_MAX_DOFS, docs/limits.md)", file, key)
    entries = rows * cols if dense else (dims[2] if len(dims) > 2 else 0)
    if entries * (2 if dense else 4) > size:
        raise DataError(f"the header declares {entries} entries, more than a file of {size} "
                        "bytes can hold", file, key)


def _read_csv(path: Path, header: list[str], item: str) -> np.ndarray:
    file = str(path)
    if path.exists():
        check_regular_file(path, f"{item} table")
    try:
        with open(path, encoding="utf-8") as fh:
            first = fh.readline()
            cols = [c.strip().lower() for c in first.strip().split(",")]
            if cols != header:
                raise DataError(f"header must be {','.join(header)}, got {first.strip()!r}",
                                file, item, 1)
            rows = fh.readlines()
            if any(line.strip() for line in rows):  # np.loadtxt warns on an empty table
                table = np.loadtxt(rows, delimiter=",", dtype=str, ndmin=2)
            else:
                table = np.zeros((0, len(header)), dtype=str)
    except FileNotFoundError:
        raise DataError("file not found", file, item) from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise DataError(f"cannot read CSV ({exc})", file, item) from None
    if table.size == 0:
        table = table.reshape(0, len(header))
    if table.shape[1] != len(header):
        raise DataError(f"expected {len(header)} columns, got {table.shape[1]}", file, item)
    return np.char.strip(table)


def _numbers(col: np.ndarray, file: str, item: str, what: str, start_line: int = 2):
    try:
        return col.astype(np.float64)
    except ValueError:
        flat = col.reshape(col.shape[0], -1)
        bad = next(i for i, row in enumerate(flat) if not all(_is_float(s) for s in row))
        text = next(s for s in flat[bad] if not _is_float(s))
        raise DataError(f"{what} {str(text)!r} is not a number", file, item,
                        start_line + bad) from None


def _is_float(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


def _read_nodes(path: Path) -> np.ndarray:
    table = _read_csv(path, ["id", "x", "y", "z"], "nodes")
    return _numbers(table, str(path), "nodes", "entry")


def _read_dofs(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    file = str(path)
    table = _read_csv(path, ["index", "node", "kind"], "dofs")
    index = _numbers(table[:, 0], file, "dofs", "index")
    node = _numbers(table[:, 1], file, "dofs", "node id")
    for col, what in ((index, "index"), (node, "node id")):
        if np.any(col != np.round(col)):
            bad = int(np.flatnonzero(col != np.round(col))[0])
            raise DataError(f"{what} must be an integer", file, "dofs", bad + 2)
    return index.astype(np.int64), node.astype(np.int64), table[:, 2]


#: Companion file of a manifest written by :func:`write_fe_model`:
#: ``<stem>.<content hash>.<role>.<ext>`` (role M, K, D, nodes or dofs).
_COMPANION = re.compile(r"^(?P<stem>.+)\.(?P<tag>[0-9a-f]{16})\.(?:M|K|D|nodes|dofs)"
                        r"\.(?:mtx|rua|csv)$")


def _old_companions(path: Path) -> set[str]:
    """Companion files named by the manifest currently at ``path`` that this writer made.

    Only names of the writer's own pattern (same stem, content-hash tag, same directory) are
    returned, so rewriting a hand-made manifest never deletes the user's files.
    """
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return set()
    if not isinstance(meta, dict):
        return set()
    mats = meta.get("matrices")
    names = list(mats.values()) if isinstance(mats, dict) else []
    names += [meta.get("nodes"), meta.get("dofs")]
    out = set()
    for name in names:
        if isinstance(name, str) and Path(name).name == name:
            m = _COMPANION.fullmatch(name)
            if m and m.group("stem") == path.stem:
                out.add(name)
    return out


def _fsync_and_hash(path: Path, h) -> None:
    with open(path, "rb") as fh:
        h.update(fh.read())
        os.fsync(fh.fileno())


def _write_manifest(fe: FEModel, path: Path, matrix_format: str,
                    extra: dict[str, Any] | None = None) -> None:
    """Write the companion files, then the manifest; a reader always sees a consistent set.

    The companions get names with a content hash (``<stem>.<hash>.M.mtx``, …): they are
    written to a temporary directory, fsync'ed, moved in under names no existing manifest
    uses (or onto an identical file), then the manifest naming them replaces the old one
    atomically (``os.replace``), and only then the companions of the old manifest are
    removed. An interrupt at any point leaves the old manifest with its own files (new
    companions already moved in are removed again) or the complete new model.
    """
    if matrix_format not in ("mtx", "hb"):
        raise ValueError(f"matrix_format must be 'mtx' or 'hb', got {matrix_format!r}")
    ext = ".mtx" if matrix_format == "mtx" else ".rua"
    stem = path.stem
    directory = path.parent if str(path.parent) else Path(".")
    directory.mkdir(parents=True, exist_ok=True)
    old = _old_companions(path)
    meta = _meta(fe)
    meta.update((extra or {}).get("meta", {}))
    keys = ["M", "K"] + (["D"] if fe.D is not None else [])
    roles = {key: f"{key}{ext}" for key in keys}
    roles.update(nodes="nodes.csv", dofs="dofs.csv")
    tmpdir = Path(tempfile.mkdtemp(prefix=f".{stem}.", dir=directory))
    placed: list[Path] = []
    try:
        for key in keys:
            a = getattr(fe, key).tocsc()
            if matrix_format == "mtx":
                scipy.io.mmwrite(str(tmpdir / roles[key]), a, precision=17)
            else:
                scipy.io.hb_write(str(tmpdir / roles[key]), a)
        ids = fe.nodes[:, 0].astype(np.int64)
        with open(tmpdir / roles["nodes"], "w", encoding="utf-8") as fh:
            fh.write("id,x,y,z\n")
            xyz = np.char.mod("%.17g", fe.nodes[:, 1:])
            lines = np.char.add(np.char.add(ids.astype(str), ","), _join(xyz))
            fh.write("\n".join(lines.tolist()) + ("\n" if lines.size else ""))
        with open(tmpdir / roles["dofs"], "w", encoding="utf-8") as fh:
            fh.write("index,node,kind\n")
            cols = np.stack([np.arange(fe.n_dofs).astype(str), fe.dof_node.astype(str),
                             fe.dof_kind.astype(str)], axis=1)
            lines = _join(cols)
            fh.write("\n".join(lines.tolist()) + ("\n" if lines.size else ""))
        h = hashlib.sha256()
        for role in roles.values():
            h.update(f"\0{role}\0".encode())
            _fsync_and_hash(tmpdir / role, h)
        tag = h.hexdigest()[:16]
        names = {key: f"{stem}.{tag}.{role}" for key, role in roles.items()}
        for key, role in roles.items():
            target = directory / names[key]
            existed = target.exists()  # same name = same content (hash)
            os.replace(tmpdir / role, target)
            if not existed:
                placed.append(target)
        meta["matrices"] = {key: names[key] for key in keys}
        meta["nodes"], meta["dofs"] = names["nodes"], names["dofs"]
        text = json.dumps(meta, indent=2, allow_nan=False) + "\n"
        atomic_write(path, lambda fh: fh.write(text.encode("utf-8")))
    except BaseException:
        for p in placed:
            try:
                p.unlink()
            except OSError:
                pass
        raise
    finally:
        shutil.rmtree(tmpdir, ignore_errors=True)
    for name in old - set(names.values()):
        try:
            (directory / name).unlink()
        except OSError:  # already gone or not removable: a stale file, harmless
            pass


def _join(cols: np.ndarray) -> np.ndarray:
    out = cols[:, 0].astype(object)
    for j in range(1, cols.shape[1]):  # loop over the few columns, not the rows
        out = out + "," + cols[:, j].astype(object)
    return out.astype(str)


# ---------------------------------------------------------------------- npz
def csr_arrays(prefix: str, a: sps.spmatrix) -> dict[str, np.ndarray]:
    """``<prefix>_data``, ``_indices``, ``_indptr`` (int32 where the values fit, else int64)
    and ``_shape`` of the CSR form of ``a``."""
    a = sps.csr_matrix(a)
    fits = max((*a.shape, a.nnz)) < 2**31
    index = np.int32 if fits else np.int64
    return {f"{prefix}_data": a.data, f"{prefix}_indices": a.indices.astype(index),
            f"{prefix}_indptr": a.indptr.astype(index),
            f"{prefix}_shape": np.asarray(a.shape, dtype=np.int64)}


def fe_arrays(fe: FEModel, extra: Mapping[str, Any] | None = None) -> dict[str, np.ndarray]:
    """The arrays of the complete ``.npz`` file of ``fe`` (module docstring) with the optional
    groups ``extra`` (``{"meta": {…}, "arrays": {…}, "loss_meta": {…}}``)."""
    extra = extra or {}
    arrays: dict[str, np.ndarray] = {"meta": json_to_uint8({**_meta(fe),
                                                            **extra.get("meta", {})})}
    arrays.update(extra.get("arrays", {}))
    if fe.G is not None:
        arrays.update(loss_group(fe.G, {"f_ref_Hz": fe.loss_reference_frequency,
                                        **extra.get("loss_meta", {})}))
    for key in ("M", "K", "D"):
        a = getattr(fe, key)
        if a is not None:
            arrays.update(csr_arrays(key, a))
    arrays["nodes"] = fe.nodes
    arrays["dof_node"] = fe.dof_node
    arrays["dof_kind"] = fe.dof_kind.astype("U2")
    return arrays


def loss_group(G: sps.spmatrix, meta: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """The arrays of the optional loss group (:data:`LOSS_KEYS`) for ``G`` and ``meta``
    (which must hold ``f_ref_Hz``)."""
    return {**csr_arrays("loss_G", G), "loss_meta": json_to_uint8(dict(meta))}


def load_fe_arrays(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Every array of an ``.npz`` FE file after its header check; a delta file's merged with
    its base's (:func:`~neweul_py.elastic.io.fe_delta.merge_delta`: equal to the arrays written,
    bit for bit).

    Raises
    ------
    DataError
        Not an FE file of a version this reader knows; a missing or changed base.
    """
    path = Path(path)
    file = str(path)
    data = load_npz(path)
    if "meta" not in data:
        raise DataError("missing the \"meta\" array", file, "meta")
    meta = json_from_uint8(data["meta"], file)
    _check_header(meta, file)
    if "base" not in meta:
        return data
    if meta["version"] < 2:
        raise DataError("a delta file (\"base\") needs version 2 or later", file, "meta.base")
    return merge_delta(path, data, meta)


def _read_npz(path: Path) -> FEModel:
    file = str(path)
    data = load_fe_arrays(path)
    meta = json_from_uint8(data["meta"], file)
    matrices = {}
    for key in ("M", "K", "D"):
        parts = [f"{key}_{s}" for s in ("data", "indices", "indptr", "shape")]
        present = [p in data for p in parts]
        if not any(present) and key == "D":
            continue
        if not all(present):
            raise DataError(f"needs arrays {', '.join(parts)}", file, key)
        d, ind, ptr, shape = (data[p] for p in parts)
        try:
            matrices[key] = sps.csr_matrix((d.astype(np.float64), ind, ptr),
                                           shape=tuple(int(s) for s in shape))
            matrices[key].check_format(full_check=True)
        except (ValueError, TypeError, IndexError) as exc:
            raise DataError(f"inconsistent CSR arrays ({exc})", file, key) from None
    for key in ("nodes", "dof_node", "dof_kind"):
        if key not in data:
            raise DataError("missing array", file, key)
    return _build(file, meta, matrices, data["nodes"], data["dof_node"], data["dof_kind"],
                  loss=_read_loss_group(data, file))


#: Keys of the optional loss group of an ``.npz`` FE file (``docs/equations.md`` §1.1): the
#: hysteretic damping ``G`` of ``K + iG`` in CSR form and ``loss_meta`` (UTF-8 JSON with at
#: least ``f_ref_Hz``, the reference frequency of the time-domain equivalent ``D = G/ω_ref``).
LOSS_KEYS = ("loss_G_data", "loss_G_indices", "loss_G_indptr", "loss_G_shape", "loss_meta")


def _read_loss_group(data: Mapping[str, np.ndarray], file: str
                     ) -> tuple[sps.csr_matrix, float] | None:
    """``(G, f_ref)`` of the optional loss group, ``None`` without one."""
    if "loss_G_data" not in data:
        return None
    missing = [k for k in LOSS_KEYS if k not in data]
    if missing:
        raise DataError(f"the loss group lacks {', '.join(missing)}", file, "loss_G")
    try:
        G = sps.csr_matrix((data["loss_G_data"].astype(np.float64), data["loss_G_indices"],
                            data["loss_G_indptr"]),
                           shape=tuple(int(s) for s in data["loss_G_shape"]))
        G.check_format(full_check=True)
    except (ValueError, TypeError, IndexError) as exc:
        raise DataError(f"inconsistent CSR arrays ({exc})", file, "loss_G") from None
    meta = json_from_uint8(data["loss_meta"], file)
    f_ref = meta.get("f_ref_Hz") if isinstance(meta, dict) else None
    if not isinstance(f_ref, int | float) or isinstance(f_ref, bool):
        raise DataError(f"loss_meta must name the reference frequency f_ref_Hz, got "
                        f"{f_ref!r}", file, "loss_meta.f_ref_Hz")
    return G, float(f_ref)



# ------------------------------------------------ optional groups: node sets, stiffening
def _optional_groups(fe: FEModel, node_sets, stiffening, path: Path,
                     responses=None) -> dict[str, Any]:
    """Meta entries and arrays of the optional groups (validated before anything is written)."""
    out: dict[str, Any] = {"meta": {}, "arrays": {}}
    if node_sets:
        ids = set(fe.nodes[:, 0].astype(np.int64).tolist())
        sets = {}
        for name, members in node_sets.items():
            members = [int(i) for i in np.asarray(members).reshape(-1)]
            if not members or not set(members) <= ids:
                raise DataError("node set is empty or names unknown node ids", str(path),
                                f"node_sets.{name}")
            sets[str(name)] = members
        out["meta"]["node_sets"] = sets
    if stiffening:
        if path.suffix.lower() != ".npz":
            raise DataError("stiffening matrices are written to .npz files only", str(path),
                            "stiffening")
        for case, a in stiffening.items():
            if case not in LOAD_CASES:
                raise DataError(f"unknown load case {case!r}", str(path), f"stiffening.{case}")
            a = sps.csr_matrix(a, dtype=np.float64)
            if a.shape != (fe.n_dofs, fe.n_dofs):
                raise DataError(f"shape {a.shape}, the model has {fe.n_dofs} DOFs", str(path),
                                f"KG.{case}")
            out["arrays"].update(csr_arrays(f"KG.{case}", a))
    for case, u in (responses or {}).items():
        if path.suffix.lower() != ".npz":
            raise DataError("stiffening responses are written to .npz files only", str(path),
                            "stiffening_responses")
        u = np.asarray(u, dtype=np.float64)
        if case not in LOAD_CASES or u.shape != (fe.n_dofs,) or not np.all(np.isfinite(u)):
            raise DataError(f"must be a finite ({fe.n_dofs},) vector of a known load case, got "
                            f"shape {u.shape}", str(path), f"UG.{case}")
        out["arrays"][f"UG.{case}"] = u
    return out


def _meta_of(path: Path) -> tuple[dict, dict[str, np.ndarray] | None]:
    """The manifest JSON, or the ``.npz`` meta JSON and its arrays."""
    file = str(path)
    if path.suffix.lower() == ".npz":
        data = load_fe_arrays(path)
        meta = json_from_uint8(data["meta"], file)
    else:
        data = None
        try:
            meta = json.loads(read_checked(path, "FE manifest", 64 * 2**20).decode("utf-8"))
        except DataError as exc:
            raise DataError("file not found" if "not found" in exc.message else exc.message,
                            file) from None
        except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
            raise DataError(f"cannot read ({exc})", file, "manifest") from None
    if not isinstance(meta, dict):
        raise DataError("top level must be a JSON object", file, "manifest")
    return meta, data


def read_node_sets(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """The named node sets of an FE file (``{}`` when it has none).

    Raises
    ------
    DataError
        ``node_sets`` is not an object of integer lists (item ``node_sets.<name>``).
    """
    path = Path(path)
    meta, _ = _meta_of(path)
    sets = meta.get("node_sets", {})
    if not isinstance(sets, dict):
        raise DataError("must be an object of node-id lists", str(path), "node_sets")
    out = {}
    for name, members in sets.items():
        if not (isinstance(members, list)
                and all(isinstance(i, int) and not isinstance(i, bool) for i in members)):
            raise DataError("must be a list of integer node ids", str(path),
                            f"node_sets.{name}")
        out[str(name)] = np.asarray(members, dtype=np.int64)
    return out


def read_stiffening(path: str | os.PathLike) -> dict[str, sps.csr_matrix]:
    """The geometric-stiffness group ``K_G,c`` of an FE file (``{}`` when it has none).

    Raises
    ------
    DataError
        Unknown load cases, unreadable or non-square matrices (item ``KG.<case>``).
    """
    path = Path(path)
    file = str(path)
    meta, data = _meta_of(path)
    out: dict[str, sps.csr_matrix] = {}
    if data is not None:
        cases = sorted({k[3:].rsplit("_", 1)[0] for k in data if k.startswith("KG.")})
        for case in cases:
            item = f"KG.{case}"
            if case not in LOAD_CASES:
                raise DataError(f"unknown load case {case!r} (one of "
                                f"{', '.join(LOAD_CASES)})", file, item)
            parts = [f"{item}_{s}" for s in ("data", "indices", "indptr", "shape")]
            if not all(p in data for p in parts):
                raise DataError(f"needs arrays {', '.join(parts)}", file, item)
            d, ind, ptr, shape = (data[p] for p in parts)
            try:
                a = sps.csr_matrix((d.astype(np.float64), ind, ptr),
                                   shape=tuple(int(s) for s in shape))
                a.check_format(full_check=True)
            except (ValueError, TypeError, IndexError) as exc:
                raise DataError(f"inconsistent CSR arrays ({exc})", file, item) from None
            out[case] = a
    else:
        group = meta.get("stiffening", {})
        if not isinstance(group, dict):
            raise DataError("must be an object: load case -> matrix file", file, "stiffening")
        for case, name in group.items():
            if case not in LOAD_CASES:
                raise DataError(f"unknown load case {case!r} (one of "
                                f"{', '.join(LOAD_CASES)})", file, f"KG.{case}")
            out[case] = _read_matrix(path.parent, name, f"KG.{case}", file)
    for case, a in out.items():
        if a.shape[0] != a.shape[1]:
            raise DataError(f"matrix must be square, got shape {a.shape}", file, f"KG.{case}")
        if not np.all(np.isfinite(a.data)):
            raise DataError("matrix has NaN/Inf entries", file, f"KG.{case}")
    return out


def read_stiffening_responses(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """The static responses ``UG.<case>`` (n,) of an ``.npz`` FE file (``{}`` without them).

    Raises
    ------
    DataError
        Unknown load case, not a finite vector (item ``UG.<case>``).
    """
    path = Path(path)
    _meta, data = _meta_of(path)
    out: dict[str, np.ndarray] = {}
    for key in sorted(data or {}):
        if not key.startswith("UG."):
            continue
        case, u = key[3:], np.asarray(data[key])
        if case not in LOAD_CASES:
            raise DataError(f"unknown load case {case!r} (one of {', '.join(LOAD_CASES)})",
                            str(path), key)
        if u.dtype.kind not in "fi":
            raise DataError(f"must be a float vector, got dtype {u.dtype}", str(path), key)
        if u.ndim != 1 or not np.all(np.isfinite(u)):
            raise DataError(f"must be a finite vector, got shape {u.shape}", str(path), key)
        out[case] = u.astype(np.float64)
    return out
