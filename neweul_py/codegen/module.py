"""Rendering and writing a generated module (docs/generated-module-protocol.md).

:func:`render_files` picks the composition — the plain module of :mod:`.writer`, or with
elastic bodies the composed module of :mod:`~neweul_py.codegen.elastic` and its data file — and
:func:`generate_module` writes them atomically: rendered completely first (so an invalid model
raises before anything touches the disk), each written to a temporary file beside the target,
flushed, ``fsync``-ed and moved over the target with :func:`os.replace`; the data file first,
under a name carrying its SHA-256, so that an interrupted regeneration leaves the previous
module with its own data file.
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..atomic import atomic_write
from ..progress import StagedProgress
from .writer import compose, module_parts

__all__ = ["GeneratedFiles", "generate_module", "render_files", "render_module"]


@dataclass(frozen=True)
class GeneratedFiles:
    """What a generated module consists of: its text and, with elastic bodies, its data
    file (:class:`.elastic.DataFile`: name, bytes, SHA-256, arrays), written next to it."""

    text: str
    data: Any = None


def render_files(equations: Any, source_hash: str, *, cse: bool = True,
                 sensitivities: bool = False,
                 progress: StagedProgress = None,
                 body_files: Mapping[str, str] | None = None,
                 module_dir: str | os.PathLike[str] | None = None) -> GeneratedFiles:
    """The source text of the generated module and its data file (``None`` without elastic
    bodies).

    Parameters
    ----------
    equations
        An :class:`~neweul_py.equations.Equations`.
    source_hash
        SHA-256 (hex) of the description the equations came from; stored as ``SOURCE_HASH``.
    cse
        Eliminate common subexpressions (default). Off only for debugging.
    sensitivities
        Also the directional (second) derivatives of the parameter sensitivities of linear
        models (docs/sensitivity.md §1; rigid models: about as long again as the rest of the
        module). The first parameter derivatives are in every module.
    progress
        ``progress("code generation", done, total)`` after each block
        (:mod:`neweul_py.progress`).
    body_files, module_dir
        Body name → body file, when the sample stacks of parametric bodies are to be read
        from their body files instead of copied into the data file, and the directory the
        module will be written to, which names them relative to itself
        (:func:`.elastic.elastic_data`).

    Raises
    ------
    GenerationError
        When the equations cannot be turned into code.
    """
    if getattr(equations, "elastic", None) is not None:
        # here: the elastic composition embeds the NumPy kernel (neweul_py.ffrf), which a
        # rigid model never imports
        from .elastic import elastic_module_parts

        parts, data = elastic_module_parts(
            equations, source_hash, cse=cse, progress=progress,
            body_files=None if body_files is None else (body_files, module_dir or "."))
        return GeneratedFiles(compose(parts), data)
    return GeneratedFiles(compose(module_parts(equations, source_hash, cse=cse,
                                               directional=sensitivities, progress=progress)))


def render_module(equations: Any, source_hash: str, *, cse: bool = True,
                  sensitivities: bool = False, progress: StagedProgress = None) -> str:
    """The complete source text of the generated module (:func:`render_files`; a module
    with elastic bodies needs its data file too, which :func:`generate_module` writes).

    Raises
    ------
    GenerationError
        When the equations cannot be turned into code.
    """
    return render_files(equations, source_hash, cse=cse, sensitivities=sensitivities,
                        progress=progress).text


def write_files(files: GeneratedFiles, path: str | os.PathLike[str]) -> Path:
    """Write a rendered module to ``path`` and its data file next to it (first, both
    atomically); data files of the same model that the new module does not name are
    removed afterwards (``<model>.<16 hex digits>.npz``, :func:`.elastic.data_file_name`)."""
    path = Path(path)
    if files.data is None:
        return atomic_write(path, files.text)
    atomic_write(path.parent / files.data.name, files.data.content)
    atomic_write(path, files.text)
    model = files.data.name.rsplit(".", 2)[0]
    stale = re.compile(re.escape(model) + r"\.[0-9a-f]{16}\.npz")
    for other in path.parent.iterdir():
        if other.name != files.data.name and stale.fullmatch(other.name) and not any(
                _names(sibling, other.name) for sibling in path.parent.glob("*.py")
                if sibling != path):
            try:
                other.unlink()
            except OSError:
                pass            # another process removed or holds it: harmless
    return path


def _names(module: Path, data_name: str) -> bool:
    """Whether the module file ``module`` names the data file ``data_name``."""
    try:
        return f"_DATA_FILE = {data_name!r}".encode() in module.read_bytes()
    except OSError:
        return False


def generate_module(
    equations: Any, source_hash: str, path: str | os.PathLike[str], *, cse: bool = True,
    sensitivities: bool = False, progress: StagedProgress = None,
    body_files: Mapping[str, str] | None = None,
) -> Path:
    """Render the module for ``equations`` and write it atomically to ``path`` (with elastic
    bodies also its data file, next to it: :func:`write_files`; ``sensitivities``: as
    :func:`render_files`; ``body_files``: body name → the body file the module reads the
    sample stacks of a parametric body from (named relative to the module) instead of a
    copy in its data file).

    Returns
    -------
    Path
        ``path``. If rendering fails nothing is written and an existing file is untouched.

    Examples
    --------
    >>> generate_module(newton_euler(load_description("examples/pendulum.yaml")),
    ...                 description_hash(b"..."), "generated/pendulum.py")  # doctest: +SKIP
    """
    return write_files(render_files(equations, source_hash, cse=cse,
                                    sensitivities=sensitivities, progress=progress,
                                    body_files=body_files, module_dir=Path(path).parent),
                       path)
