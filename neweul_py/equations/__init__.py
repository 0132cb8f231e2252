"""Equations layer: Newton–Euler equations with Jacobian matrices (equations.md §1).

Imports ``kinematics`` and ``model`` only.
"""

from .newton_euler import AUTO_CLOSED_MAX, clear_cache, newton_euler
from .result import Equations

__all__ = ["AUTO_CLOSED_MAX", "Equations", "clear_cache", "newton_euler"]
