"""The middle ear's calibration set and forward model (neweul_py.middle_ear.calibration).

References: the definitions of the residuals (``(model − mean)/SD`` of the stated data,
Murakami's one-sided signs); and, for the forward model assembled in memory, the unreduced FE
model of the build's Δp = 0 working point read back from its file and coupled with the build's
chain through :func:`~neweul_py.middle_ear.validation.reference_frf` (the validation path).
"""

from __future__ import annotations

import numpy as np
import pytest

from neweul_py.middle_ear.calibration import (
    CALIBRATION,
    PENALTY,
    STATIC_PA,
    calibration_residuals,
    log_parabolic_peak,
    mesh_offsets,
    residual_labels,
)

KEYS = (*CALIBRATION, "murakami")


def _measures(**loss):
    """Measures at the calibration means, with umbo changes ``loss`` [dB] at ±k kPa."""
    umbo = {dp: 0.0 for dp in STATIC_PA}
    umbo |= {1000.0: -5.0, 2000.0: -9.2, 3000.0: -13.1, -1000.0: -2.0, -2000.0: -4.0,
             -3000.0: -6.0}
    umbo |= {float(k): v for k, v in loss.items()}
    return {"tw": 82.5, "ytm_mmho": float(np.exp(CALIBRATION["ytm"].mean)),
            "f_res": 1049.0, "stapes_peak_hz": float(np.sqrt(600.0 * 1500.0)),
            "loss": {"umbo": umbo}}


def test_residuals_vanish_at_the_means_and_count_in_sds():
    """At the data's means every residual is 0; TW one SD wide is a residual of 1."""
    m = _measures()
    assert np.allclose(calibration_residuals(m, KEYS), 0.0)
    m["tw"] = 82.5 + 19.1
    r = calibration_residuals(m, KEYS)
    assert r[0] == pytest.approx(1.0) and len(r) == len(residual_labels(KEYS)) == 13


def test_murakami_residuals_are_one_sided():
    """A gain at −1 kPa, and a change at +2 kPa smaller than at −2 kPa, each count in dB;
    losses that follow Murakami's signs count nothing."""
    m = _measures(**{"-1000.0": 0.5, "2000.0": -3.0})
    r = dict(zip(residual_labels(KEYS), calibration_residuals(m, KEYS), strict=True))
    assert r["gain-1kPa"] == pytest.approx(0.5)
    assert r["excess-2kPa"] == pytest.approx(1.0)          # −3 − (−4)
    assert r["gain-2kPa"] == 0.0 and r["excess-3kPa"] == 0.0


def test_width_not_reached_counts_as_the_whole_sweep_and_failure_as_penalty():
    """``TW = nan`` (the curve never halves) is taken as 400 daPa; a model that could not be
    evaluated gives :data:`PENALTY` everywhere."""
    m = _measures()
    m["tw"] = float("nan")
    assert calibration_residuals(m, ("tw",))[0] == pytest.approx((400 - 82.5) / 19.1)
    assert np.all(calibration_residuals(None, KEYS) == PENALTY)


def test_mesh_offsets_make_the_coarse_residuals_the_fine_ones():
    """The coarse mesh's measures with the offsets ``fine − coarse`` give the fine mesh's
    residuals, the one-sided signs included (reference: the fine residuals themselves);
    loss keys may be strings, as a JSON file of measures gives them back."""
    coarse = _measures(**{"-1000.0": -1.6, "3000.0": -11.7})
    fine = _measures(**{"-1000.0": 0.3, "3000.0": -11.0})
    fine |= {"tw": 73.0, "ytm_mmho": 0.48, "f_res": 831.0, "stapes_peak_hz": 1157.0}
    fine["loss"] = {"umbo": {str(k): v for k, v in fine["loss"]["umbo"].items()}}
    off = mesh_offsets(coarse, fine)
    assert off["umbo-1kPa"] == pytest.approx(1.9) and off["tw"] == pytest.approx(73.0 - 82.5)
    np.testing.assert_allclose(calibration_residuals(coarse, KEYS, off),
                               calibration_residuals(fine, KEYS), rtol=0, atol=1e-12)
    assert calibration_residuals(fine, KEYS)[residual_labels(KEYS).index("gain-1kPa")] == \
        pytest.approx(0.3)


@pytest.mark.slow
def test_forward_model_matches_the_validation_path_at_zero_pressure(tmp_path):
    """Stapes velocity and probe pressure at Δp = 0 of the in-memory forward model against
    the build's FE model read from its file and coupled with the build's chain
    (:func:`reference_frf`), at refine 0: within 1 % (the chain's φ is interpolated from a
    table in one, solved for in the other)."""
    from neweul_py.middle_ear.build import BuildOptions, build
    from neweul_py.middle_ear.calibration import CalibrationChain, calibration_measures
    from neweul_py.middle_ear.embs import model_path
    from neweul_py.middle_ear.parameters import MiddleEarParameters
    from neweul_py.middle_ear.validation import chain_module, reference_frf

    out = tmp_path / "build"
    build(out, BuildOptions(refine=0, pressures=(-2000.0, 0.0, 2000.0), tol=0.0))
    m = calibration_measures(MiddleEarParameters(), CalibrationChain(out, tmp_path / "c"), 0)
    f = np.array(m["stapes"]["frequency_hz"])[::8]
    ref = reference_frf(chain_module(out / "middle_ear.yaml", out / "fem", tmp_path / "g"),
                        model_path(out / "fem", 0.0), 0.0, f)
    want = 1e3 * np.abs(ref["stapes_velocity"] / ref["p_probe"])
    got = np.array(m["stapes"]["velocity_mm_s_Pa"])[::8]
    assert np.allclose(got, want, rtol=1e-2)


def test_peak_frequency_between_samples_is_the_vertex_of_a_log_parabola():
    """A peak that is a parabola in (ln f, ln |v|) (a log-normal resonance shape) is found
    exactly between the samples of the stapes band; at the band's end the sample is kept."""
    f = np.geomspace(200.0, 4000.0, 48)
    for centre in (612.0, 1234.0, 1499.0):
        mag = np.exp(-3.0 * (np.log(f) - np.log(centre)) ** 2)
        assert log_parabolic_peak(f, mag, int(np.argmax(mag))) == pytest.approx(centre, rel=1e-12)
    rising = f / f[-1]
    assert log_parabolic_peak(f, rising, f.size - 1) == f[-1]
