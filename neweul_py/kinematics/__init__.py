"""Kinematics layer: rotations, absolute kinematics and Jacobians of the frame tree
(equations.md §1). Imports ``model`` (and ``errors``) only."""

from .absolute import FrameKinematics, Kinematics, PointKinematics, absolute_kinematics
from .rotations import elementary_rotation, rotation_axes, rotation_product, rotation_rates
from .workspace import Workspace, is_atomic

__all__ = [
    "FrameKinematics",
    "Kinematics",
    "PointKinematics",
    "Workspace",
    "absolute_kinematics",
    "elementary_rotation",
    "is_atomic",
    "rotation_axes",
    "rotation_product",
    "rotation_rates",
]
