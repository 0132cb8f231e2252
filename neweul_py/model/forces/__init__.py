"""Force elements: one class per element, each in one module, carrying its description keys,
the expressions it reads, its loads and its potential (:mod:`.base`).

A new element is a module here with one :class:`ForceElement` subclass and its entry in
:data:`FORCE_ELEMENTS`; the description layer (keys), the model's validation (names) and the
equations (loads, potential) read everything else from the class.
"""

from collections.abc import Mapping

from .applied import GeneralizedForce, PointForce, Torque
from .base import ENABLED, LOSS_FACTOR, ForceElement, Key, ValueKind
from .bushing import Bushing
from .characteristic import (
    ELONGATION,
    ELONGATION_RATE,
    characteristic_force,
    table_characteristic,
)
from .contact import PlaneContact
from .loads import KinematicsView, Loads
from .rotational import RotationalSpringDamper
from .spring_damper import SpringDamper

__all__ = [
    "ELONGATION",
    "ELONGATION_RATE",
    "ENABLED",
    "FORCE_COMPONENTS",
    "FORCE_ELEMENTS",
    "FORCE_TYPES",
    "LOSS_FACTOR",
    "Bushing",
    "ForceElement",
    "GeneralizedForce",
    "Key",
    "KinematicsView",
    "Loads",
    "PlaneContact",
    "PointForce",
    "RotationalSpringDamper",
    "SpringDamper",
    "Torque",
    "ValueKind",
    "characteristic_force",
    "table_characteristic",
]

#: Every force element, in the order the description format lists their types.
FORCE_ELEMENTS: tuple[type[ForceElement], ...] = (
    PointForce,
    Torque,
    GeneralizedForce,
    SpringDamper,
    RotationalSpringDamper,
    Bushing,
    PlaneContact,
)
#: The element of each description ``type``.
FORCE_TYPES: Mapping[str, type[ForceElement]] = {e.type_name: e for e in FORCE_ELEMENTS}
#: Components an output may take of each kind of force element (see
#: :class:`~neweul_py.model.ForceOutput`), by class name.
FORCE_COMPONENTS: Mapping[str, tuple[str, ...]] = {e.__name__: e.components
                                                    for e in FORCE_ELEMENTS}
