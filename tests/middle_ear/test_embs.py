"""The middle-ear EMBS end to end on the refine-0 mesh: ``neweul middle-ear build`` (FE sweep →
snapshot global basis → parametric TM + air body → description retargeted to the sweep →
generated module) → FRF and static state.

References: the unreduced FE model of the working point (at a sample and, between samples, the
FE model linearized there) coupled directly with the same chain
(:func:`neweul_py.middle_ear.validation.reference_frf`,
:func:`neweul_py.middle_ear.coupled.coupled_frf`); the FE static solution (``static.csv``); for
the physics, published temporal-bone measurements (docs/middle-ear-measurements.md §1–2: the
ASTM F2504 / Rosowski et al. 2007 normal stapes band, Gyo & Goode 1987, Murakami et al. 1997,
Kringlebotn & Gundersen 1985).
"""

from __future__ import annotations

import hashlib
import itertools
import json

import numpy as np
import pytest

from neweul_py.analysis import load_generated
from neweul_py.middle_ear import embs, validation
from neweul_py.middle_ear.build import BuildOptions, build
from neweul_py.middle_ear.study import embs_frf, low_db, transfer

PRESSURES = np.arange(-4000.0, 4001.0, 1000.0)
#: Gyo & Goode 1987, umbo loss below 2 kHz at +1/+2/+3 kPa (negative middle-ear pressure):
#: mean and standard deviation [dB] (docs/middle-ear-measurements.md §2).
GYO_GOODE = {1000.0: (-5.0, 1.0), 2000.0: (-9.2, 1.3), 3000.0: (-13.1, 1.8)}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """A refine-0 build without refinement (the 1-kPa samples) with its module, and the chain
    alone generated from its description."""
    data = tmp_path_factory.mktemp("me0") / "build"
    build(data, BuildOptions(refine=0, tol=0.0))
    record = json.loads((data / "build.json").read_text())
    mod = load_generated(data / record["module"])
    chain = validation.chain_module(data / "middle_ear.yaml", data / "fem", data / "chain")
    return data, (mod, chain), (data / "middle_ear.yaml").read_text()


@pytest.fixture(scope="module")
def study(built):
    """Umbo (TM node 1), malleus and stapes velocity per probe pressure at the 9 samples."""
    _data, (mod, _chain), _text = built
    f = np.geomspace(100.0, 8000.0, 40)
    return f, {float(dp): transfer(embs_frf(mod, dp, f), f) for dp in PRESSURES}


@pytest.mark.slow          # the refine-0 build with its module (13 s)
def test_the_module_reads_the_body_file_instead_of_a_copy(built) -> None:
    """Data by reference: the generated module names the body file relative to itself with
    its SHA-256, and its own data file holds no sample stack (reference: the body file's
    bytes)."""
    data, _modules, _text = built
    text = (data / "generated" / "middle_ear.py").read_text()
    digest = hashlib.sha256((data / "embs" / "tm_air.npz").read_bytes()).hexdigest()
    assert "'../embs/tm_air.npz'" in text and digest in text
    with np.load(next((data / "generated").glob("middle_ear.*.npz"))) as z:
        assert "tm/mixing/varying" not in z.files


def _low(study, key: str) -> dict[float, float]:
    f, H = study
    return {dp: low_db(H[dp][key], H[0.0][key], f) for dp in PRESSURES}

@pytest.mark.slow
@pytest.mark.parametrize("dp", [-4000.0, 0.0, 2000.0])
def test_embs_matches_the_unreduced_fe_model_at_the_samples(built, dp: float) -> None:
    """Umbo and stapes velocity per probe pressure at working points: ≤ 1e-3 below 2 kHz,
    ≤ 2 % to 5 kHz (measured at refine 0: ≤ 1.8e-4 over 100 Hz–5 kHz, largest at 100 Hz)."""
    data, (mod, chain), _ = built
    f = np.geomspace(100.0, 5000.0, 16)
    e = validation.errors(mod, chain, dp, f, validation.fe_model_at(dp, data, 0))
    low = f < 2000.0
    for key in ("umbo", "stapes"):
        assert e[key][low].max() <= 1e-3, (key, e[key][low].max())
        assert e[key].max() <= 2e-2, (key, e[key].max())


