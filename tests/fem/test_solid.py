"""Solid elements (neweul_py.fem.solid): Hex8, Hex20, Tet10 boxes and their stress stiffness.

Independent references: the total mass ρV and rigid-body null space of K; Timoshenko beam
theory for a slender cantilever's tip deflection ``PL³/(3EI) + PL/(κGA)``; the closed form of
the initial-stress quadratic form ``vᵀ K_G v = ∫ σ_ij ∂_i v_k ∂_j v_k dV`` for a uniform uniaxial
stress ``σ_xx = S`` and the linear field ``v = (0, x, 0)``: ``S·V``; a rigid rotation has no
linear stress (``K_G = 0``).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from neweul_py.cli import main
from neweul_py.elastic import read_fe_model
from neweul_py.elastic.io.fe_files import read_node_sets
from neweul_py.elastic.reductors.interface import rigid_body_fields
from neweul_py.errors import ModelError
from neweul_py.fem.solid import SolidMaterial, solid_box

MAT = SolidMaterial(E=1.0e4, nu=0.3, rho=2.0)
SIZE = (1.0, 0.1, 0.05)


@pytest.mark.parametrize("element", ["hex8", "hex20", "tet10"])
def test_mass_rigid_modes_and_uniform_stress(element):
    """M sums to ρV in every direction, K annihilates the six rigid-body fields, and the
    initial-stress form of a uniform axial stress is σ·V for v = (0, x, 0)."""
    s = solid_box(SIZE, (4, 2, 1), MAT, element=element, origin=(0.3, -0.2, 0.1))
    fe = s.fe
    T = rigid_body_fields(fe)
    vol = np.prod(SIZE)
    np.testing.assert_allclose(np.diag(T[:, :3].T @ (fe.M @ T[:, :3])), MAT.rho * vol,
                               rtol=1e-12)
    assert abs(fe.K @ T).max() < 1e-10 * abs(fe.K).max()
    x = fe.nodes[:, 1:]
    e = 1e-3
    u = np.zeros(fe.n_dofs)
    u[0::3], u[1::3], u[2::3] = e * x[:, 0], -MAT.nu * e * x[:, 1], -MAT.nu * e * x[:, 2]
    KG = s.geometric_stiffness(u)
    v = np.zeros(fe.n_dofs)
    v[1::3] = x[:, 0]
    assert v @ (KG @ v) == pytest.approx(MAT.E * e * vol, rel=1e-10)
    assert abs(KG - KG.T).max() < 1e-12 * abs(KG).max()
    assert abs(s.geometric_stiffness(T @ np.array([0, 0, 0, 0.1, -0.2, 0.3]))).max() \
        < 1e-8 * abs(KG).max()           # KG(u) of a strain 1e-3 vs a rotation of 0.37


@pytest.mark.parametrize(("element", "divisions", "rtol"),
                         [("hex20", (10, 2, 1), 0.03), ("tet10", (10, 2, 1), 0.03),
                          ("hex8", (20, 4, 2), 0.35)])
def test_cantilever_tip_deflection(element, divisions, rtol):
    """Tip shear load P on the root-clamped box: δ within a few % of Timoshenko beam theory
    for the quadratic elements (the root clamp stiffens a little); trilinear Hex8 locks."""
    s = solid_box(SIZE, divisions, MAT, element=element)
    fe = s.fe
    fixed = fe.dofs_of_nodes(s.node_sets["root"])
    free = np.setdiff1d(np.arange(fe.n_dofs), fixed)
    tip = fe.dofs_of_nodes(s.node_sets["tip"])
    tz = tip[fe.dof_kind[tip] == "uz"]
    P = 1e-3
    f = np.zeros(fe.n_dofs)
    f[tz] = P / tz.size
    u = np.zeros(fe.n_dofs)
    u[free] = spla.spsolve(fe.K.tocsc()[free][:, free], f[free])
    b, h = SIZE[1], SIZE[2]
    I, G = b * h**3 / 12, MAT.E / (2 * (1 + MAT.nu))
    ref = P * SIZE[0] ** 3 / (3 * MAT.E * I) + P * SIZE[0] / (5 / 6 * G * b * h)
    assert np.mean(u[tz]) == pytest.approx(ref, rel=rtol)
    if element != "hex8":
        assert np.mean(u[tz]) < ref        # the clamped root face is stiffer than a beam's


def test_bad_input():
    """Unknown element, wrong lengths/divisions, bad material: one ModelError each."""
    with pytest.raises(ModelError, match="unknown solid element"):
        solid_box(element="hex27")
    with pytest.raises(ModelError, match="lengths"):
        solid_box((1.0, -0.1, 0.1))
    with pytest.raises(ModelError, match="divisions"):
        solid_box(divisions=(2, 0, 1))
    with pytest.raises(ModelError, match="Poisson"):
        SolidMaterial(nu=0.5)


def test_fem_solid_beam_command(tmp_path, capsys):
    """`neweul fem solid-beam` writes solid_box's model with the root/tip node sets."""
    out = tmp_path / "s.npz"
    assert main(["fem", "solid-beam", "--size", "1,0.1,0.05", "--divisions", "4,2,1",
                 "--element", "tet10", "--E", "1e4", "-o", str(out)]) == 0
    assert "DOFs" in capsys.readouterr().out
    fe = read_fe_model(out)
    ref = solid_box(SIZE, (4, 2, 1), SolidMaterial(E=1e4), element="tet10")
    assert abs(fe.K - ref.fe.K).max() < 1e-12 * abs(ref.fe.K).max()
    sets = read_node_sets(out)
    np.testing.assert_array_equal(sets["root"], ref.node_sets["root"])
    with pytest.raises(SystemExit):
        main(["fem", "solid-beam", "--size", "1,2", "-o", str(out)])
    assert "expected 3 comma-separated lengths" in capsys.readouterr().err
