"""Acoustic immittance at a port (neweul_py.analysis.acoustic) against closed forms."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sps

from neweul_py.analysis.acoustic import (
    MMHO,
    absorbance,
    cavity_admittance,
    characteristic_impedance,
    equivalent_volume,
    port_admittance,
    port_impedance,
    reflectance,
    surface_admittance,
)
from neweul_py.analysis.linearize import LinearModel
from neweul_py.errors import NeweulError
from neweul_py.fem.acoustic import acoustic_matrices, surface_load
from neweul_py.fem.mesh import extrude_tets

RHO, C = 1.2, 343.0


def linear_model(m, d, k, b, c_rows, outputs) -> LinearModel:
    """A LinearModel from its matrices (coordinates ``z0…``, one input ``u``); ``c_rows``
    are rows on ``z`` (displacement-like outputs)."""
    m = np.atleast_2d(np.asarray(m, dtype=float))
    n = m.shape[0]
    c = np.hstack([np.atleast_2d(c_rows), np.zeros((len(outputs), n))])
    names = tuple(f"z{i}" for i in range(n))
    return LinearModel(M0=m, P=np.asarray(d, dtype=float).reshape(n, n),
                       Q=np.asarray(k, dtype=float).reshape(n, n),
                       B=np.asarray(b, dtype=float).reshape(n, 1), C=c,
                       D=np.zeros((len(outputs), 1)), coordinates=names, inputs=("u",),
                       outputs=tuple(outputs), basis=np.eye(n), all_coordinates=names,
                       y0=np.zeros(n), yd0=np.zeros(n), u0=np.zeros(1), p=np.zeros(0))


def tube(length: float, width: float, nz: int, matched: bool) -> LinearModel:
    """A rigid-walled square duct (P1 tetrahedra) driven at ``z = 0`` by a piston of volume
    acceleration ``u`` (fluid load ``ρ/A ∫N dΓ``, docs/equations-middle-ear.md), its output the
    mean pressure over the piston; the far end rigid or (``matched``) the plane-wave
    absorbing condition ``∂p/∂n = −ṗ/c`` (``Df = (1/c) ∫ NᵀN dΓ``)."""
    g = np.linspace(0.0, width, 3)
    gx, gy = np.meshgrid(g, g, indexing="ij")
    base = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(9)])
    idx = np.arange(9).reshape(3, 3)
    q0, q1, q2, q3 = (idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(),
                      idx[:-1, 1:].ravel())
    tri = np.vstack([np.column_stack([q0, q1, q2]), np.column_stack([q0, q2, q3])])
    mesh, _, _ = extrude_tets(base, tri, nz, lambda p, s: p + np.array([0, 0, s * length]))
    mf, kf = acoustic_matrices(mesh, C)
    n = mf.shape[0]
    area = width**2
    load = surface_load(mesh.points, tri)
    df = sps.csr_matrix((n, n))
    if matched:
        far = tri + nz * 9
        rows, cols, vals = [], [], []
        a = np.full(far.shape[0], area / far.shape[0])
        local = (np.ones((3, 3)) + np.eye(3)) / 12.0          # ∫ N_i N_j over a triangle / A
        for i in range(3):
            for j in range(3):
                rows.append(far[:, i])
                cols.append(far[:, j])
                vals.append(a * local[i, j])
        df = sps.csr_matrix((np.concatenate(vals) / C,
                             (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
    return linear_model(mf.toarray(), df.toarray(), kf.toarray(), RHO / area * load,
                        load / area, ["p_port"])


def test_lumped_cavity_admittance_is_j_omega_v_over_rho_c2():
    """A cavity of uniform pressure (``(V/c²) p̈ = ρ U̇``) against its closed form
    ``jωV/(ρc²)``, and the equivalent volume back to ``V`` (1 mmho ≈ 1 cm³ at 226 Hz)."""
    v = 1.3e-6
    lin = linear_model([[v / C**2]], [[0.0]], [[0.0]], [RHO], [[1.0]], ["p"])
    f = np.array([100.0, 226.0, 1000.0])
    y = port_admittance(lin, f, "u", "p")
    np.testing.assert_allclose(y, cavity_admittance(v, f, RHO, C), rtol=1e-12)
    np.testing.assert_allclose(equivalent_volume(y, f, RHO, C), v, rtol=1e-12)
    # read as a volume-velocity source, the same response H is Z/(jω)
    z = port_impedance(lin, f, "u", "p", source_kind="volume_velocity")
    np.testing.assert_allclose(z, 1 / (2j * np.pi * f * y), rtol=1e-12)
    y1 = cavity_admittance(1e-6, [226.0], RHO, C)[0]
    assert abs(abs(y1) / MMHO - 1.0) < 0.01


def test_rigid_tube_input_impedance_and_unit_reflectance():
    """A rigid-terminated duct: ``Z = −j (ρc/A) cot kL`` (plane waves below the first
    cross-mode), |R| = 1 (a lossless load absorbs nothing), and at low frequency the compact
    cavity ``jωAL/(ρc²)``."""
    length, width = 0.03, 0.004
    lin = tube(length, width, 60, matched=False)
    z0 = characteristic_impedance(RHO, C, width**2)
    f = np.array([20.0, 1000.0, 3000.0, 8000.0])
    z = port_impedance(lin, f, "u", "p_port")
    k = 2 * np.pi * f / C
    np.testing.assert_allclose(z, -1j * z0 / np.tan(k * length), rtol=5e-3)
    np.testing.assert_allclose(np.abs(reflectance(z, z0)), 1.0, atol=1e-9)
    np.testing.assert_allclose(absorbance(z, z0), 0.0, atol=1e-9)
    np.testing.assert_allclose(1 / z[0], cavity_admittance(width**2 * length, 20.0, RHO, C),
                               rtol=1e-3)


def test_matched_termination_absorbs_everything():
    """A duct ended by its characteristic impedance (the plane-wave absorbing condition)
    presents ``Z = ρc/A`` at the source, so ``R = 0`` and the absorbance is 1 (up to the
    mesh's dispersion error)."""
    length, width = 0.03, 0.004
    lin = tube(length, width, 60, matched=True)
    z0 = characteristic_impedance(RHO, C, width**2)
    f = np.geomspace(200.0, 8000.0, 7)
    z = port_impedance(lin, f, "u", "p_port")
    np.testing.assert_allclose(z, z0, rtol=2e-2)
    assert np.all(np.abs(reflectance(z, z0)) < 1e-2)
    np.testing.assert_allclose(absorbance(z, z0), 1.0, atol=1e-4)


def test_surface_admittance_of_a_piston_on_a_spring():
    """A piston (area S, mass m, stiffness k) closing a cavity of volume V, driven through
    the cavity: its admittance ``jωS x/p = jωS²/(k − ω²m)`` and the port's admittance the
    sum of the cavity's ``jωV/(ρc²)`` and the piston's."""
    s, m, k, v = 40e-6, 30e-6, 1500.0, 1e-6
    mass = [[m, 0.0], [RHO * s, v / C**2]]
    stiff = [[k, -s], [0.0, 0.0]]
    lin = linear_model(mass, np.zeros((2, 2)), stiff, [0.0, RHO], [[s, 0.0], [0.0, 1.0]],
                       ["volume", "p"])
    f = np.array([226.0, 678.0, 1000.0, 3000.0])
    w = 2 * np.pi * f
    ys = surface_admittance(lin, f, "u", "volume", "p")
    np.testing.assert_allclose(ys, 1j * w * s**2 / (k - w**2 * m), rtol=1e-10)
    np.testing.assert_allclose(port_admittance(lin, f, "u", "p"),
                               ys + cavity_admittance(v, f, RHO, C), rtol=1e-10)


def test_bad_input_is_one_clear_error():
    """Frequencies ≤ 0, an unknown source kind, a non-positive area."""
    lin = linear_model([[1.0]], [[0.0]], [[0.0]], [1.0], [[1.0]], ["p"])
    with pytest.raises(NeweulError, match="> 0 Hz"):
        port_impedance(lin, [0.0, 100.0], "u", "p")
    with pytest.raises(NeweulError, match="source kind"):
        port_impedance(lin, [100.0], "u", "p", source_kind="force")
    with pytest.raises(NeweulError, match="area"):
        characteristic_impedance(RHO, C, 0.0)
