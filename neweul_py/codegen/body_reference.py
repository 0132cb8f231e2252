"""A parametric body's sample stacks read from its body file instead of copied (data by
reference, docs/generated-module-protocol.md "The data file").

The mixing stack of a parametric body in a module's data file (:func:`~neweul_py.ffrf.parametric.
ffrf_stack`: the columns that vary over the samples, one row per sample and derivative) holds
the same numbers as the body file the description names: there each matrix's varying entries
are stored as ``X@values`` (k, n), with ``slope/X@values`` and ``curvature/X@values`` for
Hermite weights (docs/reduced-body-format.md), and the module's stack interleaves them row by
row, the damping ``D = G/ω_ref`` as ``G`` times a factor. :func:`body_sources` finds the
members whose interleaved rows (times a factor) give the stack column block by column block
and checks that reading them back (:func:`~neweul_py.ffrf.data_file.ffrf_stack_parts`) gives
the stack bit for bit; the module then names the body file with its SHA-256 instead of
holding a copy (on the refine-1 middle ear 49 of the data file's 58 MB). A body whose file
does not give its stack exactly keeps it in the data file.
"""

from __future__ import annotations

import hashlib
import mmap
import os
from pathlib import Path
from typing import Any

import numpy as np

from ..ffrf.data_file import ffrf_members, ffrf_npy, ffrf_stack_parts

__all__ = ["DERIVATIVE_PREFIXES", "body_sources", "stack_parts"]

#: The members of a body file that follow ``X@values`` in the rows of a mixing stack: the
#: sample slopes and curvatures (docs/reduced-body-format.md).
DERIVATIVE_PREFIXES = ("slope/", "curvature/")


def _groups(buf: Any, members: dict[str, tuple[int, int]], rows: int
            ) -> list[tuple[list[str], np.ndarray]]:
    """The candidate column blocks of a file: per matrix its ``X@values`` and the derivative
    members that exist, interleaved, when that gives ``rows`` rows."""
    out = []
    for member in members:
        name = member.removesuffix(".npy")
        if not name.endswith("@values") or name.startswith(DERIVATIVE_PREFIXES):
            continue
        names = [name] + [p + name for p in DERIVATIVE_PREFIXES if f"{p}{name}.npy" in members]
        head = ffrf_npy(buf, *members[member])
        if head is None or len(head[1]) != 2 or head[1][0] * len(names) != rows:
            continue
        block = ffrf_stack_parts(buf, members, [[names, 1.0]])
        if block is not None:
            out.append((names, block))
    return out


def _factor(block: np.ndarray, target: np.ndarray) -> float | None:
    """The factor ``s`` with ``block * s`` equal to ``target`` bit for bit, or ``None``."""
    if block.shape != target.shape:
        return None
    if np.array_equal(block, target):
        return 1.0
    nonzero = np.flatnonzero(block)
    if nonzero.size == 0:
        return None
    i = nonzero[0]
    s = float(target.flat[i] / block.flat[i])
    return s if s != 0.0 and np.array_equal(block * s, target) else None


def stack_parts(stack: np.ndarray, buf: Any, members: dict[str, tuple[int, int]]
                ) -> list[list[Any]] | None:
    """The parts (``[names, factor]``, :func:`~neweul_py.ffrf.data_file.ffrf_stack_parts`)
    of the file ``buf`` that give ``stack`` column block by column block, or ``None``."""
    groups = _groups(buf, members, stack.shape[0])
    parts, col = [], 0
    while col < stack.shape[1]:
        for names, block in groups:
            n = block.shape[1]
            s = _factor(block, stack[:, col:col + n]) if col + n <= stack.shape[1] else None
            if s is not None:
                parts.append([names, s])
                col += n
                break
        else:
            return None
    return parts


def body_sources(bodies: list[tuple[str, str]], arrays: dict[str, np.ndarray],
                 module_dir: str | os.PathLike[str]) -> dict[str, Any]:
    """The body files the module reads its parametric bodies' mixing stacks from.

    Parameters
    ----------
    bodies
        ``(name, file)`` of the parametric bodies (the file a description names).
    arrays
        The module's arrays by key (the stack of body ``name`` under ``name/mixing/varying``).
    module_dir
        The module's directory: the files are named relative to it.

    Returns
    -------
    dict
        File name relative to ``module_dir`` → ``{"sha256", "bytes", "owner", "arrays":
        {key: parts}}`` (:func:`~neweul_py.ffrf.data_file.ffrf_load_sources`), for the bodies
        whose file gives their stack exactly.
    """
    out: dict[str, Any] = {}
    for name, file in bodies:
        key = f"{name}/mixing/varying"
        stack = arrays.get(key)
        if stack is None or not file or not Path(file).is_file():
            continue
        with open(file, "rb") as fh:
            if os.fstat(fh.fileno()).st_size == 0:
                continue
            with mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as buf:
                parts, digest = _file_parts(np.asarray(stack), buf)
                size = len(buf)
        try:        # no relative name (another drive): the copy stays
            rel = Path(os.path.relpath(os.path.abspath(file), os.path.abspath(module_dir)))
        except ValueError:
            continue
        if parts is None:
            continue
        entry = out.setdefault(rel.as_posix(), {"sha256": digest, "bytes": size,
                                                "owner": name, "arrays": {}})
        entry["arrays"][key] = parts
    return out


def _file_parts(stack: np.ndarray, buf: Any) -> tuple[list[list[Any]] | None, str]:
    """The parts of the archive ``buf`` that give ``stack`` exactly (read back and compared),
    or ``None``, and the SHA-256 of ``buf``."""
    members = ffrf_members(buf)
    parts = None if members is None else stack_parts(stack, buf, members)
    if parts is not None and not np.array_equal(ffrf_stack_parts(buf, members, parts), stack):
        parts = None
    return parts, hashlib.sha256(buf).hexdigest()
