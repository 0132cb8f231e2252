"""Loss factors in the frequency domain (docs/equations.md §1.1): ``loss_factor`` of force
elements, ``loss_matrix`` of generated modules, ``linearize``'s ``G`` and ``frf`` in the form
``C(K + iG + iω(D − G/ω_ref) − ω²M)⁻¹B`` (``damping="viscous"``: the time-domain equivalent)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from neweul_py import api
from neweul_py.analysis import linearize
from neweul_py.analysis.frf import frequency_response
from neweul_py.analysis.linearize import LinearModel
from neweul_py.analysis.module import as_model
from neweul_py.cli import main
from neweul_py.errors import NeweulError

M, K, ETA, F_REF = 2.0, 800.0, 0.1, 50.0

SDOF = f"""
name: sdof_loss
loss_reference_frequency: {F_REF}
parameters: {{m: {M}, k: {K}, eta: {ETA}, c: 0.0}}
coordinates: {{x: {{}}}}
inputs: {{F: 0}}
frames: {{body: {{translation: [x, 0, 0]}}}}
bodies: {{mass: {{frame: body, mass: m}}}}
forces:
  spring:
    type: spring_damper
    between: [ISYS, body]
    points: [[-1, 0, 0], [0, 0, 0]]
    length: 1
    stiffness: k
    damping: c
    loss_factor: eta
  drive: {{type: generalized, coordinate: x, value: F}}
outputs: {{pos: x}}
"""

#: A planar double pendulum on two bushings and a rotational spring with loss factors: the
#: tangent stiffness depends on the configuration (the reference for G = ω_ref ∂q_loss/∂ẏ).
CHAIN = """
name: loss_chain
loss_reference_frequency: 200
gravity: [0, -9.81, 0]
parameters: {k1: 3000.0, k2: 1500.0, kr: 4.0, eta1: 0.2, eta2: 0.05, etar: 0.3}
coordinates: {x: {initial: 0.01}, a: {initial: 0.3}, b: {initial: -0.2}}
inputs: {F: 0}
frames:
  cart: {translation: [x, 0, 0]}
  arm: {parent: cart, rotation: [[z, a]]}
  tip: {parent: arm, translation: [0.5, 0, 0], rotation: [[z, b]]}
bodies:
  c: {frame: cart, mass: 1.0}
  l1: {frame: arm, mass: 0.5, center_of_mass: [0.25, 0, 0],
       inertia: [[0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01]]}
  l2: {frame: tip, mass: 0.3, center_of_mass: [0.2, 0, 0],
       inertia: [[0.005, 0, 0], [0, 0.005, 0], [0, 0, 0.005]]}
forces:
  ground:
    type: bushing
    between: [ISYS, cart]
    stiffness: {diag: [k1, 0, 0]}
    loss_factor: eta1
  link:
    type: bushing
    between: [cart, tip]
    points: [[0.6, 0.1, 0], [0.2, 0, 0]]
    stiffness: {diag: [k2, k2, 0]}
    rotational_stiffness: {diag: [0, 0, kr]}
    loss_factor: eta2
  hinge:
    type: rotational_spring_damper
    coordinate: b
    stiffness: {table: [[-1, -2], [0, 0], [0.5, 1.5], [1, 4]]}
    loss_factor: etar
  drive: {type: generalized, coordinate: x, value: F}
