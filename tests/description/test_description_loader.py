"""The YAML description loader: a good file gives the expected System; every bad input gives
one DescriptionError naming the file, the key path and the right line."""

from __future__ import annotations

import hashlib
import pathlib

import numpy as np
import pytest
import sympy as sp

import neweul_py
import neweul_py.api
from neweul_py.description import description_hash, load_description, load_description_text
from neweul_py.errors import DescriptionError
from neweul_py.model import (
    GeneralizedForce,
    KinematicOutput,
    PointForce,
    SpringDamper,
    Torque,
    symbol,
    time,
)

GOOD = """\
name: double_pendulum
description: planar double pendulum with a few of everything
gravity: [0, 0, -g]
parameters:
  m1: 1.0
  m2: 0.5
  l1: 1
  l2: 8e-1
  g: 9.81
  c: 1e-3
coordinates:
  phi1: 0.1
  phi2: {initial: -0.2, velocity: 0.5}
inputs:
  u: 0.1*sin(2*pi*t)
frames:
  link2:
    parent: link1
    translation: [0, 0, -l1]
    rotation: [[y, phi2]]
  link1:
    rotation: [[y, phi1], [x, 0]]
bodies:
  b1:
    frame: link1
    mass: m1
    center_of_mass: [0, 0, -l1]
    inertia: {diag: [0, 0, 0]}
  b2:
    frame: link2
    mass: m2
    center_of_mass: [0, 0, -l2]
    inertia: [[1e-3, 0, 0], [0, 1e-3, 0], [0, 0, 1e-3]]
forces:
  drive: {type: generalized, coordinate: phi1, value: u - c*d_phi1}
  push: {type: force, frame: link2, point: [0, 0, -l2], vector: [u, 0, 0], in: ISYS}
  twist: {type: torque, frame: link1, vector: [0, -c*d_phi1, 0], in: link1}
  spring:
    type: spring_damper
    between: [ISYS, link2]
    points: [[0, 0, 0], [0, 0, -l2]]
    stiffness: 10
    damping: 0.1
    length: l1
outputs:
  angle_sum: phi1 + phi2
  tip_x: {position: link2, point: [0, 0, -l2], in: ISYS, component: x}
  tip_vz: {velocity: link2, component: z}
"""

FILE = "pendulum.yaml"


def line_of(text: str, snippet: str, occurrence: int = 1) -> int:
    """1-based line of the ``occurrence``-th line containing ``snippet``."""
    hits = [i for i, line in enumerate(text.splitlines(), 1) if snippet in line]
    return hits[occurrence - 1]


def write(tmp_path: pathlib.Path, text: str) -> pathlib.Path:
    path = tmp_path / FILE
    path.write_text(text)
    return path


