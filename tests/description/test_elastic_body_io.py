"""An elastic body's own FE inputs and outputs in a description (``elastic_bodies.NAME.inputs``
/ ``.outputs``, neweul_py/description/elastic.py) and generalized forces on elastic
coordinates (neweul_py/equations/elastic.py ``used_elastic_coordinates``).

Reference: the unreduced u–p piston–duct FE model of ``examples/elastic_up_body`` with the
spring, damper and rigid mass assembled directly (as ``make_fe.reference_frf``), driven by the
FE input ``force`` on the piston DOF, output the piston DOF (FE output ``x_piston``) and the
mass displacement.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sps

from neweul_py.analysis import load_generated
from neweul_py.analysis.linearize import linearize
from neweul_py.api import generate
from neweul_py.elastic import reduce_modal, write_fe_model
from neweul_py.elastic.io.body_files import save_reduced_body
from neweul_py.elastic.reductors.invariants import attach_invariants
from neweul_py.errors import DescriptionError

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "elastic_up_body"
M2, K2, D2 = 0.02, 5.0e4, 2.0


def _make_fe():
    spec = importlib.util.spec_from_file_location("elastic_up_make_fe_io", EXAMPLE / "make_fe.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _text(body: str, io: str, forces: str = "", outputs: str = "") -> str:
    return f"""
name: duct_io
parameters: {{m2: {M2}, k2: {K2}, d2: {D2}}}
coordinates: {{z: {{}}}}
inputs: {{F: 0}}
frames:
  carrier: {{translation: [z, 0, 0]}}
elastic_bodies:
  duct: {{frame: ISYS, data: {body}, nodes: {{piston: 1}}{io}}}
bodies:
  mass: {{frame: carrier, mass: m2}}
forces:
  link:
    type: bushing
    between: [duct.piston, carrier]
    stiffness: {{diag: [k2, 0, 0]}}
    damping: {{diag: [d2, 0, 0]}}
{forces}
outputs:
  mass_x: {{position: carrier, in: ISYS, component: x}}
{outputs}
"""


@pytest.fixture(scope="module")
def duct(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("io")
    mk = _make_fe()
    fe = mk.piston_duct()
    write_fe_model(fe, tmp / "duct.npz")
    body = attach_invariants(reduce_modal(fe, modes=16, two_sided=True, keep_nodes=[1],
                                          static_correction=True, store_bases=True),
                           fe, nodes=[1])
    save_reduced_body(body, tmp / "body.npz")
    return tmp, fe, body


def _reference(fe, f: np.ndarray) -> np.ndarray:
    """x_piston and mass_x per piston force, unreduced model + spring, damper, mass."""
    n = fe.M.shape[0]
    M = sps.block_diag([fe.M, sps.csr_matrix([[M2]])]).toarray()
    K = sps.block_diag([fe.K, sps.csr_matrix([[0.0]])]).toarray()
    D = np.zeros_like(K)
    for A, c in ((K, K2), (D, D2)):
        A[[0, n], [0, n]] += c
        A[0, n] -= c
        A[n, 0] -= c
    b = np.zeros(n + 1)
    b[0] = 1.0
    w = 2 * np.pi * f
    x = np.array([np.linalg.solve(K - wi**2 * M + 1j * wi * D, b) for wi in w])
    return x[:, [0, n]]


def test_body_inputs_and_outputs_match_the_unreduced_model(duct) -> None:
    """``inputs: {force: F}``, ``outputs: {x_piston: xp}`` give the FRF of the unreduced
    model below the cut-off (16 modes + static correction: < 1 %)."""
    tmp, fe, _body = duct
    (tmp / "io.yaml").write_text(_text("body.npz",
                                       ", inputs: {force: F}, outputs: {x_piston: xp}"))
    mod = load_generated(generate(tmp / "io.yaml", tmp / "gen_io"))
    f = np.linspace(20.0, 900.0, 23)
    lin = linearize(mod)
    w = 2 * np.pi * f
    x = np.array([np.linalg.solve(lin.Q - wi**2 * lin.M0 + 1j * wi * lin.P, lin.B[:, 0])
                  for wi in w])
    C = lin.C[[list(lin.outputs).index(o) for o in ("xp", "mass_x")]]
    m = lin.M0.shape[0]
    y = x @ C[:, :m].T + (1j * w[:, None] * x) @ C[:, m:].T
    got_xp, got_mass = y[:, 0], y[:, 1]
    ref = _reference(fe, f)
    assert np.max(np.abs(got_xp - ref[:, 0]) / np.abs(ref[:, 0])) < 1e-2
    assert np.max(np.abs(got_mass - ref[:, 1]) / np.abs(ref[:, 1])) < 1e-2


def test_generalized_force_on_an_elastic_coordinate_is_not_dropped(duct) -> None:
    """A generalized force ``(Wᵀb)_k F`` written by hand on every ``duct_qk`` gives the same
    FRF as ``inputs: {force: F}`` (it used to be accepted and dropped: FRF 0)."""
    tmp, _fe, body = duct
    b = body.B[:, 0]
    forces = "\n".join(f"  g{k + 1}: {{type: generalized, coordinate: duct_q{k + 1}, "
                       f"value: {float(b[k])!r}*F}}" for k in range(b.size))
    (tmp / "hand.yaml").write_text(_text("body.npz", "", forces))
    (tmp / "auto.yaml").write_text(_text("body.npz", ", inputs: {force: F}"))
    res = []
    for name in ("hand", "auto"):
        lin = linearize(load_generated(generate(tmp / f"{name}.yaml", tmp / f"gen_{name}")))
        res.append(np.linalg.solve(lin.Q - (2 * np.pi * 300.0) ** 2 * lin.M0, lin.B[:, 0]))
    assert np.abs(res[0]).max() > 0
    assert np.allclose(res[0], res[1], rtol=1e-12, atol=0)


@pytest.mark.parametrize(("io", "words"), [
    (", inputs: {nosuch: F}", "unknown FE input 'nosuch'"),
    (", outputs: {nosuch: xp}", "unknown FE output 'nosuch'"),
    (", inputs: {force: [1]}", "expected an expression"),
    (", inputs: {force: G}", "'G'"),
])
def test_bad_body_io_names_the_key(duct, io: str, words: str) -> None:
    """Unknown FE names, a non-expression and an unknown symbol: one DescriptionError naming
    ``elastic_bodies.duct.inputs`` / ``.outputs``."""
    tmp, _fe, _body = duct
    (tmp / "bad.yaml").write_text(_text("body.npz", io))
    with pytest.raises(DescriptionError) as info:
        generate(tmp / "bad.yaml", tmp / "gen_bad")
    assert words in str(info.value)
    assert "elastic_bodies.duct" in str(info.value) or "forces.duct_q1" in str(info.value)
