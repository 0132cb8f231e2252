"""The poses of the frames: where every frame is and how it is turned (equations.md §1).

For a frame K with parent P, relative origin ``r_K`` (P components) and relative rotation
``A_K`` (K → P components), the absolute pose in ISYS components follows parent → child:

```
S_K = S_P A_K                  (K components → ISYS components)
r_K = r_P + S_P r_K,rel        (origin of K from the origin of ISYS)
```

These are the quantities :meth:`~neweul_py.kinematics.Kinematics.rotation_matrix` and
:meth:`~neweul_py.kinematics.Kinematics.origin` already form (in recursive form as
intermediates). They do not enter the equations of motion; code generation prints them as the
protocol function ``frame_poses`` that animations and post-processing read
(docs/generated-module-protocol.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..kinematics import Kinematics

__all__ = ["FramePoses", "frame_poses"]


@dataclass(frozen=True)
class FramePoses:
    """Absolute poses of the frames of a system (module docstring).

    Attributes
    ----------
    frames
        Frame names (without ISYS), parents before children (``System.frames_topological``).
    parents
        The parent of each frame (``"ISYS"`` for the first level).
    positions
        (nF, 3): row ``i`` is ``r`` of frame ``i``, ISYS components.
    rotations
        (nF, 9): row ``i`` is ``S`` of frame ``i`` row-major (frame components → ISYS).
    """

    frames: tuple[str, ...]
    parents: tuple[str, ...]
    positions: sp.ImmutableMatrix
    rotations: sp.ImmutableMatrix

    def substituted(self, values: dict[sp.Symbol, sp.Expr]) -> FramePoses:
        """The same poses with the intermediates ``values`` substituted."""
        return FramePoses(self.frames, self.parents,
                          self.positions.xreplace(values), self.rotations.xreplace(values))


def frame_poses(kin: Kinematics) -> FramePoses:
    """The poses ``(r_K, S_K)`` of every frame of ``kin.system`` (module docstring).

    In recursive form the entries are intermediates appended to ``kin.workspace`` (after
    everything the equations need, so the other functions' code is unchanged).

    Examples
    --------
    >>> from neweul_py.kinematics import absolute_kinematics
    >>> from neweul_py.model import Coordinate, Frame, System, symbol
    >>> s = System("p", coordinates=(Coordinate("a"),),
    ...            frames=(Frame("f", rotation=(("z", symbol("a")),)),))
    >>> frame_poses(absolute_kinematics(s)).rotations[0, :2]
    Matrix([[cos(a), -sin(a)]])
    """
    frames = kin.system.frames_topological
    nf = len(frames)
    positions: list[sp.Expr] = []
    rotations: list[sp.Expr] = []
    for frame in frames:
        positions += list(kin.origin(frame.name))
        rotations += [x for row in kin.rotation_matrix(frame.name) for x in row]
    return FramePoses(
        frames=tuple(f.name for f in frames),
        parents=tuple(f.parent for f in frames),
        positions=sp.ImmutableMatrix(nf, 3, positions),
        rotations=sp.ImmutableMatrix(nf, 9, rotations),
    )
