"""Loading generated modules by path and checking them against the protocol.

The analysis layer never imports sympy or the symbolic layers; it works on modules written by
``neweul generate`` through the generated-module protocol (docs/generated-module-protocol.md).
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

from ..errors import NeweulError

__all__ = ["SUPPORTED_PROTOCOL_VERSIONS", "check_protocol", "load_generated"]

#: Protocol versions this package can read.
SUPPORTED_PROTOCOL_VERSIONS = (1,)

_CONSTANTS: dict[str, type | tuple[type, ...]] = {
    "PROTOCOL_VERSION": int,
    "MODEL_NAME": str,
    "COORDINATES": list,
    "INITIAL_STATE": list,
    "PARAMETERS": dict,
    "INPUTS": list,
    "OUTPUTS": list,
    "CONSTRAINTS": list,
    "STATE_SIZE": int,
    "SOURCE_HASH": str,
    "MASS_MATRIX_SYMMETRIC": bool,
}
_FUNCTIONS = (
    "default_parameters",
    "default_inputs",
    "mass_matrix",
    "force_vector",
    "rhs",
    "force_jacobians",
    "mass_matrix_times_derivative",
    "rhs_jacobian",
    "outputs",
    "output_jacobians",
    "constraints",
    "constraint_jacobian",
    "constraint_gamma",
)


def check_protocol(module: Any, where: str | None = None) -> None:
    """Raise :class:`NeweulError` unless ``module`` implements the generated-module protocol.

    Checks the presence and types of the constants, their consistency (``STATE_SIZE`` ≥ 2n,
    ``INITIAL_STATE`` of length ``STATE_SIZE``, string names) and that the functions exist.
    """
    where = where or getattr(module, "__file__", None) or getattr(module, "__name__", "module")
    for name, kind in _CONSTANTS.items():
        if not hasattr(module, name):
            raise NeweulError(
                f"{where}: not a generated module (missing {name}; see "
                "docs/generated-module-protocol.md)"
            )
        if not isinstance(getattr(module, name), kind) or (
            kind is int and isinstance(getattr(module, name), bool)
        ):
            raise NeweulError(f"{where}: {name} has the wrong type")
    if module.PROTOCOL_VERSION not in SUPPORTED_PROTOCOL_VERSIONS:
        raise NeweulError(
            f"{where}: protocol version {module.PROTOCOL_VERSION} is not supported (this "
            f"neweul-py reads {', '.join(map(str, SUPPORTED_PROTOCOL_VERSIONS))}); regenerate it"
        )
    n = len(module.COORDINATES)
    for name in ("COORDINATES", "INPUTS", "OUTPUTS", "CONSTRAINTS"):
        if not all(isinstance(s, str) for s in getattr(module, name)):
            raise NeweulError(f"{where}: {name} must hold names (strings)")
    if module.STATE_SIZE < 2 * n or len(module.INITIAL_STATE) != module.STATE_SIZE:
        raise NeweulError(
            f"{where}: STATE_SIZE {module.STATE_SIZE} does not fit {n} coordinates and an "
            f"initial state of length {len(module.INITIAL_STATE)}"
        )
    missing = [f for f in _FUNCTIONS if not callable(getattr(module, f, None))]
    if missing:
        raise NeweulError(f"{where}: not a generated module (missing {', '.join(missing)})")


def load_generated(path: str | os.PathLike[str]) -> ModuleType:
    """Import the generated module at ``path`` and validate its protocol constants.

    The module is imported under a private name derived from the file's content
    (``neweul_generated_<name>_<sha>``), so loading two different files with the same model name,
    or a regenerated file, never returns a stale module.

    Parameters
    ----------
    path
        A ``.py`` file written by ``neweul generate``.

    Returns
    -------
    module
        The imported module.

    Raises
    ------
    NeweulError
        If the file is missing, cannot be imported, or does not implement the protocol.

    Examples
    --------
    >>> mod = load_generated("generated/pendulum.py")  # doctest: +SKIP
    >>> mod.rhs(0.0, mod.INITIAL_STATE, mod.default_parameters())  # doctest: +SKIP
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise NeweulError(f"{path}: cannot read generated module ({exc.strerror})") from None
    digest = hashlib.sha256(raw).hexdigest()[:16]
    stem = "".join(c if c.isalnum() else "_" for c in path.stem)
    name = f"neweul_generated_{stem}_{digest}"
    if name in sys.modules:
        module = sys.modules[name]
    else:
        spec = importlib.util.spec_from_file_location(name, path)
        if spec is None or spec.loader is None:
            raise NeweulError(f"{path}: cannot be imported as a Python module")
        module = importlib.util.module_from_spec(spec)
        try:
            spec.loader.exec_module(module)
        except Exception as exc:
            raise NeweulError(
                f"{path}: importing the generated module failed: {type(exc).__name__}: {exc}"
            ) from None
        sys.modules[name] = module
    check_protocol(module, str(path))
    return module
