"""Equations layer: Newton–Euler equations with Jacobian matrices (equations.md §1) and their
symbolic Jacobians for linearization.

Imports ``kinematics`` and ``model`` only.
"""

from .linearization import (
    Derivatives,
    force_jacobians,
    jacobian,
    mass_matrix_times_derivative,
    output_jacobians,
)
from .newton_euler import AUTO_CLOSED_MAX, clear_cache, newton_euler
from .poses import FramePoses, frame_poses
from .result import Equations

__all__ = [
    "AUTO_CLOSED_MAX",
    "Derivatives",
    "Equations",
    "FramePoses",
    "clear_cache",
    "force_jacobians",
    "frame_poses",
    "jacobian",
    "mass_matrix_times_derivative",
    "newton_euler",
    "output_jacobians",
]