@pytest.mark.slow
def test_embs_between_samples_against_the_fe_model_linearized_there(built) -> None:
    """At Δp = 2500 Pa (between the samples 2000 and 3000 Pa) against the FE model
    linearized at 2500 Pa: the error of interpolating the FE matrices (cubic weights), measured
    at refine 0: 1.3 % (umbo) max to 5 kHz, 0.25 % below 2 kHz (0.75 % / 0.37 % while the
    static state used the dynamic modulus); asserted at the issue's 2 % and at 0.5 %. The
    fixture builds without refinement (``--tol 0``): the 1-kPa samples are too coarse for
    1e-3 between them; the refined body is tested below."""
    data, (mod, chain), _ = built
    f = np.geomspace(100.0, 5000.0, 16)
    fe = validation.fe_model_at(2500.0, data, 0)
    e = validation.errors(mod, chain, 2500.0, f, fe, damping="viscous")
    low = f < 2000.0
    for key in ("umbo", "stapes"):
        assert e[key][low].max() <= 5e-3, (key, e[key][low].max())
        assert e[key].max() <= 2e-2, (key, e[key].max())
    # in the loss-factor form (K + iG, docs/equations.md §1.1) the resonances above f_ref are
    # less damped than with the viscous equivalent, and the same interpolation error shows
    # more: measured at refine 0, umbo 3.0 % and stapes 1.7 % at 3.9 kHz, below 2 kHz 0.43 %
    e = validation.errors(mod, chain, 2500.0, f, fe)
    for key in ("umbo", "stapes"):
        assert e[key][low].max() <= 5e-3, (key, e[key][low].max())
        assert e[key].max() <= 5e-2, (key, e[key].max())


@pytest.mark.slow
def test_embs_is_stable_at_every_sample(built) -> None:
    """No right-half-plane pole of the coupled EMBS at the 9 working points (eigenvalues of
    the linearized first-order system; reference: a passive u–p model and chain)."""
    from neweul_py.analysis.linearize import linearize

    _data, (mod, _chain), _ = built
    for dp in np.arange(-4000.0, 4001.0, 1000.0):
        lin = linearize(mod, p=embs.parameters_at(mod, dp))
        m = lin.M0.shape[0]
        A = np.block([[np.zeros((m, m)), np.eye(m)],
                      [-np.linalg.solve(lin.M0, lin.Q), -np.linalg.solve(lin.M0, lin.P)]])
        s = np.linalg.eigvals(A)
        assert s.real.max() <= 1e-6 * np.abs(s).max(), (dp, s.real.max())


@pytest.mark.slow
def test_chain_carries_the_static_tangent_and_rotates_about_the_ossicular_axis(built) -> None:
    """The chain alone (TM removed, a static force at the malleus's umbo point): its stiffness
    equals the tangent of the sweep's static characteristic at every working point (reference:
    ``fem/static.csv``, the FE static state), and the stapes follows the umbo through the lever
    of the axis: the ratio lies near 1/1.3 (lever ratio 1.3, Rosowski 1993; the geometric
    lever 4.4/3.4 mm gives 0.77), between 0.5 (joint compliance) and 0.8 (measured at refine
    0: 0.66 at Δp = 0, 0.75–0.77 at ±4 kPa where the stiffened joint passes more). The former chain
    moved the stapes by 0.007 of the umbo."""
    data, _mods, text = built
    mod = embs.calibration_module(text, embs.node_positions(data / "fem"), data / "calib")
    tangent = embs.sweep_tangents(data / "fem")
    phi = embs.factor_table(mod, tangent)
    for dp in PRESSURES:
        p = embs.parameters_at(mod, dp)
        p[list(mod.PARAMETERS).index(embs.PHI)] = phi[dp]
        r = embs.umbo_stiffness(mod, p)
        assert abs(r["k"] / tangent[dp] - 1.0) < 1e-6, (dp, r["k"], tangent[dp])
        assert 0.5 < r["stapes_ratio"] < 0.8, (dp, r["stapes_ratio"])


def _first_peak(f: np.ndarray, h: np.ndarray) -> int:
    """Index of the first local maximum of ``|h|`` (the middle-ear resonance)."""
    a = np.abs(h)
    k = np.flatnonzero((a[1:-1] >= a[:-2]) & (a[1:-1] >= a[2:]))
    return int(k[0] + 1) if k.size else int(np.argmax(a))


