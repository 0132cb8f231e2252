"""Equations layer: Newton–Euler equations with Jacobian matrices (equations.md §1) and every
symbolic derivative of them that a generated module evaluates (:mod:`.jacobians`, by the chain
rule of :mod:`.derivatives`).

Imports ``kinematics`` and ``model`` only.
"""

from .derivatives import gradient, jacobian
from .jacobians import (
    Derivatives,
    Program,
    force_jacobians,
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
    "Program",
    "clear_cache",
    "force_jacobians",
    "frame_poses",
    "gradient",
    "jacobian",
    "mass_matrix_times_derivative",
    "newton_euler",
    "output_jacobians",
]
