"""The u–p coupling of Eq. (2): a piston on a spring closing a rigid tube (sign of C)."""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sps
from scipy.optimize import brentq

from neweul_py.fem.acoustic import acoustic_matrices
from neweul_py.fem.coupling import assemble_up, coupling_matrix
from neweul_py.fem.mesh import box_tets

RHO, C_AIR = 1.2, 343.0


def _piston_tube(length, width, mass, stiffness, nz=40):
    mesh = box_tets((width, width, length), (2, 2, nz))
    mf, kf = acoustic_matrices(mesh, C_AIR)
    face = np.flatnonzero(np.abs(mesh.points[:, 2]) < 1e-12)
    local = -np.ones(mesh.points.shape[0], dtype=int)
    local[face] = np.arange(face.size)
    # triangles of the face z = 0 from the tetrahedra's faces lying in it
    tri = []
    for f in ([0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]):
        t = mesh.tets[:, f]
        on = np.all(local[t] >= 0, axis=1)
        tri.append(t[on])
    tri = local[np.vstack(tri)]
    xs = mesh.points[face]
    nrm = np.cross(xs[tri[:, 1]] - xs[tri[:, 0]], xs[tri[:, 2]] - xs[tri[:, 0]])
    tri[nrm[:, 2] < 0] = tri[nrm[:, 2] < 0][:, [0, 2, 1]]  # orient +z (into the fluid)
    # fluid in z > 0: the normal out of the fluid is −z → sign −1; piston DOF u along +z
    c_nodes = coupling_matrix(xs, tri, np.arange(face.size), face, face.size, mf.shape[0], -1.0)
    t = sps.csr_matrix(
        (np.ones(face.size), (3 * np.arange(face.size) + 2, np.zeros(face.size))),
        shape=(3 * face.size, 1),
    )
    c = (t.T @ c_nodes).tocsr()
    ms = sps.csr_matrix([[mass]])
    ks = sps.csr_matrix([[stiffness]])
    return assemble_up(ms, ks, mf, kf, c, RHO), c


def test_piston_closing_a_tube():
    """Piston (m, k) at z = 0 of a rigid tube (area S, length L, closed at z = L):
    k − m ω² + ρ S ω² cot(ωL/c) / (ω/c) = 0 (plane waves; e.g. Fahy, *Sound and Structural
    Vibration*, ch. 6). The gas spring ρc²S/L stiffens the piston, as it must."""
    length, width, mass, stiffness = 0.1, 0.01, 1e-3, 2e3
    s = width**2
    (m, _, k), c = _piston_tube(length, width, mass, stiffness)
    np.testing.assert_allclose(c.sum(), -s, rtol=1e-12)
    lam_all = sla.eigvals(k.toarray(), m.toarray())
    assert np.all(np.abs(lam_all.imag) < 1e-8 * np.abs(lam_all).max())
    lam = np.sort(lam_all.real)
    # one λ = 0 (u–p static mode of the closed fluid: constant p, u = Ks⁻¹ C p)
    assert abs(lam[0]) < 1e-8 * lam[1]
    f_fe = np.sqrt(lam[1:5]) / (2 * np.pi)

    def char(w):  # the characteristic equation times (ω/c) sin(ωL/c): no poles
        kk = w / C_AIR
        return (stiffness - mass * w**2) * kk * np.sin(kk * length) + RHO * s * w**2 * np.cos(
            kk * length
        )

    roots = []
    edges = np.linspace(1.0, 4.2 * np.pi * C_AIR / length, 4000)
    vals = [char(w) for w in edges]
    for a, b, fa, fb in zip(edges[:-1], edges[1:], vals[:-1], vals[1:], strict=True):
        if np.sign(fa) != np.sign(fb):
            roots.append(brentq(char, a, b))
    f_ref = np.array(roots[:4]) / (2 * np.pi)
    # the coupled frequencies differ from both the piston in vacuo and the rigid-piston tube
    assert abs(f_ref[0] - np.sqrt(stiffness / mass) / (2 * np.pi)) > 0.02 * f_ref[0]
    np.testing.assert_allclose(f_fe, f_ref, rtol=0.01)
