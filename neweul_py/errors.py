"""The exception hierarchy of neweul-py.

Every error a user can act on is a :class:`NeweulError`; the CLI catches it and prints one line.
Anything else escaping the package is a bug and keeps its traceback.
"""

from __future__ import annotations

from collections.abc import Sequence

__all__ = [
    "DataError",
    "DescriptionError",
    "GenerationError",
    "ModelError",
    "NeweulError",
    "SolverError",
]


class NeweulError(Exception):
    """Base class of all errors a user of neweul-py can act on."""


class ModelError(NeweulError):
    """An invalid model (built in Python or from a description file).

    Parameters
    ----------
    message
        What is wrong, in words a user understands.
    key_path
        Where in the model it is wrong, as a dotted key path such as
        ``bodies.malleus.inertia[1][2]`` (empty when it concerns the whole model).
    """

    def __init__(self, message: str, key_path: str = "") -> None:
        self.message = message
        self.key_path = key_path
        super().__init__(self._format())

    def _format(self) -> str:
        return f"{self.key_path}: {self.message}" if self.key_path else self.message


class DescriptionError(ModelError):
    """An error in a description file, naming the file, the key path and (where known) the line."""

    def __init__(
        self, message: str, key_path: str = "", file: str | None = None, line: int | None = None
    ) -> None:
        self.file = file
        self.line = line
        super().__init__(message, key_path)

    def _format(self) -> str:
        where = self.file or "<description>"
        if self.line is not None:
            where += f":{self.line}"
        if self.key_path:
            where += f": {self.key_path}"
        return f"{where}: {self.message}"


class GenerationError(NeweulError):
    """Code generation failed (nothing previously generated has been touched)."""


class DataError(NeweulError):
    """An FE-model, reduced-body or SID file (or array) is malformed.

    Parameters
    ----------
    message
        What is wrong.
    file
        The file concerned, if any.
    item
        The matrix, table or block concerned (``"K"``, ``"dofs"``, ``"Ct"``, ...).
    line
        The line in a text file, where known.
    """

    def __init__(
        self,
        message: str,
        file: str | None = None,
        item: str | None = None,
        line: int | None = None,
    ) -> None:
        self.message = message
        self.file = file
        self.item = item
        self.line = line
        parts = []
        if file:
            parts.append(f"{file}:{line}" if line is not None else str(file))
        if item:
            parts.append(item)
        parts.append(message)
        super().__init__(": ".join(parts))


class SolverError(NeweulError):
    """A numerical solver failed; carries the last iterate and its residual.

    Parameters
    ----------
    message
        What failed.
    last_iterate
        The last iterate of the solver (e.g. coordinates of a Newton iteration).
    residual
        The residual norm (or vector) at the last iterate.
    names
        Optional names of the entries of ``last_iterate``.
    """

    def __init__(
        self,
        message: str,
        last_iterate: object = None,
        residual: object = None,
        names: Sequence[str] | None = None,
    ) -> None:
        self.message = message
        self.last_iterate = last_iterate
        self.residual = residual
        self.names = list(names) if names is not None else None
        super().__init__(message)