outputs: {tip_x: {position: tip, in: ISYS, component: x}}
"""


@pytest.fixture(scope="module")
def sdof(tmp_path_factory: pytest.TempPathFactory):
    return as_model(api.generate(SDOF, tmp_path_factory.mktemp("sdof")))


@pytest.fixture(scope="module")
def chain(tmp_path_factory: pytest.TempPathFactory):
    return as_model(api.generate(CHAIN, tmp_path_factory.mktemp("chain")))


def test_single_dof_loss_factor_matches_closed_form(sdof) -> None:
    """Reference: the closed form of a spring–mass with hysteretic damping,
    ``x/F = 1/(k(1 + iη) − mω²)``, at frequencies below, at and above resonance."""
    f = np.array([0.5, 2.0, np.sqrt(K / M) / (2 * np.pi), 10.0, 50.0, 300.0])
    w = 2 * np.pi * f
    H = frequency_response(linearize(sdof), f, "F", "pos").H[:, 0, 0]
    ref = 1.0 / (K * (1 + 1j * ETA) - M * w**2)
    assert np.max(np.abs(H / ref - 1)) < 1e-12


def test_loss_form_equals_viscous_form_at_the_reference_frequency(sdof) -> None:
    """Reference: ``iG = iω_ref (G/ω_ref)``, so the loss-factor form and its time-domain
    equivalent (``damping="viscous"``: ``c = ηk/ω_ref``) agree exactly at ``f = f_ref`` and
    differ elsewhere; the viscous form is the closed form ``1/(k + iωηk/ω_ref − mω²)``."""
    lin = linearize(sdof)
    f = np.array([F_REF / 4, F_REF, 4 * F_REF])
    h_loss = frequency_response(lin, f, "F", "pos").H[:, 0, 0]
    h_visc = frequency_response(lin, f, "F", "pos", damping="viscous").H[:, 0, 0]
    w, w_ref = 2 * np.pi * f, 2 * np.pi * F_REF
    assert np.allclose(h_visc, 1.0 / (K + 1j * w * ETA * K / w_ref - M * w**2), rtol=1e-12)
    assert abs(h_loss[1] / h_visc[1] - 1) < 1e-13
    # elsewhere the dynamic stiffnesses differ by i(1 − ω/ω_ref) ηk
    assert np.allclose(1 / h_loss - 1 / h_visc, 1j * (1 - f / F_REF) * ETA * K, rtol=1e-8)


def test_time_domain_equivalent_is_the_viscous_damper(sdof) -> None:
    """Reference: the time domain carries ``c = ηk/ω_ref`` on ``ẋ`` (docs/equations.md §1.1):
    ``q − k = F − k x − (ηk/ω_ref) ẋ`` about the rest position."""
    p = sdof.default_parameters()
    f = sdof.force_vector(0.0, [0.001], [0.3], p, [0.0])
    assert f[0] == pytest.approx(-K * 0.001 - ETA * K / (2 * np.pi * F_REF) * 0.3, rel=1e-12)
    assert sdof.LOSS_REFERENCE_FREQUENCY == F_REF


def test_loss_matrix_is_omega_ref_times_the_velocity_jacobian_of_the_loss_forces(chain) -> None:
    """Reference: the definition ``G = −ω_ref ∂q_loss/∂ẏ`` — the force Jacobians of the same
    module with the loss factors on and off differ by exactly ``−G/ω_ref`` (bushings with
    translational and rotational stiffness, a rotational spring with a piecewise-linear
    characteristic whose local slope (2 N m/rad at s = −0.3) the loss factor acts on), at a
    deflected, moving state."""
    p = chain.default_parameters()
    names = list(chain.PARAMETERS)
    off = p.copy()
    for nm in ("eta1", "eta2", "etar"):
        off[names.index(nm)] = 0.0
    y = np.array([0.02, 0.4, -0.3])
    yd = np.array([0.5, -1.0, 2.0])
    x = np.concatenate([y, yd])
    G = chain.loss_matrix(0.0, x, p)
    assert np.abs(G).max() > 100.0 and np.allclose(G, G.T, atol=1e-9)
    _, fyd_on, _ = chain.force_jacobians(0.0, y, yd, p)
    _, fyd_off, _ = chain.force_jacobians(0.0, y, yd, off)
    w_ref = 2 * np.pi * chain.LOSS_REFERENCE_FREQUENCY
    assert np.allclose(-(fyd_on - fyd_off) * w_ref, G, rtol=1e-10, atol=1e-9 * np.abs(G).max())
    # the rotational spring's share: η × the slope of the table segment [−1, 0] on b
    ib = chain.COORDINATES.index("b")
    only = np.where(np.isin(names, ["eta1", "eta2"]), 0.0, p)
    Gr = chain.loss_matrix(0.0, x, only)
    assert Gr[ib, ib] == pytest.approx(0.3 * 2.0, rel=1e-12)
    assert np.count_nonzero(Gr) == 1


def test_linearize_returns_g_and_it_survives_a_file_round_trip(chain, tmp_path: Path) -> None:
    """Reference: the module's own ``loss_matrix`` at the operating point (``linearize`` must
    hand it through unchanged without constraints) and :meth:`LinearModel.load`."""
    lin = linearize(chain)
    x0 = np.asarray(chain.INITIAL_STATE, dtype=float)
    assert np.allclose(lin.G, chain.loss_matrix(0.0, x0, chain.default_parameters()))
    assert lin.loss_reference_frequency == 200.0
    back = LinearModel.load(lin.save(tmp_path / "lin.npz"))
    assert np.array_equal(back.G, lin.G) and back.loss_reference_frequency == 200.0


def test_loss_form_needs_the_second_order_solve(chain) -> None:
    """Reference: the loss-factor form is no constant first-order pencil, so ``eig`` and
    ``hessenberg`` are refused (one error naming the way out); the viscous form takes them."""
    lin = linearize(chain)
    with pytest.raises(NeweulError, match="needs the method 'solve'"):
        frequency_response(lin, [10.0], "F", "tip_x", method="eig")
    a = frequency_response(lin, [10.0, 50.0], "F", "tip_x", method="eig", damping="viscous")
    b = frequency_response(lin, [10.0, 50.0], "F", "tip_x", damping="viscous")
    assert np.allclose(a.H, b.H, rtol=1e-8)
    with pytest.raises(NeweulError, match="damping form"):
        frequency_response(lin, [10.0], "F", "tip_x", damping="hysteretic")


def test_frf_command_damping_option(tmp_path: Path, monkeypatch, capsys) -> None:
    """Reference: the closed form ``1/(k(1 + iη) − mω²)`` (default) and the viscous closed
    form (``--damping viscous``) through ``neweul frf``'s CSV output."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sdof.yaml").write_text(SDOF)
    f = np.array([1.0, 10.0, 100.0])
    w, w_ref = 2 * np.pi * f, 2 * np.pi * F_REF
    refs = {"loss": 1.0 / (K * (1 + 1j * ETA) - M * w**2),
            "viscous": 1.0 / (K + 1j * w * ETA * K / w_ref - M * w**2)}
    for form, ref in refs.items():
        assert main(["frf", "sdof.yaml", "--input", "F", "--response", "pos", "--f",
                     "1,10,100", "--damping", form, "-o", f"{form}.csv"]) == 0
        data = np.genfromtxt(f"{form}.csv", delimiter=",", names=True)
        H = data["magnitude"] * np.exp(1j * np.deg2rad(data["phase_deg"]))
        assert np.allclose(H, ref, rtol=1e-9)
