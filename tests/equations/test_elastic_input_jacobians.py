"""Jacobians of the elastic splice (``docs/equations.md`` §2): the input
Jacobian ``∂(q−k)/∂u`` of a generated module includes the elastic bodies' terms (kinematic
excitation through the reference frame, with the rates ``d_u``, ``dd_u``), and so do
``∂(q−k)/∂y``, ``∂(q−k)/∂ẏ`` and ``∂(M a)/∂y``.

References: central differences of the generated ``force_vector`` and ``mass_matrix`` (an
independent path: no Jacobian code involved), and for the base-excitation FRF the FE beam
projected on the same modes with the base motion assembled directly (relative coordinates,
``M ẍ_rel + K x_rel = −M r ẍ_b``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from beam_fe import beam

from neweul_py.analysis import load_generated
from neweul_py.analysis.frf import frequency_response
from neweul_py.analysis.linearize import linearize
from neweul_py.api import generate


def _generate(tmp_path: Path, text: str):
    desc = tmp_path / "model.yaml"
    desc.write_text(text)
    return load_generated(generate(desc, tmp_path / "gen"))


def _beam_data(tmp_path: Path, stiffening: bool = False):
    """Cantilever (tests/support/beam_fe.py, 20 elements) with its first 4 clamped modes; the
    invariants with a node frame at the tip (node 21)."""
    from neweul_py.elastic.bodies.invariants import LOAD_CASES
    from neweul_py.elastic.reductors.invariants import compute_invariants, stress_stiffening

    b = beam(20)
    lam, V = b.clamped_modes(4)
    kw = {}
    if stiffening:
        kw["geometric_stiffness"] = stress_stiffening(
            b.fe, lambda u: b.geometric_stiffness(b.axial_forces(u)), support=np.arange(6),
            cases=LOAD_CASES)
    inv = compute_invariants(b.fe, V, nodes=[21], **kw)
    np.savez(tmp_path / "beam.npz", **inv.to_flat())
    return b, lam, V


def _fd_inputs(mod, t, y, yd, p, u, h=1e-6):
    out = np.empty((len(y), len(u)))
    for k in range(len(u)):
        e = np.zeros(len(u))
        e[k] = h * max(1.0, abs(u[k]))
        out[:, k] = (mod.force_vector(t, y, yd, p, u + e)
                     - mod.force_vector(t, y, yd, p, u - e)) / (2 * e[k])
    return out


def _fd_states(mod, t, y, yd, p, u, h=1e-6):
    n = len(y)
    fy, fyd = np.empty((n, n)), np.empty((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = h
        fy[:, j] = (mod.force_vector(t, y + e, yd, p, u)
                    - mod.force_vector(t, y - e, yd, p, u)) / (2 * h)
        fyd[:, j] = (mod.force_vector(t, y, yd + e, p, u)
                     - mod.force_vector(t, y, yd - e, p, u)) / (2 * h)
    return fy, fyd


def _fd_mass(mod, t, y, p, a, u, h=1e-6):
    n = len(y)
    out = np.empty((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = h
        out[:, j] = (mod.mass_matrix(t, y + e, p, u) - mod.mass_matrix(t, y - e, p, u)) @ a \
            / (2 * h)
    return out


def _close(got, ref, rtol=1e-6):
    """Entrywise against central differences, to ``rtol`` of the largest reference entry."""
    np.testing.assert_allclose(got, ref, rtol=rtol, atol=rtol * np.abs(ref).max())


SHAKER = """
name: shaker
inputs: {xb: 0}
coordinates: {a: {}}
parameters: {c: 0.3}
frames:
  base: {translation: [0, xb, 0]}
  arm: {parent: base, rotation: [[z, a]]}
  link: {parent: arm, translation: [0.2, 0.5, 0.1]}
elastic_bodies:
  beam: {frame: link, data: beam.npz, nodes: {tip: 21}}
forces:
  hinge: {type: torque, frame: arm, vector: [0, 0, "-c*a"], in: arm}
outputs:
  tip_y: {position: beam.tip, in: ISYS, component: y}
