"""Fixtures of the analysis tests: hand-written protocol modules (see fixtures/README.md) and
the models of the sensitivity tests, generated with their second derivatives."""

from __future__ import annotations

from pathlib import Path

import pytest
from _analysis_helpers import load_fixture

from neweul_py.analysis.module import load_generated
from neweul_py.api import generate

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def two_mass():
    return load_fixture("two_mass")


@pytest.fixture(scope="session")
def spring_pendulum():
    return load_fixture("spring_pendulum")


@pytest.fixture(scope="session")
def cartesian_pendulum():
    return load_fixture("cartesian_pendulum")


@pytest.fixture(scope="session")
def cart_pendulum():
    return load_fixture("cart_pendulum")


@pytest.fixture(scope="session")
def slider_crank():
    return load_fixture("slider_crank")


# ----------------------------------------------------------------- parameter sensitivities
OSCILLATOR = """\
name: oscillator
parameters: {m: 2.0, k: 800.0, c: 4.0}
coordinates: {x: 0.0}
inputs: {F: 0}
frames:
  cart: {translation: [x, 0, 0]}
bodies:
  mass: {frame: cart, mass: m}
forces:
  spring: {type: generalized, coordinate: x, value: -k*x - c*d_x + F}
"""

#: A pendulum under gravity with a torsion spring and a constant torque T: its equilibrium
#: angle, and through it the stiffness k + m g l cos φ₀, depend on T.
PRELOADED = """\
name: preloaded
parameters: {m: 1.5, l: 0.4, g: 9.81, k: 3.0, T: 2.0, d: 0.05}
gravity: [0, 0, -g]
coordinates: {phi: 0.0}
inputs: {M: 0}
frames:
  rod: {rotation: [[y, phi]]}
bodies:
  bob: {frame: rod, mass: m, center_of_mass: [0, 0, -l]}
forces:
  spring: {type: generalized, coordinate: phi, value: -k*phi - d*d_phi + T + M}
outputs:
  x_bob: {position: rod, point: [0, 0, -l], component: x}
"""


@pytest.fixture(scope="session")
def sensitivity_models(tmp_path_factory):
    """The modules of the test descriptions and of two examples, generated with the
    directional derivatives (``sensitivities=True``)."""
    tmp = tmp_path_factory.mktemp("sens")
    (tmp / "osc.yaml").write_text(OSCILLATOR)
    (tmp / "pre.yaml").write_text(PRELOADED)
    paths = {"oscillator": tmp / "osc.yaml", "preloaded": tmp / "pre.yaml",
             "pendulum": ROOT / "examples" / "pendulum.yaml",
             "quarter_car": ROOT / "examples" / "quarter_car.yaml"}
    return {k: load_generated(generate(v, tmp / k, sensitivities=True))
            for k, v in paths.items()}


@pytest.fixture
def oscillator(sensitivity_models):
    return sensitivity_models["oscillator"]


@pytest.fixture
def preloaded(sensitivity_models):
    return sensitivity_models["preloaded"]
