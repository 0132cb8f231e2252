"""The TM shell element on a flat clamped circular plate vs. classical plate/membrane results.

The eigenfrequencies and the small deflection are checked on the centred disc mesh and on the
off-centre one of the TM (umbo 0.16 a off the rim's centre, docs/equations-middle-ear.md §1):
the plate is the same, only its nodes are placed differently, so both must meet the closed
forms."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from neweul_py.fem.mesh import cone_membrane
from neweul_py.fem.nonlinear import NewtonOptions, load_path
from neweul_py.fem.shell import ShellMaterial, ShellStructure


def _plate(a, mat, rings, umbo_offset=0.0):
    mesh = cone_membrane(a, 0.0, rings, umbo_offset=umbo_offset)
    shell = ShellStructure.create(mesh.points, mesh.triangles, mat)
    free = np.ones(shell.n_dof, bool)
    free[(3 * mesh.boundary[:, None] + np.arange(3)).ravel()] = False
    return mesh, shell, np.flatnonzero(free)


def _residual(shell, fi):
    """``R(u, Δp)`` on the free DOFs: membrane + bending − follower pressure, and its tangent."""

    def residual(uf, load):
        u = np.zeros(shell.n_dof)
        u[fi] = uf
        _, f, k = shell.membrane(u)
        _, g, kp = shell.pressure(u, load)
        r = (f + shell.bending @ u - g)[fi]
        return r, (k + shell.bending + kp)[fi][:, fi], np.linalg.norm(g)

    return residual


def _centre_uz(fi):
    return np.flatnonzero((fi // 3 == 0) & (fi % 3 == 2))[0]


@pytest.mark.parametrize("umbo_offset", [0.0, 0.16])
def test_clamped_plate_eigenfrequencies(umbo_offset):
    """ω = λ²/a² · sqrt(D/(ρt)), λ² = 10.2158, 21.26 (Leissa 1969, NASA SP-160, Table 2.1)."""
    a = 0.1
    mat = ShellMaterial(E=70e9, nu=0.3, t=0.002, rho=2700)
    _, shell, fi = _plate(a, mat, 16, umbo_offset)
    k = (shell.membrane(np.zeros(shell.n_dof))[2] + shell.bending)[fi][:, fi]
    m = shell.mass()[fi][:, fi]
    z = fi % 3 == 2
    w = spla.eigsh(k[z][:, z], M=m[z][:, z], k=3, sigma=0, which="LM")[0]
    lam2 = np.sqrt(w) * a**2 / np.sqrt(mat.bending_stiffness / (mat.rho * mat.t))
    np.testing.assert_allclose(lam2, [10.2158, 21.260, 21.260], rtol=0.01)


@pytest.mark.parametrize("umbo_offset", [0.0, 0.16])
def test_small_deflection_centre(umbo_offset):
    """Clamped plate, uniform pressure: w(r) = p (a² − r²)² / (64 D) (Timoshenko &
    Woinowsky-Krieger §62), at node 0 (the centre, or ``r = e a`` off it)."""
    a, p = 0.1, 10.0
    mat = ShellMaterial(E=70e9, nu=0.3, t=0.002, rho=2700)
    _, shell, fi = _plate(a, mat, 16, umbo_offset)

    residual = _residual(shell, fi)
    (st,) = load_path(residual, fi.size, [p], NewtonOptions(first_step=p))
    w0 = st.u[_centre_uz(fi)]
    r = umbo_offset * a
    np.testing.assert_allclose(w0, p * (a**2 - r**2) ** 2 / (64 * mat.bending_stiffness),
                               rtol=0.03)


def test_large_deflection_hencky():
    """Membrane regime: w0 = 0.662 a (p a / (E t))^(1/3) for ν = 0.3 (Hencky 1915;
    Timoshenko & Woinowsky-Krieger §103), here with w0/t ≈ 140, w0/a ≈ 0.14."""
    a, p = 0.1, 100.0
    mat = ShellMaterial(E=1e7, nu=0.3, t=1e-4, rho=1000)
    _, shell, fi = _plate(a, mat, 12)

    residual = _residual(shell, fi)
    opts = NewtonOptions(first_step=1.0, max_step=100.0, min_step=1e-3)
    (st,) = load_path(residual, fi.size, [p], opts)
    w0 = st.u[_centre_uz(fi)]
    np.testing.assert_allclose(w0, 0.662 * a * (p * a / (mat.E * mat.t)) ** (1 / 3), rtol=0.03)


def test_tangent_is_consistent():
    """The assembled tangent matches a finite difference of the residual (central, O(h²))."""
    a = 0.01
    mat = ShellMaterial(E=32e6, nu=0.3, t=8e-5, rho=1200)
    mesh = cone_membrane(a, 0.003, 4)
    shell = ShellStructure.create(mesh.points, mesh.triangles, mat)
    rng = np.random.default_rng(1)
    u = rng.normal(size=shell.n_dof) * 1e-4

    def r(v):
        return shell.membrane(v, tangent=False)[1] - shell.pressure(v, 3000.0)[1]

    k = shell.membrane(u)[2] + shell.pressure(u, 3000.0)[2]
    du = rng.normal(size=shell.n_dof) * 1e-8
    fd = r(u + du) - r(u - du)
    np.testing.assert_allclose(fd, 2 * k @ du, atol=1e-6 * np.abs(fd).max())