@pytest.mark.slow
def test_stapes_velocity_at_zero_pressure_in_the_normal_temporal_bone_band(study) -> None:
    """Δp = 0: the stapes velocity per probe pressure rises (stiffness controlled, phase
    leading by 30–90° at 0.3 kHz) to its first peak between 0.6 and 1.5 kHz at 0.03 to
    0.3 mm/s/Pa — the normal band of ASTM F2504 / Rosowski et al. 2007 and Chien et al. 2009
    as far as it is available here (docs/middle-ear-measurements.md §1). Measured at refine 0:
    0.25 mm/s/Pa at 1.48 kHz, +75° at 0.3 kHz (Chien: +0.2 period = +72°)."""
    f, H = study
    h = H[0.0]["stapes"]
    k = _first_peak(f, h)
    assert 600.0 <= f[k] <= 1500.0, f[k]
    assert 3e-5 <= abs(h[k]) <= 3e-4, abs(h[k])
    assert np.all(np.diff(np.abs(h[: k + 1])) > 0)
    k3 = int(np.argmin(np.abs(f - 300.0)))
    assert 30.0 < np.degrees(np.angle(h[k3])) <= 90.0, np.degrees(np.angle(h[k3]))


@pytest.mark.slow
def test_stapes_volume_displacement_at_low_frequency_matches_kringlebotn_gundersen(study) -> None:
    """Kringlebotn & Gundersen 1985 (68 temporal bones, abstract): the round-window volume
    displacement per eardrum pressure is about flat below 1 kHz at 6.8·10⁻⁵ mm³/Pa (level
    average; the 20 most sensitive ears 5 dB above). The cochlear fluid is incompressible, so
    that is the stapes volume displacement ``A_fp |v_s| / ω`` (footplate 3.2 mm², as the
    cochlear load of ``ossicles.yaml``). The EMBS's mean over 200–800 Hz lies within ±6 dB
    (individual bones spread about ±10 dB, ASTM F2504); and it is flat there within ±3 dB.
    Measured at refine 0: −4.2 to −2.1 dB (mean −3.6 dB), i.e. the model's stapes moves
    about two thirds of the level average, inside the spread but on its low side."""
    f, H = study
    band = (f >= 200.0) & (f <= 800.0)
    vol = 3.2e-6 * np.abs(H[0.0]["stapes"][band]) / (2 * np.pi * f[band])   # m³/Pa
    db = 20 * np.log10(vol / 6.8e-14)
    assert -6.0 <= float(np.mean(db)) <= 6.0, db
    assert float(db.max() - db.min()) <= 3.0, db


@pytest.mark.slow
def test_stapes_velocity_has_its_largest_peak_in_the_normal_band(study) -> None:
    """The same band for the largest peak (ASTM F2504 / Rosowski et al. 2007: one broad peak
    at 0.6–1.5 kHz). Measured with the off-centre umbo: refine 0 0.270 mm/s/Pa
    at 1.43 kHz (the next peak 0.152 at 2.23 kHz, 5.0 dB below), refine 1 0.259 at 1.45 kHz
    (7.4 dB above the next); it stays the largest with the TM modulus ×1.2 and the cochlear
    load ×1.5, which made the centred cone's TM mode the largest (its margin was 1.1 dB;
    CHANGELOG.md). The frequency is the tight part:
    3–4 % inside the band's edge."""
    f, H = study
    k = int(np.argmax(np.abs(H[0.0]["stapes"])))
    assert 600.0 <= f[k] <= 1500.0, f[k]


@pytest.mark.slow
def test_stapes_velocity_falls_above_its_peak_without_a_second_resonance(study) -> None:
    """Above the main peak the measured stapes response falls: Kringlebotn & Gundersen 1985
    (68 temporal bones) give a volume displacement falling ≈ 15 dB/octave above 1 kHz, i.e.
    ≈ 9 dB/octave in velocity, so 0.6 octave above a 1.4 kHz peak (2.1–2.3 kHz, where a
    centred cone has its strongly driven TM mode) about 5–6 dB below the peak; and the TM's
    asymmetry mistunes its modes into a smooth response (Fay et al. 2006). Held to: the
    largest stapes velocity in 1.9–3.2 kHz at least 4 dB below the main peak (2 dB for the
    spread of bones). Measured at refine 0: 5.0 dB with the off-centre umbo and the manubrium
    to the rim (0.270 at 1.43 kHz, 0.152 at 2.23 kHz); the former centred cone with a 0.8-
    radius manubrium: 3.2 dB (refine 1: 7.3 dB against 0.9 dB;
    examples/middle_ear/README.md)."""
    f, H = study
    s = np.abs(H[0.0]["stapes"])
    main = s[(f >= 600.0) & (f <= 1600.0)].max()
    above = s[(f >= 1900.0) & (f <= 3200.0)].max()
    assert 20 * np.log10(main / above) >= 4.0, 20 * np.log10(main / above)


