"""A constraint on a node frame of a *two-sided* elastic body (``docs/equations.md``
§1 and §2): the constraint itself moves with the right basis (``g(S_V y)``, ``G = G_s S_V``,
``γ``), its reactions enter the host's elastic rows through the left basis,
``G_Rᵀ λ = (G_s S_W)ᵀ λ`` (``constraint_reaction_jacobian``), like every other node load.

Reference (independent path through the code): the same rigid point mass ``B`` hung on the
node frame as a child (``frame: duct.piston``, no constraint) instead of a free point mass
``(bx, by, bz)`` tied to the node by a ``coincide`` constraint. The u–p piston–duct host
(Eq. (2), tests/support/fe_builders.py) has ``W_P ≠ Φ_P`` at the piston node, so the test can
tell ``G_s S_W`` from ``G_s S_V``; the multipliers are the force the node exerts on ``B``,
``λ = m_B (a_B − g)``, with ``a_B`` the node acceleration of the reference.
"""

from __future__ import annotations

import types

import numpy as np
import pytest
from fe_builders import piston_duct

from neweul_py.analysis import load_generated
from neweul_py.analysis.dae import consistent_initial_state, simulate_constrained
from neweul_py.analysis.equilibrium import equilibrium
from neweul_py.analysis.linearize import linearize
from neweul_py.analysis.modes import modes
from neweul_py.analysis.simulate import simulate
from neweul_py.api import generate

MB, GRAV = 0.03, 9.81
MODEL = """
name: {name}
parameters: {{g: {grav!r}, mB: {mb!r}, ka: 40.0}}
gravity: [0, -g, 0]
coordinates: {{a: {{initial: 0.2}}{extra}}}
inputs: {{Md: 0}}
frames:
  hub: {{rotation: [[z, a]]}}
  arm: {{parent: hub, translation: [0.3, 0, 0], rotation: [[z, 0.4]]}}
{frames}
elastic_bodies:
  duct: {{frame: arm, data: {tag}.npz, nodes: {{piston: 1}}}}
bodies:
  B: {{frame: {bframe}, mass: mB}}
forces:
  spring: {{type: rotational_spring_damper, coordinate: a, stiffness: ka, damping: 0.01}}
  drive: {{type: generalized, coordinate: a, value: Md}}
outputs:
  px: {{position: duct.piston, component: x}}
  py: {{position: duct.piston, component: y}}
  vx: {{velocity: duct.piston, component: x}}
  vy: {{velocity: duct.piston, component: y}}
  vz: {{velocity: duct.piston, component: z}}
{cons}
"""


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    """tag → (constrained module, rigid-child reference module) for a two- and a one-sided
    host."""
    from neweul_py.elastic import reduce_modal, save_reduced_body
    from neweul_py.elastic.reductors.invariants import attach_invariants

    tmp = tmp_path_factory.mktemp("constraint_on_node")
    fe = piston_duct(n_el=40)
    out = {}
    for tag, two in (("two", True), ("one", False)):
        host = reduce_modal(fe, modes=5, two_sided=two, keep_nodes=[1], store_bases=True,
                            skip_rigid=True)
        save_reduced_body(attach_invariants(host, fe, nodes=[1]), tmp / f"{tag}.npz")
        common = {"tag": tag, "grav": GRAV, "mb": MB}
        texts = {
            f"con_{tag}": MODEL.format(
                name=f"con_{tag}", extra=", bx: {}, by: {}, bz: {}",
                frames="  bf: {translation: [bx, by, bz]}", bframe="bf",
                cons="constraints:\n  pin: {coincide: [duct.piston, bf]}", **common),
            f"ref_{tag}": MODEL.format(name=f"ref_{tag}", extra="", frames="",
                                       bframe="duct.piston", cons="", **common),
        }
        mods = []
        for name, text in texts.items():
            (tmp / f"{name}.yaml").write_text(text)
            mods.append(load_generated(generate(tmp / f"{name}.yaml", tmp / "gen")))
        out[tag] = tuple(mods)
    return out


