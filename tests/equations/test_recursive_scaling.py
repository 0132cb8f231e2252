"""Size of the recursive (semi-symbolic) form (docs/architecture.md, "Rigid bodies").

Reference: the structure of the recursion itself — every assignment and every entry of M and
q − k has a size bounded independently of the chain length, and the total operation count of
the N-link planar chain grows like N² (Jacobian columns × frames), not faster. Counts, not
wall-clock times, so the test is machine-independent.
"""

from __future__ import annotations

import sympy as sp

from neweul_py.equations import newton_euler
from neweul_py.model import Coordinate, Frame, Parameter, RigidBody, System, symbol


def planar_chain(n: int) -> System:
    frames, bodies, params = [], [], [Parameter("g", 9.81)]
    for i in range(n):
        m, l = symbol(f"m{i}"), symbol(f"l{i}")
        params += [Parameter(f"m{i}", 1.0), Parameter(f"l{i}", 1.0)]
        origin = [0, 0, 0] if i == 0 else [symbol(f"l{i - 1}"), 0, 0]
        frames.append(Frame(f"link{i}", "ISYS" if i == 0 else f"link{i - 1}",
                            sp.ImmutableMatrix(origin), (("z", symbol(f"q{i}")),)))
        bodies.append(RigidBody(f"rod{i}", f"link{i}", m, sp.ImmutableMatrix([l / 2, 0, 0]),
                                sp.ImmutableMatrix(sp.diag(0, m * l**2 / 12, m * l**2 / 12))))
    return System(f"chain{n}", coordinates=tuple(Coordinate(f"q{i}") for i in range(n)),
                  parameters=tuple(params), frames=tuple(frames), bodies=tuple(bodies),
                  gravity=sp.ImmutableMatrix([0, -symbol("g"), 0]))


def _sizes(n: int) -> tuple[int, int]:
    eq = newton_euler(planar_chain(n), form="recursive")
    exprs = [e for _, e in eq.intermediates] + list(eq.mass_matrix) + list(eq.force_vector)
    return max(sp.count_ops(e) for e in exprs), sp.count_ops(exprs)


def test_recursive_form_has_bounded_assignments_and_quadratic_total() -> None:
    largest_5, total_5 = _sizes(5)
    largest_15, total_15 = _sizes(15)
    assert largest_15 == largest_5  # no expression grows with the chain
    assert total_15 <= 1.2 * (15 / 5) ** 2 * total_5  # ~N², not N³ or exponential
