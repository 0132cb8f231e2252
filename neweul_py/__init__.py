"""neweul-py: symbolic-to-numeric equations of motion for elastic multibody systems.

The pipeline runs one way: description → model → kinematics → equations → codegen →
generated module → analysis (see DESIGN.md). ``elastic`` and ``fem`` are numeric libraries
(NumPy/SciPy only) that produce reduced elastic-body data.
"""

from .description import SystemBuilder, load_description
from .errors import (
    DataError,
    DescriptionError,
    GenerationError,
    ModelError,
    NeweulError,
    SolverError,
)

__version__ = "0.1.0"

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
