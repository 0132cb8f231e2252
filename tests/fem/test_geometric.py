"""Stress stiffness of the facet shell (neweul_py.fem.geometric).

Independent references: a flat membrane under uniform equi-biaxial strain ``e`` carries the
membrane force ``N = E t e/(1 − ν)`` in every direction, so the initial-stress form of the
out-of-plane slope field ``w = x`` is ``vᵀ K_G v = N·A``; the stress part of the nonlinear
membrane tangent of ShellStructure.membrane at ``εu`` divided by ``ε`` tends to ``K_G(u)``.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from neweul_py.fem.geometric import shell_geometric_stiffness, shell_model, shell_stiffening
from neweul_py.fem.shell import ShellMaterial, ShellStructure


def square(n: int = 4, size: float = 2.0):
    g = np.linspace(0, size, n + 1)
    X, Y = np.meshgrid(g, g, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    idx = np.arange(pts.shape[0]).reshape(n + 1, n + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), \
        idx[:-1, 1:].ravel()
    tri = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return pts, tri


def test_uniform_biaxial_membrane_force():
    """vᵀ K_G v = N A for w = x under equi-biaxial strain e, N = E t e/(1 − ν)."""
    pts, tri = square()
    mat = ShellMaterial(E=2.0e6, nu=0.3, t=1e-3, rho=1.0)
    shell = ShellStructure.create(pts, tri, mat)
    e = 1e-4
    u = np.zeros_like(pts)
    u[:, :2] = e * pts[:, :2]
    KG = shell_geometric_stiffness(shell, u.ravel())
    v = np.zeros_like(pts)
    v[:, 2] = pts[:, 0]
    N = mat.E * mat.t * e / (1 - mat.nu)
    assert v.ravel() @ (KG @ v.ravel()) == pytest.approx(N * 4.0, rel=1e-12)


def test_matches_nonlinear_membrane_tangent():
    """(K_T(εu) − K_T(0) − material change) / ε → K_G(u): checked on the out-of-plane block,
    where the material tangent of a flat membrane does not change to first order."""
    pts, tri = square(3)
    pts[:, 2] = 0.0
    mat = ShellMaterial(E=1.0e6, nu=0.25, t=1e-3, rho=1.0)
    shell = ShellStructure.create(pts, tri, mat)
    u = np.random.default_rng(3).normal(size=pts.shape) * 1e-2
    u[:, 2] = 0.0                                # in-plane state: out-of-plane block = K_G
    eps = 1e-6
    _, _, kt = shell.membrane(eps * u)
    _, _, k0 = shell.membrane(np.zeros_like(u))
    z = np.arange(2, 3 * pts.shape[0], 3)
    lhs = ((kt - k0)[z][:, z] / eps).toarray()
    ref = shell_geometric_stiffness(shell, u.ravel())[z][:, z].toarray()
    np.testing.assert_allclose(lhs, ref, rtol=1e-5, atol=1e-6 * abs(ref).max())


def strip(nx: int, ny: int, lx: float, ly: float):
    gx, gy = np.linspace(0, lx, nx + 1), np.linspace(-ly / 2, ly / 2, ny + 1)
    X, Y = np.meshgrid(gx, gy, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    idx = np.arange(pts.shape[0]).reshape(nx + 1, ny + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), \
        idx[:-1, 1:].ravel()
    return pts, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def test_spinning_strip_stiffening():
    """A narrow strip clamped at x = 0 spinning about z: the ωz² state is tension, so K_G is
    positive semidefinite on the out-of-plane DOFs, and the first flapwise ω² rises by
    α Ω² with α near Southwell's 1.193 of a cantilever (here 1.14: the facet shell's
    boundary sides also hold the normal slope at the free tip, see fem/shell.py)."""
    pts, tri = strip(40, 2, 1.0, 0.05)
    shell = ShellStructure.create(pts, tri, ShellMaterial(E=1e6, nu=0.0, t=1e-2, rho=1.0))
    fe = shell_model(shell)
    root = fe.nodes[np.isclose(pts[:, 0], 0.0), 0].astype(int)
    support = fe.dofs_of_nodes(root)
    KG = shell_stiffening(shell, fe, support, cases=["wzz"])["wzz"]
    z = np.setdiff1d(np.arange(2, fe.n_dofs, 3), support)
    G = KG[z][:, z].toarray()
    ev = np.linalg.eigvalsh(G)
    assert ev.min() > -1e-10 * ev.max() and ev.max() > 0
    K, M = fe.K[z][:, z].toarray(), fe.M[z][:, z].toarray()
    lam0 = sla.eigh(K, M, eigvals_only=True, subset_by_index=[0, 0])[0]
    om2 = 0.25 * lam0
    lam = sla.eigh(K + om2 * G, M, eigvals_only=True, subset_by_index=[0, 0])[0]
    assert (lam - lam0) / om2 == pytest.approx(1.1932, rel=0.06)