def test_good_file_gives_the_expected_system(tmp_path: pathlib.Path) -> None:
    s = load_description(write(tmp_path, GOOD))
    sym = {n: symbol(n) for n in ("m1", "m2", "l1", "l2", "g", "c", "phi1", "phi2", "u",
                                  "d_phi1")}
    assert s.name == "double_pendulum"
    assert s.description.startswith("planar")
    assert s.gravity == sp.ImmutableMatrix([0, 0, -sym["g"]])
    assert {p.name: p.default for p in s.parameters} == {
        "m1": 1.0, "m2": 0.5, "l1": 1.0, "l2": 0.8, "g": 9.81, "c": 1e-3}
    assert [(q.name, q.initial, q.velocity) for q in s.coordinates] == [
        ("phi1", 0.1, 0.0), ("phi2", -0.2, 0.5)]
    assert s.inputs[0].default == sp.Rational(1, 10) * sp.sin(2 * sp.pi * time)
    assert [f.name for f in s.frames_topological] == ["link1", "link2"]
    link2 = s.frame_map["link2"]
    assert link2.parent == "link1"
    assert link2.translation == sp.ImmutableMatrix([0, 0, -sym["l1"]])
    assert s.frame_map["link1"].rotation == (("y", sym["phi1"]), ("x", 0))
    b1, b2 = s.bodies
    assert (b1.frame, b1.mass) == ("link1", sym["m1"])
    assert b1.inertia == sp.zeros(3, 3)
    assert b2.inertia == sp.eye(3) / 1000
    drive, push, twist, spring = s.forces
    assert isinstance(drive, GeneralizedForce)
    assert drive.value == sym["u"] - sym["c"] * sym["d_phi1"]
    assert isinstance(push, PointForce) and push.in_frame == "ISYS"
    assert isinstance(twist, Torque) and twist.in_frame == "link1"
    assert isinstance(spring, SpringDamper)
    assert (spring.frame_a, spring.frame_b, spring.length) == ("ISYS", "link2", sym["l1"])
    assert spring.damping == sp.Rational(1, 10)
    angle_sum, tip_x, tip_vz = s.outputs
    assert angle_sum.expr == sym["phi1"] + sym["phi2"]
    assert isinstance(tip_x, KinematicOutput) and tip_x.quantity == "position"
    assert (tip_vz.quantity, tip_vz.component, tip_vz.in_frame) == ("velocity", "z", "ISYS")


def test_text_and_file_give_equal_systems(tmp_path: pathlib.Path) -> None:
    a = load_description(write(tmp_path, GOOD))
    b = load_description_text(GOOD.encode(), "other.yaml")
    assert a.fingerprint() == b.fingerprint()


def test_top_level_reexports(tmp_path: pathlib.Path) -> None:
    # the top-level function is api.load_description: the same loader, reading elastic data
    assert neweul_py.load_description is neweul_py.api.load_description
    path = write(tmp_path, GOOD)
    assert neweul_py.load_description(path).fingerprint() == load_description(path).fingerprint()
    assert neweul_py.SystemBuilder.__name__ == "SystemBuilder"


def test_description_hash_is_sha256() -> None:
    assert description_hash(GOOD.encode()) == hashlib.sha256(GOOD.encode()).hexdigest()
    assert description_hash(GOOD) == description_hash(GOOD.encode())


def test_minimal_and_empty_sections() -> None:
    s = load_description_text("name: empty\nparameters:\ninputs: {}\nframes:\n  f:\n")
    assert s.frames[0].parent == "ISYS" and s.parameters == ()


