"""An elastic body hung on a node frame of a *two-sided* elastic body
(``docs/equations.md`` §2): its loads reach the host's elastic equations through the left
basis, ``W_Pᵀ f``, exactly as those of a rigid body on that node (``M = S_Wᵀ M_s S_V``).

Reference: the same model with a rigid body of the child's mass properties (``m``, centre
of mass ``md/m``, inertia about it from ``J``) in place of the elastic child — a different
path through the code (symbolic rigid-body equations mapped by ``S_W``, ``S_V``). At
``q_child = q̇_child = 0`` every row and column but the child's own must agree.
"""

from __future__ import annotations

import numpy as np
import pytest
from beam_fe import beam
from fe_builders import piston_duct

from neweul_py.analysis import load_generated
from neweul_py.api import generate

HOST = """
name: {name}
parameters: {{g: 9.81}}
gravity: [0, -g, 0]
coordinates: {{a: {{}}}}
frames:
  hub: {{rotation: [[z, a]]}}
elastic_bodies:
  duct: {{frame: hub, data: duct.npz, nodes: {{piston: 1}}}}
{child}
"""


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """(rigid-child module, elastic-child module, host body, child mass)."""
    from neweul_py.elastic import reduce_modal, save_reduced_body
    from neweul_py.elastic.reductors.invariants import attach_invariants, compute_invariants
    from neweul_py.model import ElasticBody

    tmp = tmp_path_factory.mktemp("child_on_node")
    fe = piston_duct(n_el=40)
    host = reduce_modal(fe, modes=6, two_sided=True, keep_nodes=[1], store_bases=True)
    host = attach_invariants(host, fe, nodes=[1])
    save_reduced_body(host, tmp / "duct.npz")
    b = beam(2, length=0.2, A=0.05, Iy=1e-5, Iz=4e-5, offset=(0.02, 0.05, 0.01), E=1e3)
    _lam, V = b.clamped_modes(1)
    inv = compute_invariants(b.fe, V)
    np.savez(tmp / "child.npz", **inv.to_flat())
    m = float(inv.m)
    c = inv.md.m0[:, 0] / m
    Ic = inv.J.m0 - m * (c @ c * np.eye(3) - np.outer(c, c))
    rigid = HOST.format(name="rigid_child", child=f"""bodies:
  A: {{frame: duct.piston, mass: {m!r}, center_of_mass: {c.tolist()!r},
      inertia: {Ic.tolist()!r}}}""")
    elastic = HOST.format(name="elastic_child",
                          child="  B: {frame: duct.piston, data: child.npz}")
    mods = []
    for name, text in (("rigid", rigid), ("elastic", elastic)):
        (tmp / f"{name}.yaml").write_text(text)
        mods.append(load_generated(generate(tmp / f"{name}.yaml", tmp / "gen")))
    from neweul_py.elastic.io.reader import read_elastic_data

    duct = ElasticBody("duct", "ISYS", read_elastic_data(tmp / "duct.npz", None), (("p", 1),))
    return (*mods, duct, m)


def _state(n: int):
    rng = np.random.default_rng(7)
    return 0.01 * rng.normal(size=n), 0.3 * rng.normal(size=n)


def test_elastic_child_on_two_sided_node_equals_rigid_child(pair) -> None:
    """Host block (rows and columns of ``a`` and the host modes) of ``M`` and ``q − k`` with
    the elastic child equals that with the rigid child (``Me + m W_Pᵀ Φ_P`` in the host
    modes, not ``m Φ_Pᵀ Φ_P``); the host's ``W_P`` differs from ``Φ_P`` so the test can
    tell."""
    R, E, duct, m = pair
    assert duct.two_sided and duct.node_components("p") == (0,)
    tv, tw = duct.node_maps("p")
    assert E.COORDINATES == [*R.COORDINATES, "B_q1"]
    assert np.abs(tw - tv).max() > 0.1 * np.abs(tv).max()
    n = len(R.COORDINATES)
    p = R.default_parameters()
    y, yd = _state(n)
    yE, ydE = np.append(y, 0.0), np.append(yd, 0.0)
    MR = R.mass_matrix(0.0, y, p)
    ME = E.mass_matrix(0.0, yE, p)
    scale = np.abs(MR).max()
    np.testing.assert_allclose(ME[:n, :n], MR, rtol=1e-12, atol=1e-12 * scale)
    fR = R.force_vector(0.0, y, yd, p)
    fE = E.force_vector(0.0, yE, ydE, p)
    np.testing.assert_allclose(fE[:n], fR, rtol=1e-10, atol=1e-12 * np.abs(fR).max())
    # the child's share of the host-mode block is m W_Pᵀ Φ_P (the node moves in ux only)
    E0 = E.mass_matrix(0.0, np.zeros(n + 1), p)[1:n, 1:n]
    share = m * np.outer(tw[0], tv[0])
    np.testing.assert_allclose(E0, duct.data["Me.m0"] + share, rtol=1e-12, atol=1e-12 * scale)
    assert np.abs(share - m * np.outer(tv[0], tv[0])).max() > 0.1 * np.abs(share).max()


def test_elastic_child_on_two_sided_node_jacobians(pair) -> None:
    """The host blocks of ``∂(q−k)/∂y``, ``∂(q−k)/∂ẏ`` and ``∂(M a)/∂y`` of the elastic-child
    module equal those of the rigid-child module (symbolic derivatives), and the whole
    ``force_jacobians`` equals central differences of its ``force_vector``."""
    R, E, _duct, _m = pair
    n = len(R.COORDINATES)
    p = R.default_parameters()
    y, yd = _state(n)
    yE, ydE = np.append(y, 0.0), np.append(yd, 0.0)
    fyR, fydR, _ = R.force_jacobians(0.0, y, yd, p)
    fyE, fydE, _ = E.force_jacobians(0.0, yE, ydE, p)
    for got, ref in ((fyE[:n, :n], fyR), (fydE[:n, :n], fydR)):
        np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-10 * np.abs(ref).max())
    a = np.random.default_rng(8).normal(size=n)
    dR = R.mass_matrix_times_derivative(0.0, y, p, a)
    dE = E.mass_matrix_times_derivative(0.0, yE, p, np.append(a, 0.0))
    np.testing.assert_allclose(dE[:n, :n], dR, rtol=1e-9,
                               atol=1e-12 * np.abs(R.mass_matrix(0.0, y, p)).max())
    h = 1e-6
    fd = np.empty_like(fyE)
    for j in range(n + 1):
        e = np.zeros(n + 1)
        e[j] = h
        fd[:, j] = (E.force_vector(0.0, yE + e, ydE, p) - E.force_vector(0.0, yE - e, ydE, p)) \
            / (2 * h)
    np.testing.assert_allclose(fyE, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())
