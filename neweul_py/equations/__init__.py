"""Equations layer: Newton–Euler equations with Jacobian matrices (equations.md §1).

Imports ``kinematics`` and ``model`` only.
"""

from .result import Equations

__all__ = ["Equations"]