# (case id, old text, new text, key path, snippet that marks the line in the new text,
#  part of the message)
BAD = [
    ("unknown top-level key", "outputs:", "output:", "output", "output:", "unknown key 'output'"),
    ("unknown frame key", "    parent: link1", "    parent: link1\n    offset: 1",
     "frames.link2.offset", "offset", "valid keys are: parent, translation, rotation"),
    ("unknown body key", "    mass: m2", "    mass: m2\n    volume: 1", "bodies.b2.volume",
     "volume", "unknown key 'volume'"),
    ("unknown force key", "    stiffness: 10", "    stiffness: 10\n    preload: 1",
     "forces.spring.preload", "preload", "unknown key"),
    ("unknown output key", "component: z}", "comp: z}", "outputs.tip_vz.comp", "comp: z",
     "unknown key 'comp'"),
    ("unknown coordinate key", "velocity: 0.5}", "speed: 0.5}", "coordinates.phi2.speed",
     "speed", "unknown key"),
    ("malformed YAML", "  m2: 0.5", "  m2: [0.5", "", "l1: 1", "malformed YAML"),
    ("tab", "  m2: 0.5", "\tm2: 0.5", "", "m2: 0.5", "malformed YAML"),
    ("duplicate key", "  m2: 0.5", "  m2: 0.5\n  m2: 0.7", "parameters.m2", "m2: 0.7",
     "duplicate key 'm2' (first defined on line 6)"),
    ("duplicate frame", "  link1:\n", "  link2: {}\n  link1:\n", "frames.link2", "link2: {}",
     "duplicate key 'link2'"),
    ("short vector", "translation: [0, 0, -l1]", "translation: [0, -l1]",
     "frames.link2.translation", "translation", "expected a list of 3 expressions, got 2"),
    ("long gravity", "gravity: [0, 0, -g]", "gravity: [0, 0, -g, 1]", "gravity", "gravity",
     "got 4"),
    ("short point", "points: [[0, 0, 0], [0, 0, -l2]]", "points: [[0, 0, 0], [0, -l2]]",
     "forces.spring.points[1]", "points:", "got 2"),
    ("non-numeric default", "  m2: 0.5", "  m2: heavy", "parameters.m2", "m2: heavy",
     "must be a number"),
    ("expression default", "  m2: 0.5", "  m2: 2*m1", "parameters.m2", "m2: 2*m1",
     "must be a number"),
    ("bool default", "  m2: 0.5", "  m2: yes", "parameters.m2", "m2: yes", "got bool"),
    ("nan default", "  m2: 0.5", "  m2: .nan", "parameters.m2", "m2: .nan", "finite"),
    ("non-numeric initial", "  phi1: 0.1", "  phi1: up", "coordinates.phi1", "phi1: up",
     "initial value must be a number"),
    ("unknown parent", "parent: link1", "parent: link9", "frames.link2.parent", "parent:",
     "unknown parent frame 'link9'; frames are: ISYS, link1, link2"),
    ("unknown body frame", "frame: link1\n    mass: m1", "frame: arm\n    mass: m1",
     "bodies.b1.frame", "frame: arm", "unknown frame 'arm'"),
    ("unknown in frame", "in: link1}", "in: link3}", "forces.twist.in", "in: link3",
     "unknown frame 'link3'"),
    ("unknown between frame", "between: [ISYS, link2]", "between: [ISYS, link5]",
     "forces.spring.between[1]", "between", "unknown frame 'link5'"),
    ("frame cycle", "  link1:\n    rotation", "  link1:\n    parent: link2\n    rotation",
     "frames.link2.parent", "parent: link1", "frame cycle: link2 -> link1 -> link2"),
    ("negative mass", "mass: m2", "mass: -m2", "bodies.b2.mass", "mass: -m2",
     "must not be negative"),
    ("negative literal mass", "mass: m1", "mass: -1", "bodies.b1.mass", "mass: -1",
     "must not be negative"),
    ("non-symmetric inertia", "[[1e-3, 0, 0], [0, 1e-3, 0]", "[[1e-3, 0, 0], [2e-4, 1e-3, 0]",
     "bodies.b2.inertia[0][1]", "inertia: [[", "symmetric"),
    ("non-positive inertia", "[[1e-3, 0, 0], [0, 1e-3, 0]", "[[-1e-3, 0, 0], [0, 1e-3, 0]",
     "bodies.b2.inertia", "inertia: [[", "positive semidefinite"),
    ("non-positive diag inertia", "diag: [0, 0, 0]", "diag: [1, 1, -1]", "bodies.b1.inertia",
     "diag:", "positive semidefinite"),
    ("triangle inequality", "diag: [0, 0, 0]", "diag: [1, 1, 3]", "bodies.b1.inertia",
     "diag:", "triangle inequality"),
    ("inertia shape", "inertia: {diag: [0, 0, 0]}", "inertia: [[1, 0], [0, 1]]",
     "bodies.b1.inertia", "inertia: [[1, 0]", "3×3"),
    ("unknown name", "value: u - c*d_phi1", "value: u - k*d_phi1", "forces.drive.value",
     "drive:", "unknown name 'k'; allowed names are: c, d_phi1, d_phi2, d_u, dd_u, g, l1"),
    ("coordinate in mass", "mass: m1", "mass: m1*phi1", "bodies.b1.mass", "mass: m1*phi1",
     "'phi1' is a coordinate, which is not allowed here"),
    ("velocity in frame", "translation: [0, 0, -l1]", "translation: [0, 0, -d_phi1]",
     "frames.link2.translation[2]", "translation", "'d_phi1' is a velocity"),
    ("unbalanced", "angle_sum: phi1 + phi2", "angle_sum: (phi1 + phi2", "outputs.angle_sum",
     "angle_sum", "expected ')'"),
    ("unknown function", "angle_sum: phi1 + phi2", "angle_sum: cbrt(phi1)", "outputs.angle_sum",
     "angle_sum", "unknown function 'cbrt'"),
    ("attribute access", "angle_sum: phi1 + phi2", "angle_sum: phi1.real", "outputs.angle_sum",
     "angle_sum", "attribute access"),
    ("lambda", "angle_sum: phi1 + phi2", "angle_sum: 'lambda: 0'", "outputs.angle_sum",
     "angle_sum", "keyword 'lambda'"),
    ("unknown force type", "type: torque", "type: moment", "forces.twist.type", "moment",
     "unknown force type 'moment'; types are: force, torque, generalized, spring_damper"),
    ("missing force key", "    stiffness: 10\n", "", "forces.spring", "spring:",
     "missing the key 'stiffness'"),
    ("missing body key", "    mass: m1\n", "", "bodies.b1", "b1:", "missing the key 'mass'"),
    ("rotation not pairs", "rotation: [[y, phi1], [x, 0]]", "rotation: [y, phi1]",
     "frames.link1.rotation[0]", "rotation: [y, phi1]", "[[axis, angle]]"),
    ("bad axis", "rotation: [[y, phi2]]", "rotation: [[w, phi2]]", "frames.link2.rotation[0][0]",
     "rotation: [[w", "x, y, z"),
    ("bad component", "component: z}", "component: w}", "outputs.tip_vz.component", "tip_vz",
     "x, y, z"),
    ("two quantities", "{velocity: link2, component: z}",
     "{velocity: link2, position: link1}", "outputs.tip_vz", "tip_vz", "exactly one"),
    ("unknown coordinate", "coordinate: phi1", "coordinate: phi3", "forces.drive.coordinate",
     "drive:", "unknown coordinate 'phi3'"),
    ("bool key", "  c: 1e-3", "  on: 1e-3", "parameters", "on: 1e-3", "booleans"),
    ("reserved name", "  c: 1e-3", "  sin: 1e-3", "parameters.sin", "sin: 1e-3", "reserved"),
    ("python tag", "  c: 1e-3", "  c: !!python/object/apply:os.system ['true']", "parameters.c",
     "c: !!python", "not allowed"),
    ("python scalar tag", "  c: 1e-3", "  c: !!python/name:os.system ''", "", "c: !!python",
     "malformed YAML"),
    ("overflowing default", "  m2: 0.5", "  m2: 1e400", "parameters.m2", "m2: 1e400",
     "1e400 is out of range"),
    ("negative rest length", "    length: l1", "    length: -l1", "forces.spring.length",
     "length: -l1", "must not be negative (it is -1)"),
    ("missing force vector", ", vector: [u, 0, 0], in: ISYS}", ", in: ISYS}", "forces.push",
     "push:", "a 'force' force element is missing the key 'vector'"),
]





