"""The mixing of parametric samples (``neweul_py.ffrf.parametric``): one product of the stacked
sample arrays must equal the weighted sum of every array of every sample.

Reference: the explicit sum ``Σ_i w_i X_i`` per array (the definition, equations.md §4).
"""

from __future__ import annotations

import numpy as np

from neweul_py.ffrf.parametric import ffrf_mix, ffrf_stack


def _sample(rng: np.random.Generator) -> dict:
    return {"mass": float(rng.uniform(1, 2)), "nq": 3, "fixed": True,
            "Me": rng.standard_normal((3, 3)), "ks": rng.standard_normal(3),
            "md0": rng.standard_normal(3),
            "quad": {"mass": float(rng.uniform(1, 2)), "T1": rng.standard_normal((4, 2)),
                     "C2": None, "where": {"J": (0, 9, (3, 3))}}}


def test_one_product_equals_the_weighted_sum_of_every_array() -> None:
    """Arrays, the mass, the nested body of a second-order field and extra rows (``S_V,i``)
    mixed with real and with complex weights (the complex step in σ) equal ``Σ w_i X_i``;
    the other entries are sample 1's."""
    rng = np.random.default_rng(3)
    samples = [_sample(rng) for _ in range(4)]
    rows = rng.standard_normal((4, 2, 5))
    mixing = ffrf_stack(samples, {"_sv": rows})
    assert mixing["stack"].shape[0] == 4
    for w in (rng.standard_normal(4), rng.standard_normal(4) + 1e-30j * rng.standard_normal(4)):
        got = ffrf_mix(mixing, w)
        for key in ("Me", "ks", "md0", "mass"):
            ref = sum(wi * s[key] for wi, s in zip(w, samples, strict=True))
            np.testing.assert_allclose(got[key], ref, rtol=1e-13, atol=1e-300)
            if np.iscomplexobj(w):
                np.testing.assert_allclose(np.imag(got[key]), np.imag(ref), rtol=1e-13)
        quad = sum(wi * s["quad"]["T1"] for wi, s in zip(w, samples, strict=True))
        np.testing.assert_allclose(got["quad"]["T1"], quad, rtol=1e-13)
        np.testing.assert_allclose(got["_sv"], np.tensordot(w, rows, axes=1), rtol=1e-13)
        assert got["nq"] == 3 and got["fixed"] is True and got["quad"]["C2"] is None
    # the samples themselves are untouched
    assert samples[0]["quad"]["T1"].shape == (4, 2)
