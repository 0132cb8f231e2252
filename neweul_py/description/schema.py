"""Key schemas of description mappings and the entries of a section (shared by the loaders).

Every section loader (:mod:`.loader`, :mod:`~neweul_py.description.elastic`) checks the keys
of its mappings with :class:`Schema`, so that an unknown or missing key is one
:class:`~neweul_py.errors.ModelError` naming the key path.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..errors import ModelError

__all__ = ["Schema", "section_items"]


@dataclass(frozen=True)
class Schema:
    """The keys a mapping may have."""

    required: tuple[str, ...] = ()
    optional: tuple[str, ...] = ()

    @property
    def keys(self) -> tuple[str, ...]:
        return self.required + self.optional

    def check(self, value: object, path: str, what: str) -> dict[str, Any]:
        """Return ``value`` as a dict after checking its keys, else raise ModelError."""
        if value is None:
            value = {}
        if not isinstance(value, dict):
            raise ModelError(
                f"{what} must be a mapping with keys {', '.join(self.keys)}; got "
                f"{type(value).__name__} {value!r}",
                path,
            )
        for key in value:
            if key not in self.keys:
                raise ModelError(
                    f"unknown key {key!r} in {what}; valid keys are: {', '.join(self.keys)}",
                    f"{path}.{key}" if path else key,
                )
        missing = [k for k in self.required if k not in value]
        if missing:
            raise ModelError(
                f"{what} is missing the key{'s' if len(missing) > 1 else ''} "
                f"{', '.join(repr(k) for k in missing)}",
                path,
            )
        return value


def section_items(value: object, path: str, what: str) -> list[tuple[str, Any]]:
    """The entries of a section mapping (``None``, an empty section, has none)."""
    if value is None:
        return []
    if not isinstance(value, dict):
        raise ModelError(
            f"{path} must be a mapping of {what}, got {type(value).__name__} {value!r}", path
        )
    return list(value.items())


