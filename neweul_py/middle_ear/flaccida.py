"""The pars flaccida: a lumped, strongly stiffening membrane between the canal and the cavity.

docs/equations-middle-ear.md §8. The pars flaccida (Shrapnell's membrane) closes the tympanic
ring above the pars tensa; it is thicker, has no fibrous layer and is far less tensed, so that
it moves with small static pressures and stiffens quickly (it bulges laterally, and is pushed
against the bone of the attic medially: Gea et al. 2010). It shunts canal volume velocity
around the pars tensa, past the malleus (Teoh et al. 1997 in gerbil).

The model is one degree of freedom, the membrane's mean normal displacement ``w`` (medial
positive), with the volume displacement ``v = A w`` over its area ``A``, loaded by the mean
pressures over two patches of the air next to the superior rim of the TM, one in the canal
and one in the cavity. Its static characteristic is the volume form of the bulge equation of
a clamped circular membrane with a prestress (Beams 1959; Vlassak & Nix 1992: ``Δp`` is a
linear plus a cubic term in the centre deflection, and ``v ≈ π a² h / 2``)::

    Δp(v) = (v / C₀) (1 + (v / v_l)²),    v_l = C₀ p_s / 2,

with the compliance ``C₀`` at ``Δp = 0`` and the stiffening pressure ``p_s``, at which the tangent
compliance ``dv/dΔp`` has fallen to ``C₀/4``. As a structural DOF ``w``: the force is
``A (p̄_canal − p̄_cavity)``, the tangent stiffness ``k = A² dΔp/dv``, the mass ``(4/3) m'' A`` (the
kinetic energy of a paraboloid of mean displacement ``w``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["flaccida_mass", "flaccida_stiffness", "flaccida_volume", "quarter_volume"]


def quarter_volume(compliance: float, stiffening_pressure: float) -> float:
    """``v_l = C₀ p_s / 2`` [m³]: where the tangent compliance is ``C₀/4``."""
    return 0.5 * compliance * stiffening_pressure


def flaccida_volume(dp: float, compliance: float, stiffening_pressure: float) -> float:
    """The static volume displacement ``v`` [m³] at the pressure difference ``dp`` [Pa].

    The one real root of ``v³ + v_l² v − C₀ v_l² Δp = 0`` (the characteristic in the module
    docstring), in the hyperbolic form of the depressed cubic with a positive linear
    coefficient ``P = v_l²`` and ``Q = −C₀ v_l² Δp``:
    ``v = −2 √(P/3) sinh(⅓ arsinh((3Q / 2P) √(3/P)))`` (no cancellation near ``Δp = 0``).

    Examples
    --------
    >>> v = flaccida_volume(300.0, 1e-12, 200.0)
    >>> round((v / 1e-12) * (1 + (v / quarter_volume(1e-12, 200.0)) ** 2), 9)
    300.0
    """
    vl = quarter_volume(compliance, stiffening_pressure)
    big_p, big_q = vl * vl, -compliance * vl * vl * float(dp)
    arg = (3.0 * big_q / (2.0 * big_p)) * np.sqrt(3.0 / big_p)
    return float(-2.0 * np.sqrt(big_p / 3.0) * np.sinh(np.arcsinh(arg) / 3.0))


def flaccida_stiffness(dp: float, area: float, compliance: float,
                       stiffening_pressure: float) -> float:
    """Tangent stiffness ``k = A² dΔp/dv = (A²/C₀)(1 + 3 (v/v_l)²)`` [N/m] of the mean
    displacement at the static pressure difference ``dp``."""
    v = flaccida_volume(dp, compliance, stiffening_pressure)
    vl = quarter_volume(compliance, stiffening_pressure)
    return area * area / compliance * (1.0 + 3.0 * (v / vl) ** 2)


def flaccida_mass(area: float, surface_density: float) -> float:
    """``(4/3) m'' A`` [kg]: the mass of the mean displacement of a paraboloid
    ``w(r) = 2 w̄ (1 − r²/a²)`` (``½ m'' ∫ ẇ² dA = ½ (4/3) m'' A ẇ̄²``)."""
    return 4.0 / 3.0 * surface_density * area