@pytest.mark.slow
def test_static_pressure_of_either_sign_lowers_low_frequency_transmission(study) -> None:
    """Mean change 100–1000 Hz re Δp = 0: a loss for either sign at umbo, malleus and stapes,
    growing with |Δp| on each side, and larger for negative middle-ear pressure (Δp > 0) than
    for the same positive one (Murakami et al. 1997; Gyo & Goode 1987)."""
    for key in ("umbo", "malleus", "stapes"):
        low = _low(study, key)
        for side in (1.0, -1.0):
            steps = [low[side * a] for a in (0.0, 1000.0, 2000.0, 3000.0, 4000.0)]
            assert all(b < a for a, b in itertools.pairwise(steps)), (key, side, steps)
        for a in (1000.0, 2000.0, 3000.0, 4000.0):
            assert low[a] < low[-a], (key, a, low[a], low[-a])


@pytest.mark.slow
def test_umbo_loss_within_two_standard_deviations_of_gyo_goode(study) -> None:
    """Umbo loss (TM node 1 and the malleus at the umbo) at +1/+2/+3 kPa within Gyo & Goode's
    mean ± 2 standard deviations (5 temporal bones, 1987). Measured at refine 0: TM node
    −6.1/−9.7/−11.4 dB, malleus −6.1/−9.7/−11.3 dB (``s₊`` is fitted to the malleus's means
    at refine 1 and 2, where it lies within 0.6 and 0.8 SD: examples/middle_ear/README.md)."""
    for key in ("umbo", "malleus"):
        low = _low(study, key)
        for dp, (mean, sd) in GYO_GOODE.items():
            assert abs(low[dp] - mean) <= 2.0 * sd, (key, dp, low[dp], mean)


@pytest.mark.slow
def test_stapes_loses_less_than_the_umbo(study) -> None:
    """Murakami et al. 1997 (15 temporal bones): the change in stapes vibration is smaller
    than that of the umbo at low frequencies, for either sign of Δp. The measured umbo is the
    manubrium tip, i.e. the malleus at the umbo: the stapes loses less at every working point.
    Against the TM node at the umbo (tied to the malleus by the TM–manubrium springs) it is
    asserted up to ±2 kPa (refine 1 holds it at every Δp since the static state has its own
    modulus; examples/middle_ear/README.md)."""
    st, um, ma = _low(study, "stapes"), _low(study, "umbo"), _low(study, "malleus")
    for dp in PRESSURES[PRESSURES != 0.0]:
        assert st[dp] > ma[dp], (dp, st[dp], ma[dp])
        if abs(dp) <= 2000.0:
            assert st[dp] > um[dp], (dp, st[dp], um[dp])


@pytest.mark.slow
def test_static_equilibrium_of_the_body_and_chain_is_the_fe_static_state(built) -> None:
    """The body carries each working point's static state (``static/*``); with the static
    interface forces and the chain's static characteristic the reduced static problem
    (:func:`~neweul_py.elastic.quality.static_equilibrium.tied_static_equilibrium`, malleus tied to
    the
    manubrium nodes) gives the FE static umbo displacement and swept volume (reference: the
    FE static solution, ``static.csv`` of ``neweul fem middle-ear``, and at 2500 Pa the FE
    model built there): with the closed-form characteristic ≤ 1e-9 at the samples and
    ≤ 5e-3 between them (the static state mixed by the body's weights; measured 3.0e-3 at
    2500 Pa, refine 0, 1-kPa samples); with the
    ``ossicles.yaml`` table ≤ 3 % (the table's own error: 7 mN at −55 µm)."""
    data, _, _ = built
    rows = validation.static_errors(data, [2500.0])
    tol = {(True, "F(s)"): 1e-9, (False, "F(s)"): 5e-3, (True, "table"): 3e-2,
           (False, "table"): 3e-2}
    assert {r[0] for r in rows} == {-4000.0, -3000.0, -2000.0, -1000.0, 1000.0, 2000.0, 2500.0,
                                    3000.0, 4000.0}
    for dp, sample, kind, e_umbo, e_volume in rows:
        assert max(abs(e_umbo), abs(e_volume)) <= tol[(sample, kind)], (dp, kind, e_umbo,
                                                                         e_volume)