def _start(C, R):
    """A consistent state of ``C`` from a random state of the reference ``R``: ``(y, ẏ)`` of
    ``C``, the reference's ``(y, ẏ)`` and the positions of its coordinates in ``C``."""
    rng = np.random.default_rng(3)
    n = len(R.COORDINATES)
    yR = np.r_[0.2, 1e3 * rng.normal(size=n - 1)]       # piston Φ_P q ≈ 1e-4 m
    ydR = np.r_[0.5, 1e5 * rng.normal(size=n - 1)]
    idx = [C.COORDINATES.index(c) for c in R.COORDINATES]
    y0, yd0 = np.zeros(len(C.COORDINATES)), np.zeros(len(C.COORDINATES))
    y0[idx], yd0[idx] = yR, ydR
    y, yd = consistent_initial_state(C, y0, yd0, independent=R.COORDINATES)
    np.testing.assert_array_equal(y[idx], yR)
    return y, yd, yR, ydR, idx


def _node_force(R, t, yR, ydR, p):
    """``m_B (a_B − g)`` with the node acceleration ``a_B = ∂v/∂y ẏ + ∂v/∂ẏ ÿ`` of the
    reference (its analytic output Jacobians and its own ``ÿ``)."""
    n = len(yR)
    x = np.concatenate([yR, ydR])
    ydd = R.rhs(t, x, p)[n:]
    Cj, _ = R.output_jacobians(t, x, p)
    rows = [R.OUTPUTS.index(v) for v in ("vx", "vy", "vz")]
    acc = Cj[rows, :n] @ ydR + Cj[rows, n:] @ ydd
    return MB * (acc - np.array([0.0, -GRAV, 0.0]))


def test_reaction_jacobian_uses_the_left_basis(models) -> None:
    """``G_R`` and ``G`` agree in the rigid columns and differ (``W_P`` vs ``Φ_P``) in the host
    modes of the row along the piston; for the one-sided host they are the same array."""
    C, _R = models["two"]
    p = C.default_parameters()
    y = np.asarray(C.INITIAL_STATE[:len(C.COORDINATES)])
    G, GR = C.constraint_jacobian(0.0, y, p), C.constraint_reaction_jacobian(0.0, y, p)
    modal = [j for j, c in enumerate(C.COORDINATES) if c.startswith("duct_q")]
    rigid = [j for j in range(len(C.COORDINATES)) if j not in modal]
    np.testing.assert_array_equal(G[:, rigid], GR[:, rigid])
    assert np.abs(GR[:, modal] - G[:, modal]).max() > 0.1 * np.abs(GR[:, modal]).max()
    C1, _ = models["one"]
    np.testing.assert_array_equal(C1.constraint_jacobian(0.0, y, p),
                                  C1.constraint_reaction_jacobian(0.0, y, p))


def test_dae_motion_and_multipliers_equal_the_rigid_attachment(models) -> None:
    """Constrained DAE (two-sided host) vs the point mass hung on the node: the motion of the
    hub angle and the host modes over 4 ms (≈ 3 periods of the piston mode), and at every
    output time ``λ = m_B (a_B − g)`` of the reference. With ``G`` in place of ``G_R`` (the old
    reactions ``Φ_Pᵀ λ``) the accelerations are off by 10–30 %."""
    C, R = models["two"]
    p = C.default_parameters()
    y, yd, yR, ydR, idx = _start(C, R)
    times = np.linspace(0.0, 0.004, 9)
    sim = simulate_constrained(C, 0.004, t_eval=times, y0=y, yd0=yd,
                               independent=R.COORDINATES, rtol=1e-11, atol=1e-12)
    ref = simulate(R, 0.004, t_eval=times, x0=np.concatenate([yR, ydR]), method="DOP853",
                   rtol=1e-11, atol=1e-12)
    scale = np.abs(ref.y).max(axis=0)
    np.testing.assert_allclose(sim.y[:, idx], ref.y, rtol=0, atol=1e-9 * scale.max())
    for k, t in enumerate(times):
        want = _node_force(R, t, ref.y[k], ref.yd[k], p)
        np.testing.assert_allclose(sim.lambdas[k], want, rtol=1e-8,
                                   atol=1e-8 * np.abs(want).max())
    # the first multiplier, tightly (no integration error)
    want = _node_force(R, 0.0, yR, ydR, p)
    np.testing.assert_allclose(sim.lambdas[0], want, rtol=1e-9, atol=1e-12)
    assert sim.max_drift < 1e-9


