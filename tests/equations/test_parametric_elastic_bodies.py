"""Parametric (scheduled) elastic bodies in the equations of motion (equations.md §2.3, §4).

References: the parametric body's own interpolation in the elastic layer
(``ParametricBody.at``, Panzer et al. 2010), entered as a plain reduced body — the scheduled
generated module must equal it at and between the samples — and the local reduced models at
the samples.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from neweul_py.analysis import load_generated
from neweul_py.analysis.linearize import linearize
from neweul_py.api import generate
from neweul_py.elastic import reduce_modal, save_reduced_body
from neweul_py.elastic.interpolation import interpolate, save_parametric_body
from neweul_py.elastic.invariants import attach_invariants
from neweul_py.errors import DescriptionError

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "elastic"))
from fe_builders import piston_duct

SPEEDS = (300.0, 343.0, 390.0)


def _description(data: str, schedule: str | None, c: float) -> str:
    sched = f", schedule: {schedule}" if schedule else ""
    return f"""
name: scheduled_duct
parameters: {{cs: {c!r}, m2: 0.02, k2: 1.0e5}}
coordinates: {{z: {{}}}}
inputs: {{F: 0}}
frames:
  carrier: {{translation: [z, 0, 0]}}
elastic_bodies:
  duct: {{frame: ISYS, data: {data}, nodes: {{piston: 1}}{sched}}}
bodies:
  mass: {{frame: carrier, mass: m2}}
forces:
  link:
    type: bushing
    between: [duct.piston, carrier]
    stiffness: {{diag: [k2, 0, 0]}}
  push: {{type: force, frame: carrier, vector: [F, 0, 0], in: ISYS}}
"""


@pytest.fixture(scope="module")
def parametric(tmp_path_factory) -> tuple[Path, object]:
    """Two-sided u–p piston ducts at three sound speeds, 8 modes each, interpolated."""
    tmp = tmp_path_factory.mktemp("param")
    bodies = []
    for c in SPEEDS:
        fe = piston_duct(n_el=60, c=c)
        body = reduce_modal(fe, modes=8, two_sided=True, keep_nodes=[1], store_bases=True)
        bodies.append(attach_invariants(body, fe, nodes=[1]))
    pb = interpolate(bodies, list(SPEEDS), parameter="c")
    save_parametric_body(pb, tmp / "duct.npz")
    return tmp, pb


def _frf(tmp: Path, text: str, name: str) -> np.ndarray:
    (tmp / name).write_text(text)
    mod = load_generated(generate(tmp / name, tmp / f"gen_{name}"))
    lin = linearize(mod)
    iz = list(mod.COORDINATES).index("z")
    w = 2 * np.pi * np.array([50.0, 200.0, 700.0, 1500.0])
    return np.array([np.linalg.solve(lin.Q - wi**2 * lin.M0 + 1j * wi * lin.P, lin.B[:, 0])[iz]
                     for wi in w])


@pytest.mark.parametrize("c", [343.0, 321.5, 370.0])
def test_scheduled_body_equals_the_interpolated_body(parametric, c: float) -> None:
    """The generated module with ``schedule: cs`` at ``cs = c`` gives the FRF of the same
    model built from ``ParametricBody.at(c)`` as a fixed body (at a sample: the local model)."""
    tmp, pb = parametric
    save_reduced_body(pb.at(c), tmp / f"at{c}.npz")
    ref = _frf(tmp, _description(f"at{c}.npz", None, c), f"fixed{c}.yaml")
    got = _frf(tmp, _description("duct.npz", "cs", c), f"sched{c}.yaml")
    assert np.allclose(got, ref, rtol=1e-9, atol=0)


def test_schedule_outside_the_samples_is_an_error(parametric) -> None:
    """No extrapolation: σ outside [300, 390] names the body, the value and the range."""
    tmp, _pb = parametric
    (tmp / "out.yaml").write_text(_description("duct.npz", "cs", 343.0))
    mod = load_generated(generate(tmp / "out.yaml", tmp / "gen_out"))
    p = mod.default_parameters()
    p[list(mod.PARAMETERS).index("cs")] = 500.0
    with pytest.raises(ValueError, match=r"'duct'.*500.*\[300, 390\]"):
        mod.rhs(0.0, np.array(mod.INITIAL_STATE), p)


@pytest.mark.parametrize(("schedule", "words"), [
    ("cz", "cz"), ("z", "coordinate"), (None, "schedule")])
def test_bad_schedules_name_the_key(parametric, schedule, words) -> None:
    """An unknown symbol, a coordinate, or a parametric body without a schedule: one
    DescriptionError naming ``elastic_bodies.duct.schedule``."""
    tmp, _pb = parametric
    (tmp / "bad.yaml").write_text(_description("duct.npz", schedule, 343.0))
    with pytest.raises(DescriptionError) as info:
        generate(tmp / "bad.yaml", tmp / "gen_bad")
    assert "elastic_bodies.duct.schedule" in str(info.value)
    assert words in str(info.value)