@pytest.mark.parametrize(
    ("old", "new", "key_path", "snippet", "message"),
    [case[1:] for case in BAD],
    ids=[case[0] for case in BAD],
)
def test_bad_input_names_file_key_path_and_line(
    tmp_path: pathlib.Path, old: str, new: str, key_path: str, snippet: str, message: str
) -> None:
    assert old in GOOD
    text = GOOD.replace(old, new, 1)
    path = write(tmp_path, text)
    with pytest.raises(DescriptionError) as info:
        load_description(path)
    err = info.value
    line = line_of(text, snippet)
    assert err.file == str(path)
    assert err.key_path == key_path
    assert err.line == line
    rendered = str(err)
    assert rendered.startswith(f"{path}:{line}: ")
    assert FILE in rendered
    assert key_path in rendered
    assert message in rendered
    assert "\n" not in rendered


def test_hostile_description_has_no_side_effect(tmp_path: pathlib.Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    sentinel = tmp_path / "SENTINEL"
    hostile = [
        GOOD.replace("angle_sum: phi1 + phi2",
                     f"angle_sum: __import__('os').system('touch {sentinel}')"),
        GOOD.replace("  c: 1e-3", f"  c: !!python/object/apply:os.system ['touch {sentinel}']"),
        GOOD.replace("  c: 1e-3",
                     f"  c: !!python/object/new:subprocess.call [['touch', '{sentinel}']]"),
    ]
    for text in hostile:
        with pytest.raises(DescriptionError):
            load_description_text(text, FILE)
    assert not sentinel.exists()


def test_anchors_and_merge_keys_are_supported() -> None:
    text = """\
name: merged
frames:
  base: &placed {translation: [0, 0, 1]}
  arm:
    <<: *placed
    parent: base
"""
    s = load_description_text(text, "m.yaml")
    assert s.frame_map["arm"].translation == sp.ImmutableMatrix([0, 0, 1])
    assert s.frame_map["arm"].parent == "base"


@pytest.mark.parametrize(
    ("text", "line", "message"),
    [
        ("", 1, "missing the key 'name'"),
        ("- 1\n- 2\n", 1, "must be a mapping"),
        ("name: a\n---\nname: b\n", 2, "single document"),
        ("name: a\nframes:\n  f: &x\n    parent: *x\n", 4, "recursive"),
        ("name: 3\n", 1, "must be a string"),
        ("name: 3bad\n", 1, "not a valid name"),
        ("name: a\nparameters: [1]\n", 2, "parameters must be a mapping"),
        ("name: a\nframes:\n  f: [1]\n", 3, "a frame must be a mapping"),
    ],
)
def test_document_level_errors(text: str, line: int, message: str) -> None:
    with pytest.raises(DescriptionError) as info:
        load_description_text(text, "doc.yaml")
    assert info.value.line == line
    assert message in str(info.value)


def test_missing_file(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "nope.yaml"
    with pytest.raises(DescriptionError, match="cannot read description") as info:
        load_description(path)
    assert info.value.file == str(path)


def test_non_utf8_bytes() -> None:
    with pytest.raises(DescriptionError, match="not UTF-8"):
        load_description_text(b"name: \xff\xfe", "bin.yaml")


def test_the_documented_example_loads() -> None:
    """Reference: the example of docs/description-format.md (keeps the doc honest)."""
    doc = pathlib.Path(__file__).parents[2] / "docs" / "description-format.md"
    text = doc.read_text().split("```yaml\n", 1)[1].split("```", 1)[0]
    s = load_description_text(text, "pendulum.yaml")
    assert [f.name for f in s.forces] == ["drive", "push", "twist", "spring"]
    assert [o.name for o in s.outputs] == ["angle_deg", "tip_x", "tip_vz"]
    bad = text.replace("    mass: m\n", "    mass: m*phi\n")
    with pytest.raises(DescriptionError) as info:
        load_description_text(bad, "pendulum.yaml")
    assert str(info.value).startswith("pendulum.yaml:20: bodies.bob.mass: in expression")


def test_aliased_mapping_with_merge_is_used_twice() -> None:
    text = """\
name: twice
frames:
  base: &placed {translation: [0, 0, 1]}
  a: &arm {<<: *placed, parent: base}
  b: *arm
"""
    s = load_description_text(text, "t.yaml")
    assert s.frame_map["b"].parent == "base"
    assert s.frame_map["b"].translation == sp.ImmutableMatrix([0, 0, 1])


def test_description_imports_only_model_and_errors() -> None:
    """Layering rule of docs/architecture.md: description imports model (and the shared errors,
    ffrf kernel, file checks of neweul_py/files.py, the YAML shape of yaml_shape.py and the YAML
    reader of neweul_py/yaml_tree.py) only."""
    import re

    import neweul_py.description as pkg

    for path in pathlib.Path(pkg.__file__).parent.glob("*.py"):
        for layer in re.findall(r"^\s*from \.\.(\w+)", path.read_text(), re.MULTILINE):
            assert layer in ("model", "errors", "ffrf", "files", "yaml_shape", "yaml_tree"), \
                f"{path.name} imports {layer}"


def test_description_size_is_capped_before_anything_is_built() -> None:
    """200 000 parameters took over a minute (every parameter is a sympy symbol, validated,
    fingerprinted and printed): a description has at most MAX_PARAMETERS parameters and
    MAX_NODES YAML nodes (docs/limits.md), counted from the parser's events before the tree
    is built. Reference: the counts written into the text."""
    from neweul_py.description.loader import MAX_PARAMETERS
    from neweul_py.yaml_tree import MAX_NODES

    head = "name: many\ncoordinates: {x: 0}\nparameters:\n"
    text = head + "".join(f"  p{i}: 1\n" for i in range(MAX_PARAMETERS + 1))
    with pytest.raises(DescriptionError, match=f"{MAX_PARAMETERS + 1} parameters, more than "
                       f"the cap of {MAX_PARAMETERS}") as info:
        load_description_text(text, "many.yaml")
    assert info.value.key_path == "parameters" and info.value.line == 3
    text = head + "  m: 1\nbig: [" + ", ".join(["0"] * MAX_NODES) + "]\n"
    with pytest.raises(DescriptionError, match=f"more than the cap of {MAX_NODES}"):
        load_description_text(text, "nodes.yaml")


@pytest.mark.parametrize("where", ["parameters: {m: NUMBER}", "parameters:\n  m: -NUMBER",
                                   "gravity: [0, 0, NUMBER]"])
def test_integer_of_5000_digits_is_one_error(where: str) -> None:
    """Python refuses to convert an integer of more than 4300 digits (a ValueError from
    PyYAML's constructor reached the user): one DescriptionError naming the place."""
    text = ("name: big\ncoordinates: {y: 0}\n" + where.replace("NUMBER", "9" * 5000)
            + "\n")
    with pytest.raises(DescriptionError, match="5000 digits") as info:
        load_description_text(text, "big.yaml")
    assert info.value.line == 3 + where.count("\n")


def test_parameter_ranges() -> None:
    """``name: {value: V, min: A, max: B}`` gives a parameter with an admissible range (both
    bounds optional, inclusive; constants allowed as for values); a default outside it, an
    unknown key or a missing value is one error with the key path and line. Reference: the
    ranges written in the text."""
    text = ("name: ranged\ncoordinates: {x: 0}\nparameters:\n  l: {value: 0.5, min: 0}\n"
            "  g: {value: 9.81, min: 9, max: 10}\n  a: {value: 1, max: 2*pi}\n  m: 1\n")
    s = load_description_text(text, "r.yaml")
    assert s.parameter_ranges == {"l": (0.0, None), "g": (9.0, 10.0),
                                  "a": (None, pytest.approx(2 * np.pi))}
    assert [p.default for p in s.parameters] == [0.5, 9.81, 1.0, 1.0]
    for bad, message, line in (
            ("  l: {value: -1, min: 0}\n", r"parameters.l: the default -1 is outside its "
                                           r"range ≥ 0", 4),
            ("  l: {value: 1, minimum: 0}\n", "unknown key 'minimum'", 4),
            ("  l: {min: 0}\n", "missing the key 'value'", 4),
            ("  l: {value: 1, min: x}\n", "parameters.l.min", 4)):
        with pytest.raises(DescriptionError, match=message) as info:
            load_description_text("name: r\ncoordinates: {x: 0}\nparameters:\n" + bad, "r.yaml")
        assert info.value.line == line