def test_equilibrium_and_linear_model_equal_the_rigid_attachment(models) -> None:
    """Static equilibrium (``λ = −m_B g``: the node carries the weight of B) and the linearized
    model about it (eigenvalues; FRF drive torque → node position, also read as the dependent
    coordinates ``bx``, ``by`` of the constrained model) equal those of the reference."""
    C, R = models["two"]
    eqC = equilibrium(C)
    eqR = equilibrium(R)
    idx = [C.COORDINATES.index(c) for c in R.COORDINATES]
    np.testing.assert_allclose(eqC.y[idx], eqR.y, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(eqC.lambda_, [0.0, MB * GRAV, 0.0], atol=1e-10)
    linC = linearize(C, eqC, independent=R.COORDINATES)
    linR = linearize(R, eqR)
    assert linC.coordinates == linR.coordinates
    evC = np.sort_complex(modes(linC).eigenvalues)
    evR = np.sort_complex(modes(linR).eigenvalues)
    np.testing.assert_allclose(evC, evR, rtol=1e-7)  # 6e-9 seen; G instead of G_R: 1.5e-2
    # The default partition must not make a mode coordinate (tiny G column) dependent:
    # the eigenvalues are the same for any well-conditioned choice.
    lin_default = linearize(C, eqC)
    assert not set(lin_default.coordinates) & {"bx", "by", "bz"}
    np.testing.assert_allclose(np.sort_complex(modes(lin_default).eigenvalues), evR, rtol=1e-6)
    from neweul_py.analysis.frf import frequency_response

    f = np.linspace(5.0, 1500.0, 40)
    hR = frequency_response(linR, f, "Md", ["px", "py"]).H
    hC = frequency_response(linC, f, "Md", ["px", "py"]).H
    hB = frequency_response(linC, f, "Md", ["bx", "by"]).H
    for h in (hC, hB):
        np.testing.assert_allclose(h, hR, rtol=1e-7, atol=1e-9 * np.abs(hR).max())


def test_one_sided_host_is_unchanged(models) -> None:
    """One-sided host: the reaction Jacobian is ``G`` itself, so the DAE, the equilibrium and
    the linear model are the same with and without the module's ``constraint_reaction_jacobian``
    (a module written before it existed), bit for bit, and equal the rigid attachment."""
    C, R = models["one"]
    old = types.SimpleNamespace(**{k: v for k, v in vars(C).items()
                                   if k != "constraint_reaction_jacobian"})
    p = C.default_parameters()
    y, yd, yR, ydR, _idx = _start(C, R)
    runs = [simulate_constrained(m, 0.001, n_out=3, y0=y, yd0=yd, independent=R.COORDINATES)
            for m in (C, old)]
    np.testing.assert_array_equal(runs[0].y, runs[1].y)
    np.testing.assert_array_equal(runs[0].lambdas, runs[1].lambdas)
    want = _node_force(R, 0.0, yR, ydR, p)
    np.testing.assert_allclose(runs[0].lambdas[0], want, rtol=1e-9, atol=1e-12)
    eqs = [equilibrium(m) for m in (C, old)]
    np.testing.assert_array_equal(eqs[0].y, eqs[1].y)
    np.testing.assert_array_equal(eqs[0].lambda_, eqs[1].lambda_)
    lins = [linearize(m, e, independent=R.COORDINATES) for m, e in zip((C, old), eqs,
                                                                         strict=True)]
    for name in ("M0", "P", "Q", "B", "basis"):
        np.testing.assert_array_equal(getattr(lins[0], name), getattr(lins[1], name))
