"""Model layer: plain, validated, immutable model objects. Imports no other layer."""

from .elements import (
    AXES,
    Coordinate,
    ExpressionOutput,
    ForceElement,
    Frame,
    GeneralizedForce,
    Input,
    KinematicOutput,
    Output,
    Parameter,
    PointForce,
    RigidBody,
    SpringDamper,
    Torque,
    vector3,
)
from .symbols import INERTIAL, RESERVED_NAMES, check_name, symbol, time, velocity_name
from .system import System

__all__ = [
    "AXES",
    "INERTIAL",
    "RESERVED_NAMES",
    "Coordinate",
    "ExpressionOutput",
    "ForceElement",
    "Frame",
    "GeneralizedForce",
    "Input",
    "KinematicOutput",
    "Output",
    "Parameter",
    "PointForce",
    "RigidBody",
    "SpringDamper",
    "System",
    "Torque",
    "check_name",
    "symbol",
    "time",
    "vector3",
    "velocity_name",
]
