"""The version of the installed distribution (``neweul_py.__version__``, ``neweul --version``,
the ``generationTool`` of an exported FMU)."""

from __future__ import annotations

import functools

__all__ = ["installed_version"]


@functools.cache
def installed_version() -> str:
    """The version of the installed distribution (its metadata, set from pyproject.toml);
    ``0+unknown`` when the package runs from a tree that was never installed. Read once:
    :mod:`importlib.metadata` costs about 50 ms."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("neweul-py")
    except PackageNotFoundError:
        return "0+unknown"
