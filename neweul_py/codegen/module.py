"""Rendering and writing a generated module (docs/generated-module-protocol.md).

:func:`render_module` picks the composition — the plain module of :mod:`.writer`, or with
elastic bodies the composed module of :mod:`~neweul_py.codegen.elastic` — and
:func:`generate_module` writes the text atomically: rendered completely first (so an invalid
model raises before anything touches the disk), written to a temporary file beside the target,
flushed, ``fsync``-ed and moved over the target with :func:`os.replace`.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from ..atomic import atomic_write
from ..progress import StagedProgress
from .writer import compose, module_parts

__all__ = ["generate_module", "render_module"]


def render_module(equations: Any, source_hash: str, *, cse: bool = True,
                  sensitivities: bool = False, progress: StagedProgress = None) -> str:
    """The complete source text of the generated module.

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

    Raises
    ------
    GenerationError
        When the equations cannot be turned into code.
    """
    if getattr(equations, "elastic", None) is not None:
        # here: the elastic composition embeds the NumPy kernel (neweul_py.ffrf), which a
        # rigid model never imports
        from .elastic import elastic_module_parts

        return compose(elastic_module_parts(equations, source_hash, cse=cse, progress=progress))
    return compose(module_parts(equations, source_hash, cse=cse, directional=sensitivities,
                                progress=progress))


def generate_module(
    equations: Any, source_hash: str, path: str | os.PathLike[str], *, cse: bool = True,
    sensitivities: bool = False, progress: StagedProgress = None,
) -> Path:
    """Render the module for ``equations`` and write it atomically to ``path``
    (``sensitivities``: as :func:`render_module`).

    Returns
    -------
    Path
        ``path``. If rendering fails nothing is written and an existing file is untouched.

    Examples
    --------
    >>> generate_module(newton_euler(load_description("examples/pendulum.yaml")),
    ...                 description_hash(b"..."), "generated/pendulum.py")  # doctest: +SKIP
    """
    text = render_module(equations, source_hash, cse=cse, sensitivities=sensitivities,
                         progress=progress)
    return atomic_write(path, text)
