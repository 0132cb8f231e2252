"""Elastic bodies in descriptions: initial elastic states (``elastic_bodies.NAME.initial`` /
``velocity``) reach ``INITIAL_STATE``; the top-level ``neweul_py.load_description`` reads the
elastic data files without being handed a reader."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

import neweul_py
from neweul_py.analysis import load_generated
from neweul_py.api import generate
from neweul_py.description import load_description as bare_load_description
from neweul_py.errors import DescriptionError

DATA = Path(__file__).resolve().parents[1] / "data"

CLAMPED = """
name: clamped_beam
elastic_bodies:
  beam:
    frame: ISYS
    data: beam.SID_FEM
    nodes: {{tip: 1793}}
    modes: 3
{extra}
"""


@pytest.fixture
def beam_dir(tmp_path: Path) -> Path:
    shutil.copy(DATA / "beam.SID_FEM", tmp_path / "beam.SID_FEM")
    return tmp_path


def _desc(beam_dir: Path, extra: str) -> Path:
    path = beam_dir / "model.yaml"
    path.write_text(CLAMPED.format(extra=extra))
    return path


def test_top_level_load_description_reads_elastic_data(beam_dir: Path) -> None:
    """``neweul_py.load_description`` supplies the elastic reader; the layer-level function
    without a reader names what is missing."""
    path = _desc(beam_dir, "")
    system = neweul_py.load_description(path)
    assert [b.name for b in system.elastic_bodies] == ["beam"]
    assert system.elastic_bodies[0].nq == 3
    with pytest.raises(DescriptionError, match="data reader"):
        bare_load_description(path)


def test_initial_elastic_state_reaches_the_module(beam_dir: Path) -> None:
    """A list (initial) and a mapping (velocity, keys ``qK`` or ``beam_qK``) give
    ``INITIAL_STATE``; the elastic coordinates' values there equal those in the model."""
    path = _desc(beam_dir,
                 "    initial: [0.01, -0.002, 3e-4]\n    velocity: {q2: 0.5, beam_q3: -1}")
    system = neweul_py.load_description(path)
    init = {c.name: (c.initial, c.velocity) for c in system.coordinates}
    assert init["beam_q1"] == (0.01, 0.0) and init["beam_q2"] == (-0.002, 0.5)
    assert init["beam_q3"] == (3e-4, -1.0)
    mod = load_generated(generate(path, beam_dir / "gen"))
    assert list(mod.COORDINATES) == ["beam_q1", "beam_q2", "beam_q3"]
    np.testing.assert_array_equal(mod.INITIAL_STATE, [0.01, -0.002, 3e-4, 0.0, 0.5, -1.0])


@pytest.mark.parametrize(("extra", "key", "words"), [
    ("    initial: [0.1, 0.2]", "elastic_bodies.beam.initial", "expected 3 values"),
    ("    velocity: {q4: 1.0}", "elastic_bodies.beam.velocity.q4", "q1 … q3"),
    ("    initial: [0.1, abc, 0]", "elastic_bodies.beam.initial.2", "number"),
    ("    initial: 0.1", "elastic_bodies.beam.initial", "expected a list"),
])
def test_bad_initial_elastic_state(beam_dir: Path, extra: str, key: str, words: str) -> None:
    with pytest.raises(DescriptionError) as info:
        neweul_py.load_description(_desc(beam_dir, extra))
    assert info.value.key_path == key
    assert words in str(info.value)


@pytest.mark.filterwarnings("ignore:.*second-order inertia terms")
def test_a_spring_on_an_elastic_coordinate_acts_like_its_generalized_force(
        beam_dir: Path) -> None:
    """A rotational spring–damper on ``beam_q1`` gives the right-hand side of the generalized
    force ``−k beam_q1`` (the reference) and adds its potential ``½ k beam_q1²``."""
    modules = {}
    for kind, force in (("generalized", "{type: generalized, coordinate: beam_q1, "
                                         "value: -k*beam_q1}"),
                        ("spring", "{type: rotational_spring_damper, coordinate: beam_q1, "
                                   "stiffness: k}")):
        path = beam_dir / f"{kind}.yaml"
        path.write_text(CLAMPED.format(extra="parameters: {k: 1000}\nforces:\n  extra: "
                                       + force).replace("clamped_beam", f"clamped_{kind}"))
        modules[kind] = load_generated(generate(path, beam_dir / kind))
    x = np.zeros(modules["spring"].STATE_SIZE)
    x[0], x[4] = 0.01, 0.3
    p = modules["spring"].default_parameters()
    np.testing.assert_allclose(modules["spring"].rhs(0.0, x, p),
                               modules["generalized"].rhs(0.0, x, p), rtol=1e-12, atol=1e-12)
    springs = modules["spring"].energy(0.0, x, p)[2]
    assert springs == pytest.approx(0.5 * 1000 * 0.01**2, rel=1e-12)
