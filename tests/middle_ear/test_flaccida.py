"""The pars flaccida (``middle_ear.flaccida`` and its DOF in the working-point model).

References: the bulge characteristic it implements (its root satisfies
``Δp = (v/C₀)(1 + (v/v_l)²)``, the tangent compliance is ``C₀`` at 0 and ``C₀/4`` at ``p_s``,
central differences of ``v(Δp)``), the kinetic energy of a paraboloid integrated numerically,
and lumped acoustics: at low frequency the canal, the TM, the pars flaccida and the cavity are
compliances, ``Y/(jω) = C_canal + (C_TM + C_pf) C_cav / (C_TM + C_pf + C_cav)``.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from neweul_py.middle_ear.flaccida import (
    flaccida_mass,
    flaccida_stiffness,
    flaccida_volume,
    quarter_volume,
)
from neweul_py.middle_ear.model import build_middle_ear
from neweul_py.middle_ear.parameters import MiddleEarParameters
from neweul_py.middle_ear.sweep import pressure_sweep

C0, PS, AREA = 1e-12, 150.0, 3e-6


@pytest.mark.parametrize("dp", [-4000.0, -150.0, -1e-3, 0.0, 1e-6, 37.0, 150.0, 4000.0])
def test_static_volume_solves_the_bulge_characteristic(dp) -> None:
    """The root satisfies the characteristic to round-off, with no cancellation near 0."""
    v = flaccida_volume(dp, C0, PS)
    vl = quarter_volume(C0, PS)
    assert (v / C0) * (1 + (v / vl) ** 2) == pytest.approx(dp, rel=1e-12, abs=1e-18)


def test_tangent_compliance_is_c0_at_rest_and_a_quarter_at_the_stiffening_pressure() -> None:
    """``A²/k`` is ``dv/dΔp``: ``C₀`` at 0, ``C₀/4`` at ``±p_s``, and central differences."""
    assert AREA**2 / flaccida_stiffness(0.0, AREA, C0, PS) == pytest.approx(C0, rel=1e-14)
    for dp in (PS, -PS):
        assert AREA**2 / flaccida_stiffness(dp, AREA, C0, PS) == pytest.approx(C0 / 4, rel=1e-12)
    h = 1e-3
    for dp in (-900.0, 20.0, 400.0):
        fd = (flaccida_volume(dp + h, C0, PS) - flaccida_volume(dp - h, C0, PS)) / (2 * h)
        assert AREA**2 / flaccida_stiffness(dp, AREA, C0, PS) == pytest.approx(fd, rel=1e-7)


def test_mass_is_the_kinetic_energy_of_a_paraboloid() -> None:
    """``½ m'' ∫ ẇ² dA`` with ``w = 2 w̄ (1 − r²/a²)`` and ``w̄ = 1``, by the trapezoid rule."""
    a = np.sqrt(AREA / np.pi)
    r = np.linspace(0.0, a, 20001)
    w = 2.0 * (1 - (r / a) ** 2)
    energy = 0.5 * 0.1 * np.trapezoid(w**2 * 2 * np.pi * r, r)
    assert flaccida_mass(AREA, 0.1) == pytest.approx(2 * energy, rel=1e-7)


def test_without_compliance_there_is_no_pars_flaccida() -> None:
    """``pf_compliance = 0`` (the default) adds no DOF: the model is the closed ring's."""
    sweep = pressure_sweep([0.0], MiddleEarParameters(), refine=0)
    assert "pf_volume_displacement" not in sweep.models[0].outputs
    with_pf = pressure_sweep([0.0], MiddleEarParameters(pf_compliance=C0), refine=0)
    assert with_pf.models[0].n_dofs == sweep.models[0].n_dofs + 1


def _admittance(params: MiddleEarParameters, dp: float, f: float) -> complex:
    fe = pressure_sweep([dp], params, refine=0).models[0]
    w = 2 * np.pi * f
    x = spla.spsolve((fe.K - w * w * fe.M).tocsc(), fe.B("canal_volume_acceleration")[:, 0])
    p = sum(wt * x[i] for i, wt in fe.outputs["entrance_pressure"])
    return 1 / (1j * w * p)


@pytest.mark.parametrize("dp", [0.0, 400.0, -400.0])
def test_low_frequency_admittance_adds_the_pars_flaccida_as_a_lumped_compliance(dp) -> None:
    """At 20 Hz the probe sees the lumped network of the module docstring: ``C_TM`` is taken
    from the model without pars flaccida, and the one with it must give the network's
    admittance with ``C_pf = A²/k`` at that static pressure (to 1e-4)."""
    base = MiddleEarParameters()
    me = build_middle_ear(base, refine=0)
    rc2 = base.rho_air * base.c_air**2
    c_canal = me.info["canal_volume_m3"] / rc2
    c_cav = (me.info["cavity_volume_m3"] + base.mastoid_volume) / rc2
    s = (_admittance(base, dp, 20.0) / (2j * np.pi * 20.0)).real - c_canal
    c_tm = s * c_cav / (c_cav - s)
    params = MiddleEarParameters(pf_compliance=C0, pf_stiffening_pressure=PS, pf_area=AREA)
    c_pf = AREA**2 / flaccida_stiffness(dp, AREA, C0, PS)
    expected = c_canal + (c_tm + c_pf) * c_cav / (c_tm + c_pf + c_cav)
    got = (_admittance(params, dp, 20.0) / (2j * np.pi * 20.0)).real
    assert got == pytest.approx(expected, rel=1e-4)
    assert got - c_canal - c_tm * c_cav / (c_tm + c_cav) > 0.05 * c_pf
