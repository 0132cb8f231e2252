"""neweul-py: symbolic-to-numeric equations of motion for elastic multibody systems.

The pipeline runs one way: description → model → kinematics → equations → codegen → generated module
→ analysis (``docs/architecture.md``). ``elastic`` and ``fem`` are numeric libraries (NumPy/SciPy
only) that produce reduced elastic-body data.
"""

from typing import TYPE_CHECKING, Any

from .errors import (
    DataError,
    DescriptionError,
    GenerationError,
    ModelError,
    NeweulError,
    SolverError,
)
from .version import installed_version

if TYPE_CHECKING:
    from .api import load_description
    from .description import SystemBuilder

#: Names re-exported lazily from the symbolic layers, so that ``import neweul_py.analysis``
#: (NumPy/SciPy only, ``docs/architecture.md``) does not import sympy through this package.
#: ``load_description`` comes from ``api``, which reads elastic-body data files by default.
_LAZY = {"SystemBuilder": ".description", "load_description": ".api"}


def __getattr__(name: str) -> Any:
    if name == "__version__":  # read once, when asked: importlib.metadata costs ~50 ms
        value = globals()["__version__"] = installed_version()
        return value
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

__all__ = [
    "DataError",
    "DescriptionError",
    "GenerationError",
    "ModelError",
    "NeweulError",
    "SolverError",
    "SystemBuilder",
    "__version__",
    "load_description",
]
