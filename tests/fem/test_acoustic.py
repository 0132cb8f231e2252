"""Acoustic pressure elements vs. closed-form rigid-wall resonances."""

from __future__ import annotations

import numpy as np
import scipy.sparse.linalg as spla

from neweul_py.fem.acoustic import acoustic_matrices, surface_load
from neweul_py.fem.mesh import box_tets, cone_membrane, extrude_tets

C_AIR = 343.0


def _freqs(mf, kf, k):
    w = spla.eigsh(kf, M=mf, k=k, sigma=-1.0, which="LM")[0]
    return np.sort(np.sqrt(np.abs(w))) / (2 * np.pi)


def test_box_cavity_resonances():
    """Rigid box: f = c/2 · sqrt((l/Lx)² + (m/Ly)² + (n/Lz)²) (e.g. Kinsler & Frey, ch. 9)."""
    lx, ly, lz = 0.5, 0.3, 0.2
    mf, kf = acoustic_matrices(box_tets((lx, ly, lz), (20, 12, 8)), C_AIR)
    f = _freqs(mf, kf, 6)
    modes = sorted(
        C_AIR / 2 * np.sqrt((i / lx) ** 2 + (j / ly) ** 2 + (k / lz) ** 2)
        for i in range(4)
        for j in range(3)
        for k in range(3)
    )[:6]
    assert abs(f[0]) < 1e-3  # constant-pressure mode
    np.testing.assert_allclose(f[1:], modes[1:], rtol=0.02)


def test_duct_resonances_of_canal_mesh():
    """Closed-closed cylindrical duct (the canal mesher with a flat end): f_n = n c / (2 L)."""
    length, radius = 0.025, 0.00375
    tm = cone_membrane(radius, 0.0, 4)

    def morph(p, s):
        return p + np.array([0.0, 0.0, -s * length])

    mesh, _, far = extrude_tets(tm.points, tm.triangles, 40, morph)
    mf, kf = acoustic_matrices(mesh, C_AIR)
    f = _freqs(mf, kf, 4)
    np.testing.assert_allclose(f[1:], C_AIR * np.arange(1, 4) / (2 * length), rtol=0.01)
    # volume of the duct from Mf and the surface load of the entrance
    ones = np.ones(mf.shape[0])
    np.testing.assert_allclose(ones @ mf @ ones * C_AIR**2, np.pi * radius**2 * length, rtol=0.03)
    area = surface_load(mesh.points, far[tm.triangles]).sum()
    np.testing.assert_allclose(area, np.pi * radius**2, rtol=0.03)
