"""Zero-length springs (neweul_py/equations/force_elements.py; issue 12 item 6) and the
documented rule of docs/description-format.md.

Reference: the force of a linear spring of rest length 0, ``F e = k d``, is defined at
``d = 0`` (closed form: the generated force is ``−k x``); with a rest length or damping the
direction ``e = d/|d|`` is undefined where the points meet.
"""

from __future__ import annotations

import numpy as np
import pytest

from neweul_py.cli import main

BASE = """name: zl
parameters: {m: 1.0, k: 100.0, c: 1.0, L: 0.1}
coordinates:
  x: {initial: 0.0, velocity: 0.0}
frames:
  cart: {parent: ISYS, translation: [x, 0, 0]}
bodies:
  b: {frame: cart, mass: m}
forces:
  s: {type: spring_damper, between: [BETWEEN], stiffness: k, LAW}
"""


def _write(tmp_path, between: str, law: str):
    path = tmp_path / "zl.yaml"
    path.write_text(BASE.replace("BETWEEN", between).replace("LAW", law))
    return str(path)


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))


@pytest.mark.parametrize("law", ["damping: c", "length: L", "damping: c, length: L"])
def test_points_that_always_coincide_are_refused_at_load(tmp_path, capsys, law):
    desc = _write(tmp_path, "cart, cart", law)
    for command in (["generate", desc, "-o", str(tmp_path / "g")], ["equilibrium", desc]):
        assert main(command) == 1
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "forces.s.points" in err and "coincide" in err
        assert "zl.yaml" in err


@pytest.mark.parametrize("command", [["simulate", "--t-end", "1"], ["equilibrium"],
                                     ["linearize", "--at", "initial"], ["modes"]])
def test_points_that_meet_at_the_start_give_one_error(tmp_path, capsys, command):
    """Points that coincide at the initial state with a rest length: the division by zero
    (ZeroDivisionError in the generated module) becomes one error line."""
    desc = _write(tmp_path, "ISYS, cart", "damping: c, length: L")
    assert main([command[0], desc, *command[1:]]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "ZeroDivisionError" in err and "Traceback" not in err


def test_linear_zero_length_spring_is_regular_at_zero(tmp_path):
    """No rest length, no damping: F e = k d, finite at d = 0 (the rule of the docs)."""
    from neweul_py.api import load_description_module

    module = load_description_module(_write(tmp_path, "ISYS, cart", "length: 0"))
    p = module.default_parameters()
    for x in (0.0, 0.2):
        f = module.force_vector(0.0, np.array([x]), np.array([0.0]), p)
        assert np.allclose(f, [-100.0 * x])
