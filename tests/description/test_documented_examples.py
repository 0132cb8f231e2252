"""The force, input and constraint keys of the description format: the documented example
loads and builds the model objects it describes (reference: docs/description-format.md,
second example)."""

from __future__ import annotations

import pathlib

import sympy as sp

from neweul_py.description import load_description_text
from neweul_py.model import (
    Bushing,
    CoincidenceConstraint,
    ExpressionConstraint,
    ForceOutput,
    PlaneContact,
    RotationalSpringDamper,
    SpringDamper,
    TableCurve,
)

HEADER = """\
name: documented
parameters: {k: 100, c: 1, kx: 1, ky: 2, kz: 3, d: 0.1, s1: 0.1, l0: 0.5, use_stop: 1,
             r: 0.1, l: 0.3, lam: 5}
coordinates: {phi: 0.3, theta: -0.1, xs: 0.39, x: 0.6}
frames:
  frameA: {}
  frameB: {translation: [0, 0, x]}
  arm: {rotation: [[y, phi]]}
  link: {parent: arm, translation: [1, 0, 0], rotation: [[y, theta]]}
  cart: {translation: [x, 0, 0]}
  crank: {rotation: [[y, -phi]]}
  rod: {translation: [xs, 0, 0], rotation: [[y, -theta]]}
  ball: {translation: [0, 0, x]}
"""


def test_the_documented_issue4_example_loads() -> None:
    doc = pathlib.Path(__file__).parents[2] / "docs" / "description-format.md"
    block = doc.read_text().split("```yaml\n")[2].split("```", 1)[0]
    s = load_description_text(HEADER + block, "doc.yaml")
    kinds = {f.name: type(f) for f in s.forces}
    assert kinds == {"bush": Bushing, "hinge": RotationalSpringDamper,
                     "hinge2": RotationalSpringDamper, "progressive": SpringDamper,
                     "stop": SpringDamper, "ground": PlaneContact}
    stop = next(f for f in s.forces if f.name == "stop")
    assert isinstance(stop.spring_force, TableCurve) and stop.enabled == sp.Symbol(
        "use_stop", real=True)
    assert [type(c) for c in s.constraints] == [ExpressionConstraint, CoincidenceConstraint]
    assert s.constraint_names == ("closure", "pin_x", "pin_z")
    reported = [o.name for o in s.outputs if isinstance(o, ForceOutput)]
    assert reported == ["stop_force", "spring_f", "bush_fy"]
