"""Fast full-model frequency response (``neweul_py.elastic.quality.frf_sweep``): checked adaptive
rational interpolation against one sparse LU per frequency.

References: the direct solves of the same FE models (``frf_direct`` and the real-form
``quality.frf_full(method="direct")``), independent of the projection.
"""

from __future__ import annotations

import numpy as np
import pytest
from fe_builders import membrane_cavity, piston_duct

from neweul_py.elastic.quality.frf_sweep import frf_direct, frf_sweep
from neweul_py.elastic.quality.measures import frf_full, frf_full_checked
from neweul_py.errors import DataError


@pytest.mark.parametrize("make,inputs,outputs,f", [
    (lambda: piston_duct(200, stiffness=2e5, damping=20.0), None, None,
     np.linspace(5.0, 1500.0, 300)),
    (lambda: membrane_cavity(0.3), "force", ["umbo", "probe"], np.geomspace(50, 6000, 200)),
])
def test_sweep_matches_direct_solves(make, inputs, outputs, f):
    """Every frequency within 1e-6 (relative, per frequency) of direct sparse solves, with
    far fewer full solves than frequencies; the held-out checks are real errors ≤ rtol."""
    fe = make()
    res = frf_sweep(fe, f, inputs, outputs, rtol=1e-7)
    H = frf_direct(fe, f, fe.B(inputs), fe.C(outputs))
    err = np.linalg.norm((res.H - H).reshape(f.size, -1), axis=1) / np.linalg.norm(
        H.reshape(f.size, -1), axis=1)
    assert err.max() < 1e-6
    assert res.solved_hz.size + res.checked_hz.size < f.size / 3
    assert res.checked_hz.size == 2 and res.max_checked_error <= 1e-7
    assert np.allclose(frf_full(fe, f[:4], inputs, outputs), H[:4], rtol=1e-8, atol=0)


def test_direct_method_and_small_grids():
    """method="direct" and grids of ≤ 5 frequencies use one LU per frequency (no sweep
    record); an unknown method is refused."""
    fe = piston_duct(100, stiffness=2e5, damping=20.0)
    f = np.linspace(10.0, 900.0, 40)
    H, res = frf_full_checked(fe, f, method="direct")
    assert res is None
    H2, res2 = frf_full_checked(fe, f)
    assert res2 is not None and np.allclose(H2, H, rtol=1e-6, atol=1e-6 * np.abs(H).max())
    assert frf_full_checked(fe, f[:5])[1] is None
    with pytest.raises(DataError, match="one of auto, sweep, direct"):
        frf_full(fe, f, method="fast")


def test_budget_exhausted_falls_back_to_direct_solves():
    """With max_solves too small to converge, the remaining frequencies are solved directly:
    the result equals the direct one."""
    fe = piston_duct(100, stiffness=2e5, damping=20.0)
    f = np.linspace(10.0, 2000.0, 30)
    res = frf_sweep(fe, f, max_solves=4)
    H = frf_direct(fe, f, fe.B(), fe.C())
    assert res.checked_hz.size == 0
    assert np.allclose(res.H, H, rtol=1e-12, atol=0)
