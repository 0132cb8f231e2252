"""What an FMU declares (codegen/fmu_model.py): refusals, units, the model header.

References: the rules of docs/fmu-export.md (what cannot be exported), the SI base units of
the FMI 2.0 UnitDefinitions (FMI 2.0 §2.2.2: ``N = kg m s⁻²``), and the value-reference
layout the FMI layer ``fmi2/neweul_fmi2.c`` reads.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from neweul_py.codegen.blocks import input_units, units
from neweul_py.codegen.fmu_model import (
    export_problems,
    fmu_model,
    model_description,
    model_header,
)
from neweul_py.description import load_description_text

DRIVEN = """
name: driven
parameters: {m: 1.0, k: 10.0, F0: 2.0}
coordinates: {x: 0.1, phi: 0.2}
inputs:
  F: F0           # a constant of the parameters: numeric
  z: 0            # moves a frame: m, its rates m/s, m/s2
  M: 0.5          # a torque about the hinge: N.m
frames:
  base: {translation: [0, 0, z]}
  cart: {parent: base, translation: [x, 0, 0]}
  arm: {parent: cart, rotation: [[y, phi]]}
bodies:
  c: {frame: cart, mass: m}
  a: {frame: arm, mass: m, center_of_mass: [0, 0, -1]}
forces:
  push: {type: force, frame: cart, vector: [F, 0, 0]}
  twist: {type: generalized, coordinate: phi, value: M}
  spring: {type: spring_damper, between: [ISYS, cart], stiffness: k, report: true}
outputs:
  tip: {position: arm, point: [0, 0, -1], component: x}
"""


def _constants(system):
    inputs = ["F", "z", "M", "d_z", "dd_z"]
    return {
        "MODEL_NAME": system.name, "DESCRIPTION": "", "PARAMETERS": {
            p.name: p.default for p in system.parameters},
        "INPUTS": inputs, "INPUT_RATES": {"z": ["d_z", "dd_z"]},
        "INPUT_UNITS": [input_units(system)[n] for n in inputs],
        "COORDINATES": ["x", "phi"], "COORDINATE_UNITS": units(system)[0],
        "OUTPUTS": ["spring_force", "tip"], "OUTPUT_UNITS": units(system)[1],
        "CONSTRAINTS": [],
    }


def test_input_defaults():
    """Constant defaults (numbers, expressions of parameters) pass; a default in time is named
    with its key (an FMU's inputs are driven by the importer)."""
    system = load_description_text(DRIVEN, "driven.yaml")
    assert export_problems(system) == []
    timed = load_description_text(DRIVEN.replace("z: 0 ", "z: 0.1*sin(t)"), "driven.yaml")
    [(key, message)] = export_problems(timed)
    assert key == "inputs.z" and "no numeric default" in message and "sin(t)" in message


def test_units_and_descriptions_of_the_variables():
    """Input units by where the input enters (codegen.blocks.input_units: a frame
    translation, a force vector, a generalized force on an angle) and their rates; a spring's
    reported force in N (codegen.blocks.units); as FMI unit names, each defined in
    UnitDefinitions by its SI base units."""
    system = load_description_text(DRIVEN, "driven.yaml")
    model = fmu_model(system, _constants(system), [0.1, 0.2, 0.0, 0.0],
                      [2.0, 0.0, 0.5, 0.0, 0.0])
    units = {v.name: v.unit for v in model.variables()}
    assert units["F"] == "N" and units["M"] == "N.m"
    assert (units["z"], units["d_z"], units["dd_z"]) == ("m", "m/s", "m/s2")
    assert units["der(d_phi)"] == "rad/s2" and units["spring_force"] == "N"
    root = ET.fromstring(model_description(model, "{g}", ("me", "cs"), ("a.c",), "test"))
    defined = {u.get("name"): u.find("BaseUnit").attrib for u in root.iter("Unit")}
    assert defined["N"] == {"kg": "1", "m": "1", "s": "-2"}
    assert defined["N.m"] == {"kg": "1", "m": "2", "s": "-2"}
    assert defined["m/s2"] == {"m": "1", "s": "-2"}
    assert set(defined) == {u for u in units.values() if u}
    descr = {sv.get("name"): sv.get("description") for sv in root.iter("ScalarVariable")}
    assert "time derivative of the input z" in descr["d_z"]
    assert descr["tip"] == "position of the point [0, 0, -1] of frame arm, x component in ISYS"


def test_value_references_in_the_header_match_the_description():
    """The offsets ``NW_VR_*`` of model.h are where modelDescription.xml puts the groups."""
    system = load_description_text(DRIVEN, "driven.yaml")
    model = fmu_model(system, _constants(system), [0.1, 0.2, 0.0, 0.0],
                      [2.0, 0.0, 0.5, 0.0, 0.0])
    header = model_header(model, "{g}", ("me",))
    defines = dict(line.split()[1:3] for line in header.splitlines()
                   if line.startswith("#define NW_") and len(line.split()) == 3)
    root = ET.fromstring(model_description(model, "{g}", ("me",), (), "test"))
    vr = {sv.get("name"): int(sv.get("valueReference")) for sv in root.iter("ScalarVariable")}
    assert int(defines["NW_VR_U"]) == vr["F"]
    assert int(defines["NW_VR_Y"]) == vr["x"]
    assert int(defines["NW_VR_Y"]) + 2 == vr["d_x"]
    assert int(defines["NW_VR_DER"]) == vr["der(x)"]
    assert int(defines["NW_VR_OUT"]) == vr["spring_force"]
    assert int(defines["NW_NVR"]) == len(vr)
    assert defines["NW_MODEL_EXCHANGE"] == "1" and defines["NW_CO_SIMULATION"] == "0"
    assert root.find("CoSimulation") is None


@pytest.mark.parametrize("dependent", [(), (1,)])
def test_states_are_the_independent_coordinates(dependent):
    system = load_description_text(DRIVEN, "driven.yaml")
    model = fmu_model(system, _constants(system), [0.1, 0.2, 0.0, 0.0],
                      [2.0, 0.0, 0.5, 0.0, 0.0], dependent)
    states = [v.name for v in model.derivatives]
    assert states == (["der(x)", "der(phi)", "der(d_x)", "der(d_phi)"] if not dependent
                      else ["der(x)", "der(d_x)"])
    phi = next(v for v in model.coordinates if v.name == "phi")
    assert (phi.initial, phi.start) == (("exact", 0.2) if not dependent
                                        else ("calculated", None))
