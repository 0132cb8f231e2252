"""The description keys of loss factors (docs/description-format.md: ``loss_factor`` of
``spring_damper``, ``rotational_spring_damper`` and ``bushing``; the model's
``loss_reference_frequency``): what they load into, and one error naming the key for each
kind of bad input."""

from __future__ import annotations

import pytest
import sympy as sp

from neweul_py.description import load_description_text
from neweul_py.errors import DescriptionError

BASE = """
name: lossy
{top}
parameters: {{m: 1.0, k: 100.0, eta: {eta_default}}}
coordinates: {{x: {{}}, r: {{}}}}
frames: {{b: {{translation: [x, 0, 0]}}}}
bodies: {{mass: {{frame: b, mass: m, inertia: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}}}}
forces:
  spring: {{type: spring_damper, between: [ISYS, b], points: [[-1, 0, 0], [0, 0, 0]],
            length: 1, stiffness: k, loss_factor: {eta}}}
  bush: {{type: bushing, between: [ISYS, b], stiffness: k, loss_factor: 0.2}}
  twist: {{type: rotational_spring_damper, coordinate: r, stiffness: k, loss_factor: 0.3}}
"""


def _load(eta: object = "eta", top: str = "", eta_default: float = 0.1):
    return load_description_text(BASE.format(eta=eta, top=top, eta_default=eta_default),
                                 "lossy.yaml")


def test_loss_keys_load_into_the_model() -> None:
    """Reference: the values written in the description (default reference frequency
    1000 Hz, docs/description-format.md)."""
    s = _load()
    forces = {f.name: f for f in s.forces}
    assert forces["spring"].loss_factor == sp.Symbol("eta", real=True) or str(
        forces["spring"].loss_factor) == "eta"
    assert float(forces["bush"].loss_factor) == 0.2
    assert float(forces["twist"].loss_factor) == 0.3
    assert s.loss_reference_frequency == 1000.0
    assert _load(top="loss_reference_frequency: 250").loss_reference_frequency == 250.0


@pytest.mark.parametrize(
    ("kwargs", "key", "words"),
    [
        ({"eta": "-0.1"}, "forces.spring.loss_factor", "≥ 0"),
        ({"eta": ".nan"}, "forces.spring.loss_factor", "finite"),
        ({"eta": "zeta"}, "forces.spring.loss_factor", "unknown name 'zeta'"),
        ({"eta": "x"}, "forces.spring.loss_factor", "coordinate"),
        ({"eta_default": -0.5}, "forces.spring.loss_factor", "parameter defaults"),
        ({"top": "loss_reference_frequency: -5"}, "loss_reference_frequency", "positive"),
        ({"top": "loss_reference_frequency: .inf"}, "loss_reference_frequency", "finite"),
        ({"top": "loss_reference_frequency: fast"}, "loss_reference_frequency", ""),
    ],
)
def test_bad_loss_input_is_one_error_naming_the_key(kwargs: dict, key: str, words: str) -> None:
    """Reference: the house rule — bad input is one DescriptionError naming the key path
    (and its line)."""
    with pytest.raises(DescriptionError) as exc:
        _load(**kwargs)
    assert exc.value.key_path == key
    assert words in exc.value.message
    assert exc.value.line is not None


def test_loss_factor_only_where_there_is_a_stiffness() -> None:
    """Reference: a force or torque has no stiffness, so ``loss_factor`` is an unknown key
    there (the error lists the valid keys)."""
    text = BASE.format(eta="eta", top="", eta_default=0.1) + (
        "  push: {type: force, frame: b, vector: [1, 0, 0], loss_factor: 0.1}\n")
    with pytest.raises(DescriptionError) as exc:
        load_description_text(text, "lossy.yaml")
    assert exc.value.key_path == "forces.push.loss_factor"