@pytest.mark.slow
def test_refined_body_between_samples_against_the_fe_model_linearized_there(tmp_path):
    """Refine 0, 9 working points and the refinement (default tolerance): between samples the
    EMBS against the unreduced FE model linearized there with the same chain: ≤ 1e-3 below
    2 kHz and ≤ 2 % to 5 kHz at points that are neither samples nor refinement test points
    (viscous damping on both sides, as the body's time-domain ``D``)."""
    data = tmp_path / "b"
    record = build(data, BuildOptions(refine=0))
    mod = load_generated(data / record["module"])
    chain = validation.chain_module(data / "middle_ear.yaml", data / "fem", data / "chain")
    f = np.geomspace(100.0, 5000.0, 16)
    low = f < 2000.0
    for dp in (-1400.0, 600.0, 2600.0):
        assert dp not in record["samples_Pa"]
        e = validation.errors(mod, chain, dp, f, validation.fe_model_at(dp, data, 0), "viscous")
        for key in ("umbo", "stapes"):
            assert e[key][low].max() <= 1e-3, (dp, key, e[key][low].max())
            assert e[key].max() <= 2e-2, (dp, key, e[key].max())


@pytest.mark.slow
def test_the_study_writes_its_tables_and_plots(built, tmp_path):
    """``neweul middle-ear study``: the tables hold the static state and the transfer
    functions at the nine pressures (reference: the build's samples), and the low-frequency
    change at Δp = 0 is zero by definition; the plots are written."""
    from neweul_py.cli import main

    data, _, _ = built
    out = tmp_path / "study"
    assert main(["middle-ear", "study", "--dir", str(data), "--out", str(out), "--nf", "12",
                 "-q"]) == 0
    text = (out / "results.md").read_text()
    for dp in PRESSURES:
        assert f"| {dp:+.0f} |" in text
    assert "| +0 | +0.00 | +0.00 | +0.00 |" in text
    for name in ("frf.csv", "frf.png", "dp_trend.png", "static.png"):
        assert (out / name).stat().st_size > 0


@pytest.mark.slow          # a refined refine-0 build with its module (≈ 40 s)
def test_the_identified_ear_with_a_pars_flaccida_matches_the_fe_model_near_rest(
        tmp_path_factory) -> None:
    """``examples/middle_ear/identified.yaml`` built (``BuildOptions.parameters``: a pars
    flaccida, so that samples go down to ``p_s/8`` near rest) against the unreduced FE model
    of the same data with the same chain, linearized between samples where the pars
    flaccida's stiffness changes fastest (measured at refine 0: ≤ 5.5e-4 below 2 kHz); its
    static state at the samples against the FE static solution with the build's chain; and
    at 226 Hz the canal's admittance ``Y − Y_TM``, which Δp cannot change, the same at −2, 0
    and +2 kPa within 2 % (0.8 % measured; 24 % with a constant row, the first
    sample's pars tensa alone)."""
    from pathlib import Path

    from neweul_py.middle_ear.parameters import read_parameters

    data = tmp_path_factory.mktemp("me_id") / "build"
    ear = Path(__file__).parents[2] / "examples" / "middle_ear" / "identified.yaml"
    build(data, BuildOptions(refine=0, parameters=read_parameters(ear)))
    record = json.loads((data / "build.json").read_text())
    assert record["parameters"]["pf_compliance"] > 0
    mod = load_generated(data / record["module"])
    chain = validation.chain_module(data / "middle_ear.yaml", data / "fem", data / "chain")
    f = np.geomspace(100.0, 5000.0, 16)
    for dp in (-30.0, 15.0):
        e = validation.errors(mod, chain, dp, f, validation.fe_model_at(dp, data, 0))
        for key in ("umbo", "stapes"):
            assert e[key][f < 2000.0].max() <= 1e-3, (dp, key, e[key].max())
            assert e[key].max() <= 1e-2, (dp, key, e[key].max())
    # the eardrum seen from the probe: the canal's admittance Y − Y_TM does not depend on Δp
    # (rigid walls, linear air) when Y_TM is the whole eardrum's at Δp (pars flaccida included)
    from neweul_py.middle_ear.clinical import build_model, eardrum_volume, immittance

    mod2, params = build_model(data, 0.0)
    drum = eardrum_volume(data, mod2)
    canal = [im.y_probe[0] - im.y_tm[0] for im in
             (immittance(mod2, params, dp, [226.0], eardrum=drum) for dp in (-2000, 0, 2000))]
    assert max(abs(c / canal[1] - 1) for c in canal) < 0.02, canal
    # the static state with the build's own chain (k_chain, s±), not the defaults'
    rows = validation.static_errors(data)
    assert {r[2] for r in rows} == {"F(s)"} and len(rows) >= 10
    assert max(max(abs(r[3]), abs(r[4])) for r in rows) <= 1e-9