"""


def test_input_jacobian_of_a_translating_frame(tmp_path: Path) -> None:
    """Beam on an arm (hinge coordinate ``a``, offset [0.2, 0.5, 0.1]) carried by a frame
    translating with the input ``xb`` (kinematic excitation: ``INPUTS = [xb, d_xb, dd_xb]``):
    ``force_jacobians``'s ``∂(q−k)/∂u`` — elastic rows and the hinge row — and ``∂/∂y``,
    ``∂/∂ẏ``, ``∂(M a)/∂y`` equal central differences of ``force_vector`` / ``mass_matrix`` at a
    general state and input; ``linearize(...).B`` at the initial state too. The elastic rows
    of ``∂/∂dd_xb`` (the modal loads ``Ct`` of the base acceleration) are not zero."""
    _beam_data(tmp_path)
    mod = _generate(tmp_path, SHAKER)
    assert mod.INPUTS == ["xb", "d_xb", "dd_xb"]
    p = mod.default_parameters()
    rng = np.random.default_rng(2)
    y = np.array([0.4, 0.02, -0.01, 0.015, 0.005])
    yd = rng.normal(size=5)
    u = np.array([0.1, 0.7, -2.0])
    fy, fyd, fu = mod.force_jacobians(0.0, y, yd, p, u)
    _close(fu, _fd_inputs(mod, 0.0, y, yd, p, u))
    assert np.abs(fu[1:, 2]).max() > 0.3                  # the elastic rows are there
    fy_d, fyd_d = _fd_states(mod, 0.0, y, yd, p, u)
    _close(fy, fy_d, 1e-5)
    _close(fyd, fyd_d)
    a = rng.normal(size=5)
    ref = _fd_mass(mod, 0.0, y, p, a, u)
    assert np.abs(ref).max() > 1e-3 * np.abs(mod.mass_matrix(0.0, y, p, u)).max()
    _close(mod.mass_matrix_times_derivative(0.0, y, p, a, u), ref, 1e-5)
    lin = linearize(mod)
    y0 = np.array(mod.INITIAL_STATE[:5])
    _close(lin.B, _fd_inputs(mod, 0.0, y0, np.zeros(5), p, mod.default_inputs(0.0, p)))
    assert np.abs(lin.B[1:, 2]).max() > 0.3


def test_base_excitation_frf_equals_the_projected_fe_beam(tmp_path: Path) -> None:
    """Clamped cantilever on a frame moved by ``xb`` along y: the FRF ``xb → tip_y``
    (absolute tip displacement, ``B = B_u + jω B_du − ω² B_ddu``) of the generated module
    equals ``1 + Φ_tip (K_r − ω² M_r)⁻¹ ω² Vᵀ M r`` of the FE beam projected on the same four
    modes (``r``: unit y translation of every node; no invariants or generated code
    involved). Without the elastic part of ``B`` it would be 1 at every frequency."""
    b, _lam, V = _beam_data(tmp_path)
    mod = _generate(tmp_path, """
name: shaker_clamped
inputs: {xb: 0}
frames:
  base: {translation: [0, xb, 0]}
elastic_bodies:
  beam: {frame: base, data: beam.npz, nodes: {tip: 21}}
outputs:
  tip_y: {position: beam.tip, in: ISYS, component: y}
""")
    f = np.linspace(1.0, 100.0, 5)
    H = frequency_response(mod, f, "xb", "tip_y").H.reshape(-1)
    M, K = b.fe.M.toarray(), b.fe.K.toarray()
    r = np.zeros(b.n)
    r[1::6] = 1.0
    Mr, Kr, load = V.T @ M @ V, V.T @ K @ V, V.T @ M @ r
    tip = V[b.dof(20, 1)]
    w = 2 * np.pi * f
    ref = np.array([1 + tip @ np.linalg.solve(Kr - wi**2 * Mr, wi**2 * load) for wi in w])
    np.testing.assert_allclose(H, ref, rtol=1e-8)
    assert abs(H[0]) == pytest.approx(7.18, abs=0.01)


HUB = """
name: hub_input
inputs: {th: 0}
frames:
  hub: {rotation: [[z, th]]}
elastic_bodies:
  beam: {frame: hub, data: beam.npz, nodes: {tip: 21}}
bodies:
  lump: {frame: beam.tip, mass: 0.05, inertia: {diag: [1e-4, 1e-4, 1e-4]}}
outputs:
  tip_y: {position: beam.tip, in: hub, component: y}
"""


def test_input_jacobian_of_a_hub_rate(tmp_path: Path) -> None:
    """Beam with geometric stiffening on a hub turned by the input ``th`` (rates ``d_th``,
    ``dd_th``), a rigid mass on its tip node: at ``d_th = 20`` the elastic rows of
    ``∂(q−k)/∂d_th`` (centrifugal and Coriolis terms, first-order invariants) and of
    ``∂/∂dd_th`` equal central differences of ``force_vector``; so do ``linearize``'s ``B``
    about that (deflected, spinning) state and the ``∂/∂y``, ``∂/∂ẏ`` Jacobians."""
    _beam_data(tmp_path, stiffening=True)
    mod = _generate(tmp_path, HUB)
    assert mod.INPUTS == ["th", "d_th", "dd_th"]
    p = mod.default_parameters()
    rng = np.random.default_rng(4)
    y = 0.01 * rng.normal(size=4)
    yd = 0.5 * rng.normal(size=4)
    u = np.array([0.3, 20.0, 1.5])
    fy, fyd, fu = mod.force_jacobians(0.0, y, yd, p, u)
    ref = _fd_inputs(mod, 0.0, y, yd, p, u)
    _close(fu, ref)
    assert np.abs(ref[:, 1]).max() > 0.1 and np.abs(ref[:, 2]).max() > 0.1
    fy_d, fyd_d = _fd_states(mod, 0.0, y, yd, p, u)
    _close(fy, fy_d, 1e-5)
    _close(fyd, fyd_d)
    lin = linearize(mod, y0=y, yd0=yd, u0=u)
    _close(lin.B, ref)
