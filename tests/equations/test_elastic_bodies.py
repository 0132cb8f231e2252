"""Elastic bodies in the equations of motion (``docs/equations.md`` §2).

References: the eigenfrequencies printed in the SID file's mode names (the FE code that wrote
it), closed-form Southwell stiffening, and unreduced FE models assembled directly in the tests.
"""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sl

from neweul_py.analysis import load_generated
from neweul_py.analysis.linearize import linearize
from neweul_py.analysis.modes import modes
from neweul_py.api import generate
from neweul_py.elastic.io.sid import read_sid
from neweul_py.errors import DescriptionError, SolverError

DATA = Path(__file__).resolve().parents[1] / "data"


def _write(tmp_path: Path, text: str, name: str = "model.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _generate(tmp_path: Path, text: str, form: str = "auto"):
    desc = _write(tmp_path, text)
    return load_generated(generate(desc, tmp_path / "gen", form=form))


@pytest.fixture
def beam_dir(tmp_path: Path) -> Path:
    shutil.copy(DATA / "beam.SID_FEM", tmp_path / "beam.SID_FEM")
    return tmp_path


CLAMPED = """
name: clamped_beam
elastic_bodies:
  beam:
    frame: ISYS
    data: beam.SID_FEM
    nodes: {tip: 1793}
outputs:
  tip_x: {position: beam.tip, in: ISYS, component: x}
"""


def test_sid_beam_clamped_reproduces_the_file_frequencies(beam_dir: Path) -> None:
    """SID beam fixed to the ground: the undamped modes of the generated module (linearized
    by analysis, modes by analysis.modes) are the eigenfrequencies named in the file
    (``Eigen Mode 7 : 51.626 Hz`` …); with the file's damping ``De`` (= 0.01 Ke) the
    eigenvalues are those of ``(Me, De, Ke)``."""
    mod = _generate(beam_dir, CLAMPED)
    assert mod.COORDINATES == [f"beam_q{k}" for k in range(1, 12)]
    lin = linearize(mod)
    res = modes(dataclasses.replace(lin, P=np.zeros_like(lin.P)))
    expected = read_sid(DATA / "beam.SID_FEM").frequencies_from_names()
    np.testing.assert_allclose(np.sort(res.frequency_hz), np.sort(expected), rtol=2e-5)
    sid = read_sid(DATA / "beam.SID_FEM")
    Me, De, Ke = (sid[k].m0 for k in ("Me", "De", "Ke"))
    z = np.zeros_like(Me)
    ref = sl.eigvals(np.block([[z, np.eye(11)], [-Ke, -De]]), np.block([[np.eye(11), z],
                                                                      [z, Me]]))
    got = modes(lin).eigenvalues
    np.testing.assert_allclose(np.sort_complex(got), np.sort_complex(ref), rtol=1e-6)


def test_body_on_a_fixed_frame_is_linear_structural_dynamics(beam_dir: Path) -> None:
    """The SID beam on ISYS under gravity with a spring to the ground at its tip node: the
    generated module (which embeds only the elastic rows of a body whose frame never moves)
    gives ``Me q̈ = −Ke q − De q̇ − kσ + Ct⁰ g + Φ_Pᵀ f_spring`` — the closed form of linear
    structural dynamics, written out here from the file's matrices — for ``rhs`` and its
    Jacobian, and the module holds none of the rigid-motion invariants."""
    sid = read_sid(DATA / "beam.SID_FEM")
    node = next(n for n in sid.nodes if n.id == 1793)
    at = [float(v) for v in node.origin.m0.ravel()]          # the tip node's position
    text = CLAMPED.replace("name: clamped_beam", "name: clamped_beam\nparameters: {g: 9.81, "
                           "k: 1.0e3}\ngravity: [0, 0, -g]") + f"""
forces:
  tip: {{type: bushing, between: [ISYS, beam.tip], points: [{at}, [0, 0, 0]], stiffness: k}}
"""
    mod = _generate(beam_dir, text)
    source = Path(mod.path).read_text()
    assert "'fixed': True" in source and "'Oe.m1'" not in source and "'Gr.m0'" not in source
    Me, De, Ke, Ct, ks = (sid[k].m0 for k in ("Me", "De", "Ke", "Ct", "ksigma"))
    ks = ks[:, 0]
    phi = node.phi.m0                                         # (3, nq): u_tip = Φ_P q
    rng = np.random.default_rng(0)
    q, qd = 1e-3 * rng.normal(size=11), 1e-2 * rng.normal(size=11)
    g = np.array([0.0, 0.0, -9.81])
    f_tip = -1.0e3 * (phi @ q)                                # spring of zero length at the node
    qdd = np.linalg.solve(Me, -Ke @ q - De @ qd - ks + Ct @ g + phi.T @ f_tip)
    p = mod.default_parameters()
    xd = mod.rhs(0.0, np.concatenate((q, qd)), p)
    np.testing.assert_allclose(xd[11:], qdd, rtol=1e-9, atol=1e-9 * np.abs(qdd).max())
    J = mod.rhs_jacobian(0.0, np.concatenate((q, qd)), p)
    Minv = np.linalg.inv(Me)
    np.testing.assert_allclose(J[11:, :11], -Minv @ (Ke + 1.0e3 * phi.T @ phi), rtol=1e-8,
                               atol=1e-8 * np.abs(Minv @ Ke).max())
    np.testing.assert_allclose(J[11:, 11:], -Minv @ De, rtol=1e-8,
                               atol=1e-8 * np.abs(Minv @ De).max())


def test_clamped_beam_modes_subset_and_node_output(beam_dir: Path) -> None:
    """``modes: 3`` keeps the first three; the node output moves with Φ_P (``origin(q)``)."""
    mod = _generate(beam_dir, CLAMPED.replace("nodes: {tip: 1793}",
                                              "nodes: {tip: 1793}\n    modes: 3"))
    assert len(mod.COORDINATES) == 3
    body = read_sid(DATA / "beam.SID_FEM")
    node = body.node(1793)
    q = np.array([0.1, -0.2, 0.3])
    x = np.concatenate([q, np.zeros(3)])
    want = node.origin.m0[0, 0] + node.phi.m0[0, :3] @ q
    assert mod.outputs(0.0, x, mod.default_parameters())[0] == pytest.approx(want, rel=1e-12)


def test_regeneration_is_byte_identical(beam_dir: Path) -> None:
    """Same description → byte-identical module (numeric data embedded deterministically)."""
    desc = _write(beam_dir, CLAMPED)
    a = generate(desc, beam_dir / "a").read_bytes()
    b = generate(desc, beam_dir / "b").read_bytes()
    assert a == b


@pytest.mark.parametrize(
    ("edit", "key", "words"),
    [
        (("tip: 1793", "tip: 99999"), "elastic_bodies.beam.nodes.tip", "node 99999"),
        (("frame: ISYS", "frame: nowhere"), "elastic_bodies.beam.frame", "unknown frame"),
        (("data: beam.SID_FEM", "data: missing.SID_FEM"), "elastic_bodies.beam.data",
         "no such file"),
        (("nodes: {tip: 1793}", "nodes: {tip: 1793}\n    modes: 40"),
         "elastic_bodies.beam.modes", "40 modes"),
    ],
)
def test_bad_elastic_input_names_the_key(beam_dir: Path, edit, key, words) -> None:
    """Bad input: unknown node id, unknown frame, missing data file, too many modes."""
    desc = _write(beam_dir, CLAMPED.replace(*edit))
    with pytest.raises(DescriptionError) as info:
        generate(desc, beam_dir / "gen")
    msg = str(info.value)
    assert key in msg and words in msg


def test_sid_data_and_the_inertia_form(beam_dir: Path) -> None:
    """SID data hold no second-order inertia (J.m2): by default one warning naming the file
    and what is missing (the SID truncation is used); ``inertia: consistent`` asked for
    explicitly is an error naming the key; ``inertia: sid`` is silent. Reference: the SID
    format (Wallrapp 1994) stores J to first order only."""
    import warnings

    text = CLAMPED.replace("data: beam.SID_FEM", "data: beam.SID_FEM\n    inertia: FORM")
    with pytest.warns(UserWarning, match=r"beam\.SID_FEM.*J\.m2") as record:
        generate(_write(beam_dir, CLAMPED, "a.yaml"), beam_dir / "gen_a")
    assert len([w for w in record if "J.m2" in str(w.message)]) == 1
    with pytest.raises(DescriptionError) as info:
        generate(_write(beam_dir, text.replace("FORM", "consistent"), "b.yaml"), beam_dir / "gen_b")
    assert "elastic_bodies.beam.inertia" in str(info.value) and "J.m2" in str(info.value)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        generate(_write(beam_dir, text.replace("FORM", "sid"), "c.yaml"), beam_dir / "gen_c")


def test_unknown_frame_lists_only_usable_frames(beam_dir: Path) -> None:
    """An elastic body on an unknown frame: the message lists the frames it may use — not
    its own node frames (``beam.tip``) nor frames hung on them, which are refused."""
    text = CLAMPED.replace("frame: ISYS", "frame: nowhere").replace(
        "elastic_bodies:", "frames:\n  base: {translation: [0, 1, 0]}\n"
        "  tipframe: {parent: beam.tip}\nelastic_bodies:")
    with pytest.raises(DescriptionError) as info:
        generate(_write(beam_dir, text), beam_dir / "gen")
    msg = str(info.value)
    assert "elastic_bodies.beam.frame" in msg
    assert msg.endswith("unknown frame 'nowhere'; frames are: ISYS, base")
    for frame in ("tipframe", "beam.tip"):   # really refused
        with pytest.raises(DescriptionError, match="cannot hang on the body's own nodes"):
            generate(_write(beam_dir, text.replace("frame: nowhere", f"frame: {frame}")),
                     beam_dir / "gen")


def test_sid_syntax_error_reports_the_line(beam_dir: Path) -> None:
    """A SID file with a syntax error: the message names the data key, the file and line."""
    lines = (DATA / "beam.SID_FEM").read_text().splitlines()
    lines[20] = "this is not = = SID"
    (beam_dir / "beam.SID_FEM").write_text("\n".join(lines) + "\n")
    desc = _write(beam_dir, CLAMPED)
    with pytest.raises(DescriptionError) as info:
        generate(desc, beam_dir / "gen")
    msg = str(info.value)
    assert "elastic_bodies.beam.data" in msg and "beam.SID_FEM:" in msg


SOUTHWELL_1 = 1.1932  # first flapwise Southwell coefficient of a uniform cantilever


def _spinning_module(tmp_path: Path, stiffening: bool, omega_factor: float = 0.3):
    """Cantilever (tests/support/beam_fe.py, 20 elements, 8 clamped modes) on a hub turning
    at a constant rate Ω about z (frame rotation ``Om*t``)."""

    from beam_fe import beam

    from neweul_py.elastic.reductors.invariants import compute_invariants, stress_stiffening

    b = beam(20)
    lam, V = b.clamped_modes(8)
    kw = {}
    if stiffening:
        kw["geometric_stiffness"] = stress_stiffening(
            b.fe, lambda u: b.geometric_stiffness(b.axial_forces(u)), support=np.arange(6),
            cases=("wzz",))
    inv = compute_invariants(b.fe, V, nodes=[21], **kw)
    np.savez(tmp_path / "beam.npz", **inv.to_flat())
    om = float(omega_factor * np.sqrt(lam[0]))
    mod = _generate(tmp_path, f"""
name: spinning_beam
parameters: {{Om: {om!r}}}
frames:
  hub: {{rotation: [[z, "Om*t"]]}}
elastic_bodies:
  beam: {{frame: hub, data: beam.npz, nodes: {{tip: 21}}}}
""")
    return mod, lam, om


@pytest.mark.parametrize("stiffening", [True, False])
def test_spinning_cantilever_southwell(tmp_path: Path, stiffening: bool) -> None:
    """Hub spinning at constant Ω: the generated module, linearized by analysis (Coriolis and
    centrifugal terms included), gives the flapwise ω² = ω₀² + α Ω² with Southwell's
    α = 1.1932 and chordwise α − 1 (spin softening); without the stiffening terms the
    flapwise frequency does not rise (α = 0) and chordwise softens by Ω² (α = −1)."""
    mod, lam, om = _spinning_module(tmp_path, stiffening)
    ev = modes(linearize(mod)).eigenvalues
    w = np.sort(np.abs(ev.imag[ev.imag > 1e-9]))
    alpha = (w[:2] ** 2 - lam[:2]) / om**2
    if stiffening:
        assert alpha[0] == pytest.approx(SOUTHWELL_1, rel=2e-3)
        assert alpha[1] == pytest.approx(SOUTHWELL_1 - 1, abs=2e-3)
    else:
        assert alpha[0] == pytest.approx(0.0, abs=1e-5)
        assert alpha[1] == pytest.approx(-1.0, abs=1e-3)


def _up_module(tmp_path: Path, fe, two_sided: bool, m2: float, k2: float, d2: float):
    from neweul_py.elastic import reduce_modal, save_reduced_body
    from neweul_py.elastic.reductors.invariants import attach_invariants

    body = reduce_modal(fe, modes=12, two_sided=two_sided, keep_nodes=[1], store_bases=True)
    body = attach_invariants(body, fe, nodes=[1])
    tag = "two" if two_sided else "one"
    save_reduced_body(body, tmp_path / f"{tag}.npz")
    return _generate(tmp_path, f"""
name: up_{tag}
parameters: {{m2: {m2!r}, k2: {k2!r}, d2: {d2!r}}}
coordinates: {{z: {{}}}}
inputs: {{F: 0}}
frames:
  carrier: {{translation: [z, 0, 0]}}
elastic_bodies:
  duct: {{frame: ISYS, data: {tag}.npz, nodes: {{piston: 1}}}}
bodies:
  mass: {{frame: carrier, mass: m2}}
forces:
  link:
    type: bushing
    between: [duct.piston, carrier]
    stiffness: {{diag: [k2, 0, 0]}}
    damping: {{diag: [d2, 0, 0]}}
  push: {{type: force, frame: carrier, vector: [F, 0, 0], in: ISYS}}
""")


def test_up_coupled_body_with_spring_and_mass_matches_unreduced_fe(tmp_path: Path) -> None:
    """u–p coupled piston–duct (Eq. (2), unsymmetric; tests/support/fe_builders.py) fixed to
    the ground, its piston node tied by a spring–damper (bushing) to a rigid mass: the FRF
    force on the mass → mass displacement of the generated model equals that of the unreduced
    FE model with the same spring and mass assembled directly, below the cut-off (12 modes,
    ≈ 2 kHz; compared at 20–900 Hz). Two-sided data (node loads with ``W``) are accurate,
    one-sided (Galerkin) data of the unsymmetric model are not."""

    import scipy.sparse as sps
    from fe_builders import piston_duct

    fe = piston_duct(n_el=100)
    m2, k2, d2 = 0.02, 5.0e4, 2.0
    f = np.linspace(20.0, 900.0, 45)
    n = fe.M.shape[0]
    M = sps.block_diag([fe.M, sps.csr_matrix([[m2]])]).toarray()
    K = sps.block_diag([fe.K, sps.csr_matrix([[0.0]])]).toarray()
    C = np.zeros_like(K)
    for A, c in ((K, k2), (C, d2)):
        A[0, 0] += c
        A[n, n] += c
        A[0, n] -= c
        A[n, 0] -= c
    b = np.zeros(n + 1)
    b[n] = 1.0
    w = 2 * np.pi * f
    ref = np.array([np.linalg.solve(K - wi**2 * M + 1j * wi * C, b)[n] for wi in w])
    err = {}
    for two in (True, False):
        mod = _up_module(tmp_path, fe, two, m2, k2, d2)
        assert mod.MASS_MATRIX_SYMMETRIC is False
        lin = linearize(mod)
        iz = list(mod.COORDINATES).index("z")
        H = np.array([np.linalg.solve(lin.Q - wi**2 * lin.M0 + 1j * wi * lin.P,
                                      lin.B[:, 0])[iz] for wi in w])
        err[two] = np.abs(H - ref) / np.abs(ref)
    assert err[True].max() < 0.03
    assert np.median(err[True]) < 1e-3
    assert err[False].max() > 10 * err[True].max()


def _pendulum(tmp_path: Path, modes: int, *, E: float = 3.0e4, lumped: bool = False,
              inertia: str = "consistent", tag: str = "", stiffening: bool | str = False):
    """A cantilever (tests/support/beam_fe.py, 20 elements) hinged at its root (coordinate
    ``a`` about z), in-plane bending modes only, one-sided invariants, gravity along −y;
    optionally with the geometric stiffening of all 12 inertia load cases, as the
    second-order field (``True``/``"field"``) or its first-order terms (``"first"``)."""

    from beam_fe import beam

    from neweul_py.elastic.bodies.invariants import LOAD_CASES
    from neweul_py.elastic.reductors.invariants import (
        compute_invariants,
        inertia_responses,
        stress_stiffening,
    )
    from neweul_py.elastic.reductors.second_order import with_second_order

    b = beam(20, E=E, lumped=lumped, rotary=lumped)
    _lam, V = b.clamped_modes(60)
    inplane = [k for k in range(60)
               if np.linalg.norm(V[1::6, k]) > 1e-6
               and max(np.abs(V[0::6, k]).max(), np.abs(V[2::6, k]).max(),
                       np.abs(V[3::6, k]).max(), np.abs(V[4::6, k]).max()) < 1e-9]
    kw = {}
    if stiffening:
        kw["geometric_stiffness"] = stress_stiffening(
            b.fe, lambda u: b.geometric_stiffness(b.axial_forces(u)), support=np.arange(6),
            cases=LOAD_CASES)
    inv = compute_invariants(b.fe, V[:, inplane[:modes]], nodes=[21], **kw)
    if stiffening and stiffening != "first":
        inv = with_second_order(inv, b.fe, V[:, inplane[:modes]], kw["geometric_stiffness"],
                                inertia_responses(b.fe, np.arange(6)))
    name = f"b{modes}{tag}"
    np.savez(tmp_path / f"{name}.npz", **inv.to_flat())
    mod = _generate(tmp_path, f"""
name: pendulum_{name}
parameters: {{g: 9.81}}
gravity: [0, -g, 0]
coordinates: {{a: {{}}}}
frames:
  arm: {{rotation: [[z, a]]}}
elastic_bodies:
  beam: {{frame: arm, data: {name}.npz, nodes: {{tip: 21}}, inertia: {inertia}}}
outputs:
  tip_y: {{position: beam.tip, in: arm, component: y}}
""")
    return mod, inv


def _energy_drift(mod, inv, t_end: float = 2.0, rtol: float = 1e-10):
    """Largest change of the module's total energy over the run, relative to m g L/2."""
    from neweul_py.analysis import simulate

    res = simulate(mod, t_end, method="DOP853", rtol=rtol, atol=1e-3 * rtol, n_out=101)
    p = mod.default_parameters()
    x = np.hstack((res.y, res.yd))
    energy = np.array([mod.energy(t, xi, p).sum() for t, xi in zip(res.t, x, strict=True)])
    assert np.all(np.isfinite(x))
    return np.abs(energy - energy[0]).max() / (inv.m * 9.81 * 0.5), res


@pytest.mark.parametrize(("modes", "lumped", "stiffening"),
                         [(2, False, False), (2, True, False),
                          (2, False, "field"), (3, False, "first"),
                          # 8 s of CPU each; more modes are checked by the 3-mode case
                          pytest.param(4, False, False, marks=pytest.mark.slow),
                          # 8 s of CPU; the field form is checked with 2 modes by default
                          pytest.param(4, False, "field", marks=pytest.mark.slow)])
def test_flexible_pendulum_conserves_energy(tmp_path: Path, modes: int, lumped: bool,
                                            stiffening: bool | str) -> None:
    """Released horizontally under gravity, undamped: the total energy of the generated
    module (``energy()``: kinetic ``½ zᵀ M_b z``, gravity, strain ``½ qᵀ Ke q`` and the
    prestress potential) stays within 1e-7 of m g L/2 over 2 s at rtol 1e-10 (consistent and
    lumped mass, with and without geometric stiffening: the second-order field of
    equations.md §2.3, or its first-order terms for few modes) — the reference is
    conservation of energy itself. With the SID truncation (``inertia: sid``) the same model
    drifts by orders of magnitude more or blows up."""
    mod, inv = _pendulum(tmp_path, modes, lumped=lumped, stiffening=stiffening,
                         tag="s" if stiffening else "")
    drift, res = _energy_drift(mod, inv)
    assert res.y[-1, 0] < -0.5 or res.y[:, 0].min() < -0.5          # it did fall
    assert drift < 1e-7
    if modes == 4:
        mod_sid, _ = _pendulum(tmp_path, modes, inertia="sid", tag="sid")
        try:
            drift_sid, _res = _energy_drift(mod_sid, inv)
        except SolverError:                                  # it blew up
            drift_sid = np.inf
        assert drift_sid > 1e3 * max(drift, 1e-13)


@pytest.mark.slow
@pytest.mark.parametrize("stiffening", [False, True])
@pytest.mark.parametrize("modes", [10, 20])
def test_flexible_pendulum_conserves_energy_with_many_modes(tmp_path: Path, modes: int,
                                                            stiffening: bool) -> None:
    """As above with 10 and 20 modes, with and without stiffening (the SID truncation blows
    up with this many modes; so does the stiffening's second-order expansion, whose mass
    matrix turns indefinite — the second-order field of equations.md §2.3 keeps it a Gram
    matrix)."""
    mod, inv = _pendulum(tmp_path, modes, stiffening=stiffening, tag="s" if stiffening else "")
    drift, _res = _energy_drift(mod, inv)
    assert drift < 1e-7


@pytest.mark.slow
def test_flexible_pendulum_converges_to_the_unreduced_model(tmp_path: Path) -> None:
    """Tip deflection and hinge angle over 0.6 s with 2, 4, 8 modes against the model with all
    30 in-plane bending modes of the 20-element beam (the complete in-plane bending basis of
    the FE model, consistent inertia: the exact floating-frame model of the unreduced beam):
    the RMS error falls with the mode count."""
    from neweul_py.analysis import simulate

    def run(count: int):
        mod, _inv = _pendulum(tmp_path, count)
        res = simulate(mod, 0.6, method="DOP853", rtol=1e-9, atol=1e-12, n_out=61)
        return res.outputs[:, 0], res.y[:, 0]

    ref = run(30)
    errs = []
    for count in (2, 4, 8):
        tip, angle = run(count)
        errs.append(max(np.sqrt(np.mean((tip - ref[0]) ** 2) / np.mean(ref[0] ** 2)),
                        np.sqrt(np.mean((angle - ref[1]) ** 2) / np.mean(ref[1] ** 2))))
    # here 7.1e-2, 9.2e-3, 1.4e-3: each doubling of the modes divides the error by ≈ 7
    assert errs[1] < errs[0] / 3 and errs[2] < errs[1] / 3


def _krb_theta(t: float, Ws: float = 6.0, T: float = 15.0) -> tuple[float, float, float]:
    """Hub angle, rate and acceleration of the Kane–Ryan–Banerjee spin-up."""
    if t <= T:
        return (Ws / T * (t**2 / 2 + (T / (2 * np.pi)) ** 2 * (np.cos(2 * np.pi * t / T) - 1)),
                Ws / T * (t - T / (2 * np.pi) * np.sin(2 * np.pi * t / T)),
                Ws / T * (1 - np.cos(2 * np.pi * t / T)))
    return Ws * t - Ws * T / 2, Ws, 0.0


def _krb_tips(tmp_path: Path, t_end: float, n_out: int, tags=("stiff", "bare"),
              Ws: float = 6.0, modes: int = 3, n_el: int = 10) -> dict:
    """Chordwise tip deflection of the generated KRB model (10 beam elements, three in-plane
    bending modes) with and without the geometric stiffening terms."""

    from beam_fe import beam

    from neweul_py.analysis import simulate
    from neweul_py.elastic.bodies.invariants import LOAD_CASES
    from neweul_py.elastic.reductors.invariants import (
        compute_invariants,
        inertia_responses,
        stress_stiffening,
    )
    from neweul_py.elastic.reductors.second_order import with_second_order

    b = beam(n_el, length=10.0, E=7e10, G=2.7e10, rho=3000.0, A=4e-4, Iy=8e-7, Iz=2e-7)
    lam, V = b.clamped_modes(30)
    inplane = [k for k in range(30) if np.abs(V[1::6, k]).max() > 1e3 * max(
        np.abs(V[2::6, k]).max(), np.abs(V[3::6, k]).max(), np.abs(V[4::6, k]).max(), 1e-300)]
    assert np.sqrt(lam[inplane[0]]) == pytest.approx(3.8, abs=0.01)
    kg = stress_stiffening(b.fe, lambda u: b.geometric_stiffness(b.axial_forces(u)),
                           support=np.arange(6), cases=LOAD_CASES)
    tips = {}
    for tag in tags:
        kw = {"geometric_stiffness": kg} if tag in ("stiff", "quad") else {}
        inv = compute_invariants(b.fe, V[:, inplane[:modes]], nodes=[n_el + 1], **kw)
        if tag == "quad":
            inv = with_second_order(inv, b.fe, V[:, inplane[:modes]], kg,
                                    inertia_responses(b.fe, np.arange(6)))
        np.savez(tmp_path / f"{tag}.npz", **inv.to_flat())
        mod = _generate(tmp_path, f"""
name: krb_{tag}
parameters: {{Ws: {Ws!r}, T: 15.0}}
frames:
  hub: {{rotation: [[z, "Ws/T*(t**2/2 + (T/(2*pi))**2*(cos(2*pi*t/T) - 1))"]]}}
elastic_bodies:
  beam: {{frame: hub, data: {tag}.npz, nodes: {{tip: {n_el + 1}}}}}
outputs:
  tip_y: {{position: beam.tip, in: hub, component: y}}
""")
        res = simulate(mod, t_end, method="RK45", rtol=1e-8, atol=1e-10, n_out=n_out)
        tips[tag] = res.outputs[:, 0]
    return tips


def _krb_reference(t: np.ndarray, n_el: int, Ws: float = 6.0) -> np.ndarray:

    from rotating_beam_reference import spin_up_tip

    return spin_up_tip(lambda tt: _krb_theta(tt, Ws), float(t[-1]), t, n_el=n_el)


@pytest.mark.slow
def test_kane_ryan_banerjee_spin_up(tmp_path: Path) -> None:
    """Spin-up of Kane, Ryan & Banerjee (1987, J. Guidance 10(2):139–151): cantilever
    L = 10 m, ρA = 1.2 kg/m, EI = 14 000 N m² (chordwise) on a hub driven by
    Ω(t) = Ωs/T (t − T/(2π) sin(2πt/T)), Ωs = 6 rad/s, T = 15 s; three in-plane bending modes.

    Reference: no digitizable published numbers were found in the sources available here,
    so the histories are compared with an independent unreduced nonlinear model
    (``tests/support/rotating_beam_reference.py``: own planar FE, 10 elements, von Kármán
    strain in the rotating frame, all DOFs, Radau; 10 → 20 elements changes the extremum by
    0.1 %): minimum −0.575 m at t ≈ 6.8 s, ≈ 0 at t = T. This is the shape of the published
    curve (dip to about −0.5…−0.6 m near 7 s, back to ≈ 0 at 15 s). With the geometric
    stiffening terms (all twelve load cases) the generated model follows it within a few
    per cent; without them it diverges once Ω exceeds the first bending frequency
    (3.8 rad/s)."""
    t = np.linspace(0.0, 15.0, 151)
    tips = _krb_tips(tmp_path, 15.0, 151)
    ref = _krb_reference(t, 10)
    stiff = tips["stiff"]
    assert ref.min() == pytest.approx(-0.575, abs=0.005)
    assert stiff.min() == pytest.approx(ref.min(), rel=0.01)   # here 0.2 %
    assert abs(t[np.argmin(stiff)] - t[np.argmin(ref)]) <= 0.2
    assert np.abs(stiff - ref).max() < 0.01 * np.abs(ref).max()
    assert abs(stiff[-1]) < 0.01 and abs(ref[-1]) < 0.01
    assert np.abs(tips["bare"]).max() > 10.0


@pytest.mark.slow
@pytest.mark.parametrize("Ws", [4.0, 6.0, 10.0])
def test_kane_ryan_banerjee_spin_up_other_speeds(tmp_path: Path, Ws: float) -> None:
    """The spin-up at Ωs = 4, 6 and 10 rad/s (below and well above the first bending
    frequency 3.8 rad/s) against the unreduced nonlinear reference
    (tests/support/rotating_beam_reference.py, 10 elements, von Kármán strain), with the
    second-order displacement field of the stiffened body (equations.md §2.3): the extremum
    and the whole history within 0.5 % (here 0.03 %, 0.06 %, 0.10 % at the extremum,
    ≤ 0.12 % overall). The first-order stiffening terms leave 0.61 % at 10 rad/s (tip
    deflection 8.6 % of the length). Both share the reference's linear curvature; against
    exact curvature see equations.md §2.3."""
    t = np.linspace(0.0, 15.0, 151)
    tips = _krb_tips(tmp_path, 15.0, 151, tags=("quad", "stiff"), Ws=Ws)
    ref = _krb_reference(t, 10, Ws)
    assert tips["quad"].min() == pytest.approx(ref.min(), rel=5e-3)
    assert np.abs(tips["quad"] - ref).max() < 5e-3 * np.abs(ref).max()
    assert np.abs(tips["stiff"] - ref).max() < 0.01 * np.abs(ref).max()


def test_kane_ryan_banerjee_spin_up_first_half(tmp_path: Path) -> None:
    """Fast variant of the spin-up test: the first 8 s (through the extremum) against the
    unreduced nonlinear reference on a coarser (5-element) mesh; stiffened model only."""
    t = np.linspace(0.0, 8.0, 81)
    stiff = _krb_tips(tmp_path, 8.0, 81, tags=("stiff",))["stiff"]
    ref = _krb_reference(t, 5)
    assert ref.min() == pytest.approx(-0.573, abs=0.005)
    assert stiff.min() == pytest.approx(ref.min(), rel=0.03)
    assert np.abs(stiff - ref).max() < 0.04 * np.abs(ref).max()


FLEX_CHAIN = """
name: flex_chain
parameters: {{m: 1.0, l: 1.0, g: 9.81, k: 50.0, c: 0.5}}
gravity: [0, -g, 0]
coordinates: {{a: {{initial: 0.3, velocity: 0.7}}, b: {{initial: -0.2, velocity: -0.4}}}}
frames:
  link1: {{rotation: [[z, a]]}}
  link2: {{parent: link1, translation: [l, 0, 0], rotation: [[y, 0.2*b], [z, b]]}}
  tipframe: {{parent: beam.tip, translation: [0.1, 0, 0]}}
bodies:
  arm1: {{frame: link1, mass: m, center_of_mass: [0.5*l, 0, 0],
         inertia: {{diag: [0.05, 0.05, 0.1]}}}}
  lump: {{frame: tipframe, mass: 0.2, inertia: {{diag: [0.01, 0.01, 0.01]}}}}
elastic_bodies:
  beam: {{frame: link2, data: beam.npz, nodes: {{tip: 21}}}}
forces:
  tip: {{type: spring_damper, between: [ISYS, beam.tip], points: [[2.5, 0.3, 0], [0, 0, 0]],
        stiffness: k, damping: c, length: 0.5}}
  twist: {{type: torque, frame: beam.tip, vector: [0.3, 0.2, 0.1], in: beam.tip}}
outputs:
  tip_x: {{position: tipframe, in: ISYS, component: x}}
  tip_vy: {{velocity: tipframe, in: ISYS, component: y}}
"""


def _flex_chain(tmp_path: Path, two_sided: bool = False, form: str = "auto"):

    from beam_fe import beam

    from neweul_py.elastic.bodies.invariants import LOAD_CASES
    from neweul_py.elastic.reductors.invariants import compute_invariants, stress_stiffening

    b = beam(20, E=2.0e4)
    _lam, V = b.clamped_modes(4)
    kg = stress_stiffening(b.fe, lambda u: b.geometric_stiffness(b.axial_forces(u)),
                           support=np.arange(6), cases=LOAD_CASES)
    W = None
    if two_sided:  # an oblique left basis with the same span: W = V L^T, Wᵀ M V ≠ I
        W = V @ (np.eye(4) + 0.3 * np.random.default_rng(3).normal(size=(4, 4))).T
    inv = compute_invariants(b.fe, V, W, nodes=[21], geometric_stiffness=kg)
    np.savez(tmp_path / "beam.npz", **inv.to_flat())
    return _generate(tmp_path, FLEX_CHAIN.format(), form=form)


@pytest.mark.parametrize("two_sided", [False, True])
def test_elastic_jacobians_match_differences(tmp_path: Path, two_sided: bool) -> None:
    """Moving reference frame (two rotations), stiffening, a spring, a torque and a rigid body
    on the node frame: ``rhs_jacobian`` and ``output_jacobians`` equal central differences of
    ``rhs`` and ``outputs``; M is unsymmetric and regular."""
    mod = _flex_chain(tmp_path, two_sided)
    assert mod.COORDINATES == ["a", "b", "beam_q1", "beam_q2", "beam_q3", "beam_q4"]
    p = mod.default_parameters()
    rng = np.random.default_rng(0)
    x = np.array(mod.INITIAL_STATE) + 0.05 * rng.normal(size=mod.STATE_SIZE)
    J = mod.rhs_jacobian(0.0, x, p)
    C, _D = mod.output_jacobians(0.0, x, p)
    h = 1e-6
    Jd = np.empty_like(J)
    Cd = np.empty_like(C)
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = h
        Jd[:, j] = (mod.rhs(0.0, x + e, p) - mod.rhs(0.0, x - e, p)) / (2 * h)
        Cd[:, j] = (mod.outputs(0.0, x + e, p) - mod.outputs(0.0, x - e, p)) / (2 * h)
    np.testing.assert_allclose(J, Jd, rtol=1e-5, atol=1e-5 * np.abs(Jd).max())
    np.testing.assert_allclose(C, Cd, rtol=1e-6, atol=1e-8)
    M = mod.mass_matrix(0.0, x[:6], p)
    assert not np.allclose(M, M.T)
    assert mod.MASS_MATRIX_SYMMETRIC is False


def test_elastic_closed_and_recursive_forms_agree(tmp_path: Path) -> None:
    """The same elastic model generated in closed and in recursive form gives the same M,
    q − k and outputs (the elastic splice does not depend on the form)."""
    (tmp_path / "c").mkdir()
    (tmp_path / "r").mkdir()
    closed = _flex_chain(tmp_path / "c", form="closed")
    recursive = _flex_chain(tmp_path / "r", form="recursive")
    p = closed.default_parameters()
    x = np.array(closed.INITIAL_STATE) + 0.03
    np.testing.assert_allclose(closed.mass_matrix(0.0, x[:6], p),
                               recursive.mass_matrix(0.0, x[:6], p), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(closed.force_vector(0.0, x[:6], x[6:], p),
                               recursive.force_vector(0.0, x[:6], x[6:], p), rtol=1e-11,
                               atol=1e-11)
    np.testing.assert_allclose(closed.outputs(0.0, x, p), recursive.outputs(0.0, x, p),
                               rtol=1e-12, atol=1e-12)


def test_cached_module_follows_the_data_file(beam_dir: Path) -> None:
    """``api.generated_module`` keys its cache on the elastic data too: changing the data
    file (here: fewer modes in a rewritten invariants file) gives a fresh module."""
    from neweul_py.api import generated_module
    from neweul_py.elastic.io.reader import read_elastic_data

    np.savez(beam_dir / "beam.npz", **read_elastic_data(beam_dir / "beam.SID_FEM", 4))
    desc = _write(beam_dir, CLAMPED.replace("beam.SID_FEM", "beam.npz"))
    first = generated_module(desc, cache=beam_dir / "cache")
    assert len(load_generated(first).COORDINATES) == 4
    np.savez(beam_dir / "beam.npz", **read_elastic_data(beam_dir / "beam.SID_FEM", 2))
    second = generated_module(desc, cache=beam_dir / "cache")
    assert second != first
    assert len(load_generated(second).COORDINATES) == 2


@pytest.mark.parametrize("two_sided", [False, True])
def test_pendulum_splice_equals_the_body_equations(tmp_path: Path, two_sided: bool) -> None:
    """A body on a hinge (frame ``R_z(a)`` at the origin: ``J_T = 0``, ``J_R = e_z``,
    ``ā = ᾱ = 0``, ``ω = ȧ e_z``): the generated ``M`` and ``q − k`` equal the §2 body equations
    assembled by :class:`neweul_py.elastic.bodies.invariants.Invariants` (``mass_matrix``,
    ``velocity_terms``, ``elastic_forces``) premultiplied by ``J_bᵀ`` written out here — with
    stiffening, damping, gravity, one- and two-sided data. This checks the splice (frame
    kinematics, ``J_b``, gravity); the body equations themselves are checked against Newton's
    law of the mass points in tests/ffrf/test_body.py."""

    from beam_fe import beam

    from neweul_py.elastic.bodies.invariants import LOAD_CASES
    from neweul_py.elastic.reductors.invariants import compute_invariants, stress_stiffening

    b = beam(12, E=3.0e4)
    _lam, V = b.clamped_modes(4)
    kg = stress_stiffening(b.fe, lambda u: b.geometric_stiffness(b.axial_forces(u)),
                           support=np.arange(6), cases=LOAD_CASES)
    rng = np.random.default_rng(5)
    W = V @ (np.eye(4) + 0.3 * rng.normal(size=(4, 4))).T if two_sided else None
    fe = dataclasses.replace(b.fe, D=0.01 * b.fe.K)
    inv = compute_invariants(fe, V, W, geometric_stiffness=kg)
    np.savez(tmp_path / "b.npz", **inv.to_flat())
    mod = _generate(tmp_path, """
name: hinge
parameters: {g: 9.81}
gravity: [0, -g, 0]
coordinates: {a: {}}
frames:
  arm: {rotation: [[z, a]]}
elastic_bodies:
  beam: {frame: arm, data: b.npz}
""")
    p = mod.default_parameters()
    y = np.array([0.7, 0.01, -0.02, 0.015, 0.005])
    yd = np.array([1.3, 0.2, -0.1, 0.3, -0.2])
    q, qd = y[1:], yd[1:]
    Jb = np.zeros((10, 5))
    Jb[5, 0] = 1.0                               # α_z = ä
    Jb[6:, 1:] = np.eye(4)
    Mb = inv.mass_matrix(q)
    c, s = np.cos(y[0]), np.sin(y[0])
    g_frame = np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]]) @ np.array([0, -9.81, 0])
    acc = np.concatenate([-g_frame, np.zeros(3), np.zeros(4)])
    lhs = Mb @ acc + inv.velocity_terms(q, qd, np.array([0, 0, yd[0]]))
    lhs[6:] += inv.elastic_forces(q, qd)
    np.testing.assert_allclose(mod.mass_matrix(0.0, y, p), Jb.T @ Mb @ Jb, rtol=1e-12,
                               atol=1e-12)
    np.testing.assert_allclose(mod.force_vector(0.0, y, yd, p), -Jb.T @ lhs, rtol=1e-10,
                               atol=1e-10)
