"""Limits of the YAML reader (neweul_py/yaml_tree.py).

References: inputs that would otherwise end in a RecursionError, an OverflowError or a
TypeError traceback; IEEE 754 doubles end at 2¹⁰²⁴ ≈ 1.8e308.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from neweul_py.description import load_description_text
from neweul_py.errors import DescriptionError
from neweul_py.yaml_tree import MAX_DEPTH, read_yaml

PENDULUM = (Path(__file__).resolve().parents[1] / "examples" / "pendulum.yaml").read_text()


@pytest.mark.parametrize("nest", ["[" * 2000 + "]" * 2000, "{a: " * 2000 + "1" + "}" * 2000])
def test_deep_nesting_is_one_error(nest):
    with pytest.raises(DescriptionError, match=f"nested more than {MAX_DEPTH} levels"):
        load_description_text(PENDULUM + f"extra: {nest}\n", "deep.yaml")


def test_nesting_within_the_limit_is_read():
    tree = read_yaml("a: " + "[" * (MAX_DEPTH - 1) + "]" * (MAX_DEPTH - 1) + "\n")  # + the map
    assert isinstance(tree.data["a"], list)


def test_integer_beyond_double_range():
    text = PENDULUM.replace("m: 1.0 ", "m: " + "9" * 400 + " ")
    with pytest.raises(DescriptionError, match="beyond the range") as info:
        load_description_text(text, "big.yaml")
    assert info.value.key_path == "parameters.m" and info.value.line == 7


def test_unhashable_force_type():
    with pytest.raises(DescriptionError, match="unknown force type"):
        load_description_text(PENDULUM + "forces:\n  s: {type: [force]}\n", "t.yaml")


def test_huge_inertia_is_checked_without_overflow():
    """diag 1e308 made eigvalsh fail (LinAlgError): the tensor is scaled first."""
    text = PENDULUM.replace("    mass: m\n",
                            "    mass: m\n    inertia: {diag: [1e308, 1e308, 1e308]}\n")
    system = load_description_text(text, "i.yaml")
    assert system.bodies[0].name == "bob"
    bad = PENDULUM.replace("    mass: m\n", "    mass: m\n    inertia: {diag: [1e308, 1, 1]}\n")
    with pytest.raises(DescriptionError, match="triangle inequality"):
        load_description_text(bad, "i.yaml")
