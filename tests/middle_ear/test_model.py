"""The middle-ear meshes and air matrices: antrum/mastoid behind the aditus."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from neweul_py.errors import ModelError
from neweul_py.middle_ear.model import build_middle_ear
from neweul_py.middle_ear.parameters import MiddleEarParameters


@pytest.fixture(scope="module")
def me0():
    return build_middle_ear(refine=0)


def _cavity_block(me):
    nc = me.canal.points.shape[0]
    sl = slice(nc, me.n_p)
    return me.Mf[sl][:, sl].toarray(), me.Kf[sl][:, sl].toarray()


def test_helmholtz_resonance_of_cavity_and_mastoid(me0):
    """Rigid TM and walls: the lowest non-zero mode of cavity + aditus + mastoid is the
    Helmholtz resonator ``ω² = (1/C_c + 1/C_m)/M`` (closed form; the cavity's own first
    acoustic mode is far above). ``M`` = aditus ``ρl/A`` + the cavity's own air, a duct of
    length ``L = V_c/S`` (S: the cavity section) closed at the TM, whose compliance is spread
    along it: ``ρL/(3S)`` (first order of the duct's impedance)."""
    p = me0.params
    mf, kf = _cavity_block(me0)
    lam = np.sort(sla.eigh(kf, mf, eigvals_only=True))
    assert abs(lam[0]) < 1e-6 * lam[1]  # constant pressure in cavity and mastoid
    v_c = me0.info["cavity_volume_m3"]
    rho_c2 = p.rho_air * p.c_air**2
    section = np.pi * p.tm_radius**2
    mass = p.rho_air * p.aditus_length / p.aditus_area + p.rho_air * v_c / section / (3 * section)
    w2 = rho_c2 * (1 / v_c + 1 / p.mastoid_volume) / mass
    assert lam[1] == pytest.approx(w2, rel=0.02)


def test_mastoid_adds_its_compliance_at_low_frequency(me0):
    """Uniform pressure in cavity and mastoid: ``1ᵀ Mf 1 = (V_c + V_m)/c²`` (the air's
    compliance times ρ), and the constant vector is a null vector of ``Kf``."""
    mf, kf = _cavity_block(me0)
    one = np.ones(mf.shape[0])
    v = me0.info["cavity_volume_m3"] + me0.params.mastoid_volume
    assert one @ mf @ one == pytest.approx(v / me0.params.c_air**2, rel=1e-10)
    assert np.abs(kf @ one).max() < 1e-12 * np.abs(kf).max()


def test_without_mastoid_the_cavity_is_closed():
    """``mastoid_volume = 0``: no mastoid DOF, the former closed cavity (DOF count of the
    earlier model, 1 331 at refine 0)."""
    me = build_middle_ear(MiddleEarParameters(mastoid_volume=0.0), refine=0)
    assert me.n_mastoid == 0 and me.dof_counts()["total"] == 1331
    assert me.Kf_aditus.nnz == 0


def test_bad_mastoid_data():
    """Negative volumes and non-positive aditus dimensions are refused, naming the field."""
    with pytest.raises(ModelError, match="mastoid_volume"):
        MiddleEarParameters(mastoid_volume=-1e-6)
    with pytest.raises(ModelError, match="aditus_length"):
        MiddleEarParameters(aditus_length=0.0)
