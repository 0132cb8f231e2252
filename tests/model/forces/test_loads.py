"""What force elements see of the kinematics (``neweul_py/model/forces/loads.py``).

Reference: the members declared by the protocol ``KinematicsView``, looked up on the
kinematics the equations layer passes in.
"""

from __future__ import annotations

import inspect

from neweul_py.kinematics import absolute_kinematics
from neweul_py.model import Coordinate, Frame, System, symbol
from neweul_py.model.forces.loads import KinematicsView


def test_kinematics_offer_every_member_of_the_protocol() -> None:
    """Every attribute and method the loads may use exists on real kinematics."""
    system = System("k", coordinates=(Coordinate("a"),),
                    frames=(Frame("f", rotation=(("z", symbol("a")),)),))
    kin = absolute_kinematics(system)
    members = {n for n, _ in inspect.getmembers(KinematicsView) if not n.startswith("_")}
    members |= set(KinematicsView.__annotations__)
    assert members
    missing = sorted(m for m in members if not hasattr(kin, m))
    assert not missing, missing
