"""Physical and geometric data of the middle-ear FE model (SI units) and its validity limits.

Every value with its source: ``docs/middle-ear-data.md`` and
``docs/middle-ear-measurements.md``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, fields
from pathlib import Path

import yaml

from ..errors import DataError, ModelError

__all__ = [
    "MAX_DISPLACEMENT_FRACTION",
    "MAX_PARAMETER_FILE_BYTES",
    "MAX_VOLUME_FRACTION",
    "THIN_SHELL_RATIO",
    "MiddleEarParameters",
    "check_parameters",
    "read_parameters",
]

#: Largest parameter file read [bytes]: a mapping of a few dozen numbers.
MAX_PARAMETER_FILE_BYTES = 1 << 20


#: Thin-shell bound of the TM: ``thickness ≤ radius / THIN_SHELL_RATIO``.
THIN_SHELL_RATIO = 20.0
#: Validity of a static state (:func:`static_validity`): ``|ΔV|`` at most this fraction of the
#: volume of each air space (the air meshes stay in the reference geometry).
MAX_VOLUME_FRACTION = 0.05
#: Validity of a static state: the largest TM displacement at most this fraction of the TM's
#: reference depth (``max z − min z`` of the profile; the cone inverts at about 1).
MAX_DISPLACEMENT_FRACTION = 0.5


@dataclass(frozen=True)
class MiddleEarParameters:
    """Physical and geometric data (SI units); sources in ``docs/middle-ear-data.md``.

    Parameters
    ----------
    tm_area
        Physical TM area [m²] (Hudde & Engel 1998): 60 mm².
    tm_depth
        Cone depth of the TM [m] (Koike 2002; Gan 2004: 1.5–2 mm).
    tm_bulge
        Lateral bulge of the radial generators at mid-radius [m] (curved radial fibres,
        Funnell & Laszlo 1978): profile ``z = h (1 − ρ) − 4 δ ρ (1 − ρ)``.
    tm_thickness
        TM thickness [m] (Kuypers et al. 2006): 0.08 mm. At most ``radius / 20`` (thin-shell
        limit :data:`THIN_SHELL_RATIO`: the facet shell has Kirchhoff bending without
        transverse shear; for a clamped circular plate the Mindlin shear term adds
        ``8 / (3 κ (1 − ν)) · (t/a)²`` ≈ ``4.6 (t/a)²`` to the centre deflection ``p a⁴/(64 D)``
        — Wang, Reddy & Lee, *Shear Deformable Beams and Plates*, 2000 — i.e. ≈ 1 % at
        ``t = a/20``; the TM has ``a/t ≈ 55``).
    tm_E, tm_nu, tm_rho
        Pars tensa Young's modulus (storage modulus), Poisson ratio, density. ``tm_E`` = 26 MPa
        and ``tm_loss`` = 0.13 are one measurement's pair: Zhang & Gan 2013 (dynamic modulus of
        the human TM, E′ 15.1 → 27.6 MPa and E″ 0.28 → 4.1 MPa from 1 Hz to 3.8 kHz), each
        interpolated as a power law to 2 kHz, the band of the TM's first coupled modes
        (E′ 26.3 MPa, E″/E′ 0.127; docs/middle-ear-measurements.md §6). Static FE models
        fitted at acoustic frequencies give 32 MPa (Wada & Kobayashi; De Greef 2014).
        ``tm_E`` is the modulus of the small motions about the static state (the material
        part of the working point's tangent and of its loss).
    tm_E_static
        Modulus of the static state under Δp [Pa]: 15.1 MPa, Zhang & Gan 2013's storage
        modulus at 1 Hz, their lowest frequency (a pressure change held for seconds or a
        swallow of a few hundred ms is slower still). The static state and its membrane
        prestress come from this modulus, the dynamics about it from ``tm_E``
        (docs/equations-middle-ear.md §3).
    tm_loss
        TM loss factor η (above; De Greef et al. 2014: 0.01–0.13).
    manubrium_reach
        Fraction of the way from the umbo to the superior rim covered by the manubrium nodes
        (rim nodes excluded): 1, the manubrium runs from the umbo to the lateral process of
        the malleus, which lies at the superior margin of the pars tensa (the malleal
        prominence; the anterior and posterior striae run from it to the tympanic spines and
        bound the pars tensa: docs/middle-ear-measurements.md §6).
    umbo_offset
        Anterior offset of the umbo from the centre of the (circular) rim, as a fraction of
        the radius: 0.16, so that the posterior-superior quadrant (the quadrants cut by the
        manubrium and by the line through the umbo across it) holds 31 % of the pars tensa,
        as Kassem et al. 2022 measured in 23 temporal bones (the largest quadrant; 25 % for a
        centred umbo). Mesh: :func:`neweul_py.fem.mesh.cone_membrane`.
    k_tm_manubrium
        Total TM–manubrium attachment stiffness [N/m] (LVATB1, Lobato et al.: 36 933 N/m).
    k_chain
        Small-displacement stiffness ``k₀`` of the ossicular chain at the umbo [N/m]: the
        malleus ligaments (893) in parallel with the incus path — incudomalleolar joint
        (11 410) in series with the incus ligament (129) plus the incudostapedial joint
        (12 581) in series with the annular ligament (764) — of LVATB1: ≈ 1.68·10³ N/m.
    chain_limit_medial, chain_limit_lateral
        Limit displacements ``s₊``, ``s₋`` [m] of the chain's stiffening characteristic at the
        umbo, ``F(s) = −sign(s) k₀ s± ln(1 − |s|/s±)`` (tangent ``k₀/(1 − |s|/s±)``;
        :mod:`neweul_py.middle_ear.chain`): medial (``s > 0``, the stapes pushed into the
        vestibule against the annular ligament) and lateral (the incudomalleolar joint
        yields, Hüttenbrink 1988). ``s₊`` = 120 µm: the low-frequency loss of the malleus at
        the umbo (the point Gyo & Goode measured) against their means at +1/+2/+3 kPa, on the
        unreduced FE model with the 3-D chain at refine 1 (RMS of the z-scores 0.31;
        ``docs/middle-ear-measurements.md`` §2, ``examples/middle_ear/README.md``). The fit is
        shallow: with the static modulus ``tm_E_static`` most of the loss is the TM's own
        stress stiffening. ``s₋`` = 140 µm: lateral softer than medial (the joints glide);
        no measured magnitudes for Δp < 0 were available.
    mastoid_volume
        Air volume of the antrum and the mastoid air cells [m³] behind the aditus, a lumped
        compliance ``V_m/(ρc²)`` (0: a closed tympanic cavity). 3.5 cm³, so that the middle-ear
        air is 4 cm³ (2–6 cm³: Molvaer et al. 1978; mastoid 0.7–21 cm³: Swarts et al. 2011).
    aditus_area, aditus_length
        The aditus ad antrum as a lumped inertance ``ρ l / A`` [m², m] (order of magnitude
        from anatomy; Stepp & Voss 2005; Keefe 2015).
    mastoid_loss
        Loss factor of the aditus/mastoid branch (viscothermal losses of the air-cell
        system, Keefe 2015; estimate).
    canal_length, canal_diameter
        Ear canal [m] (Rosowski 1993): 25 mm, 7.5 mm.
    cavity_volume
        Tympanic cavity volume [m³] (Hudde & Engel 1998): 0.5 cm³; more than
        :attr:`min_cavity_volume`.
    rho_air, c_air
        Air density [kg/m³] and speed of sound [m/s].
    air_loss
        Small acoustic loss factor of the air.
    probe_distance
        Probe microphone on the canal's axis (through the rim's centre) this far lateral of
        the TM rim plane [m].
    pf_compliance
        Volume compliance ``C₀`` [m³/Pa] of the pars flaccida at ``Δp = 0``
        (:mod:`neweul_py.middle_ear.flaccida`); 0 (default): no pars flaccida, the tympanic
        ring is closed by the pars tensa alone.
    pf_stiffening_pressure
        ``p_s`` [Pa]: the static pressure difference at which the pars flaccida's tangent
        compliance has fallen to ``C₀/4`` (its bulge characteristic).
    pf_area
        Area of the pars flaccida [m²]: 3 mm², an estimate (5 % of the pars tensa; in gerbil,
        whose pars flaccida is large, 2.1–2.5 mm² against 17–18 mm², Buytaert et al. 2011). It
        sets the size of the air patches that load it and, with ``pf_surface_density``, its mass.
    pf_surface_density
        Mass per area of the pars flaccida [kg/m²]: 0.12, the TM's density on 100 µm (an
        estimate: thicker than the pars tensa; its mass is felt only above a few kHz).
    f_ref
        Frequency [Hz] at which the equivalent viscous damping of the time domain matches the
        loss factors (the frequency domain uses the loss factors themselves,
        ``K (1 + iη)``).
    """

    tm_area: float = 60e-6
    tm_depth: float = 2.0e-3
    tm_bulge: float = 0.5e-3
    tm_thickness: float = 80e-6
    tm_E: float = 26e6
    tm_E_static: float = 15.1e6
    tm_nu: float = 0.3
    tm_rho: float = 1200.0
    tm_loss: float = 0.13
    manubrium_reach: float = 1.0
    umbo_offset: float = 0.16
    k_tm_manubrium: float = 36933.0
    k_chain: float = 1683.0
    chain_limit_medial: float = 120e-6
    chain_limit_lateral: float = 140e-6
    canal_length: float = 25e-3
    canal_diameter: float = 7.5e-3
    cavity_volume: float = 0.5e-6
    mastoid_volume: float = 3.5e-6
    aditus_area: float = 10e-6
    aditus_length: float = 4e-3
    mastoid_loss: float = 0.2
    rho_air: float = 1.2
    c_air: float = 343.0
    air_loss: float = 0.01
    probe_distance: float = 3e-3
    f_ref: float = 1000.0
    pf_compliance: float = 0.0
    pf_stiffening_pressure: float = 200.0
    pf_area: float = 3e-6
    pf_surface_density: float = 0.12

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not (isinstance(v, int | float) and math.isfinite(v)):
                raise ModelError(f"must be a finite number, got {v!r}", f"middle_ear.{f.name}")
        positive = (
            "tm_area tm_thickness tm_E tm_E_static tm_rho k_tm_manubrium k_chain canal_length "
            "canal_diameter cavity_volume rho_air c_air probe_distance f_ref "
            "chain_limit_medial chain_limit_lateral aditus_area aditus_length "
            "pf_stiffening_pressure pf_area pf_surface_density"
        ).split()
        for name in positive:
            if getattr(self, name) <= 0:
                raise ModelError(
                    f"must be positive, got {getattr(self, name)!r}", f"middle_ear.{name}"
                )
        if self.pf_compliance < 0:
            raise ModelError("must be ≥ 0 (0: no pars flaccida)", "middle_ear.pf_compliance")
        if self.mastoid_volume < 0:
            raise ModelError("must be ≥ 0 (0: no antrum/mastoid)", "middle_ear.mastoid_volume")
        for name in ("tm_loss", "air_loss", "mastoid_loss"):
            if not 0 <= getattr(self, name) < 1:
                raise ModelError("loss factor must be in [0, 1)", f"middle_ear.{name}")
        if not 0 < self.manubrium_reach <= 1:
            raise ModelError("must be in (0, 1]", "middle_ear.manubrium_reach")
        if not 0 <= self.umbo_offset < 0.5:
            raise ModelError("must be in [0, 0.5) (a fraction of the TM radius)",
                             "middle_ear.umbo_offset")
        a = self.tm_radius
        if self.tm_thickness > a / THIN_SHELL_RATIO:
            raise ModelError(
                f"TM thickness {self.tm_thickness:.4g} m exceeds the thin-shell limit radius/"
                f"{THIN_SHELL_RATIO:g} = {a / THIN_SHELL_RATIO:.4g} m (the shell element has no "
                "transverse shear; beyond the limit that error exceeds ≈ 1 %)",
                "middle_ear.tm_thickness",
            )
        if not 0 <= self.tm_depth < a:
            raise ModelError(
                f"TM depth must be in [0, radius = {a:.4g} m), got {self.tm_depth}",
                "middle_ear.tm_depth",
            )
        if abs(self.tm_bulge) >= 0.25 * a:
            raise ModelError(
                f"TM bulge must be smaller than a quarter of the radius ({0.25 * a:.4g} m)",
                "middle_ear.tm_bulge",
            )
        v_min = self.min_cavity_volume
        if self.cavity_volume <= v_min:
            raise ModelError(
                f"cavity volume {self.cavity_volume:.6g} m³ too small to hold the TM cone "
                f"(needs > {v_min:.6g} m³: the cavity length must exceed 1.05 × the TM height "
                f"{self.tm_height:.4g} m)",
                "middle_ear.cavity_volume",
            )
        if self.probe_distance >= self.canal_length:
            raise ModelError("probe must lie inside the canal", "middle_ear.probe_distance")

    @property
    def tm_radius(self) -> float:
        """Rim radius ``a = sqrt(area / π)``."""
        return math.sqrt(self.tm_area / math.pi)

    @property
    def tm_height(self) -> float:
        """Highest point ``max z`` of the TM profile ``z = h (1 − ρ) − 4 δ ρ (1 − ρ)``.

        ``h`` (the umbo) unless the generators bulge medially by more than ``h/4``
        (``δ < −h/4``): then the vertex of the parabola, ``h − (h + 4δ)² / (16 δ)``.
        """
        h, d = self.tm_depth, self.tm_bulge
        if d < -0.25 * h:
            return h - (h + 4.0 * d) ** 2 / (16.0 * d)
        return h

    @property
    def _profile_volume(self) -> float:
        """Signed volume between the rim plane ``z = 0`` and the TM: ``π a² (h − 2δ) / 3``."""
        return math.pi * self.tm_radius**2 * (self.tm_depth - 2.0 * self.tm_bulge) / 3.0

    @property
    def cavity_length(self) -> float:
        """Axial length ``L_c`` of the cavity cylinder so that its air volume is ``V_c``:
        ``π a² L_c − π a² (h − 2δ)/3 = V_c``."""
        return (self.cavity_volume + self._profile_volume) / (math.pi * self.tm_radius**2)

    @property
    def min_cavity_volume(self) -> float:
        """Smallest admissible cavity volume: the cavity must reach beyond the TM with a gap,
        ``L_c > 1.05 max z``, i.e. ``V_c > π a² (1.05 max z − (h − 2δ)/3)`` (for the default
        shape ``max z = h``: ``π a² (1.05 h − (h − 2δ)/3)`` ≈ 1.06·10⁻⁷ m³)."""
        a = self.tm_radius
        return math.pi * a**2 * 1.05 * self.tm_height - self._profile_volume



def _number(value: object) -> float | None:
    """A finite float from a YAML value, or ``None``. YAML 1.1 reads ``410e-6`` (no dot) as
    a string; such a string is taken as the number it spells (``float``, never evaluated)."""
    if isinstance(value, bool):
        return None
    if isinstance(value, str):
        try:
            value = float(value.strip())
        except ValueError:
            return None
    if not isinstance(value, int | float) or not math.isfinite(value):
        return None
    return float(value)


def read_parameters(path: str | os.PathLike) -> dict[str, float]:
    """The middle ear's data that differ from the defaults, from a YAML (or JSON) mapping
    ``name: number`` of :class:`MiddleEarParameters` fields (``neweul middle-ear build
    --parameters``).

    The mapping is validated whole: every name a field, every value a finite number, and
    the set a valid :class:`MiddleEarParameters` (e.g. ``examples/middle_ear/identified.yaml``).

    Raises
    ------
    DataError
        A missing, oversized or unparsable file, a name that is not a field, a value that is
        not a number, or data the model refuses — naming the file and the key.
    """
    where = str(path)
    try:
        size = Path(path).stat().st_size
        if size > MAX_PARAMETER_FILE_BYTES:
            raise DataError(f"{size} bytes: larger than a parameter file can be "
                            f"({MAX_PARAMETER_FILE_BYTES})", where)
        data = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise DataError(f"cannot read: {exc.strerror or exc}", where) from None
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        line = getattr(getattr(exc, "problem_mark", None), "line", None)
        raise DataError(f"not YAML: {str(exc).splitlines()[0]}", where,
                        line=None if line is None else line + 1) from None
    return check_parameters(data, where)


def check_parameters(data: object, where: str, key: str = "") -> dict[str, float]:
    """``data`` as the middle ear's parameters: a mapping of :class:`MiddleEarParameters`
    names to finite numbers that the model accepts (:func:`read_parameters`; the
    ``parameters`` of a build's ``fem/sweep.json``).

    Raises
    ------
    DataError
        Naming ``where`` (the file) and the key (below ``key``, e.g. ``"parameters"``).
    """
    prefix = f"{key}." if key else ""
    if not isinstance(data, dict):
        raise DataError("must be a mapping of parameter names to numbers", where, key or None)
    known = {f.name for f in fields(MiddleEarParameters)}
    out: dict[str, float] = {}
    for name, value in data.items():
        if name not in known:
            raise DataError(f"unknown middle-ear parameter {name!r} (known: "
                            f"{', '.join(sorted(known))})", where, f"{prefix}{name}")
        number = _number(value)
        if number is None:
            raise DataError(f"must be a finite number, got {value!r}", where,
                            f"{prefix}{name}")
        out[name] = number
    try:
        MiddleEarParameters(**out)
    except ModelError as exc:
        raise DataError(exc.message, where,
                        f"{prefix}{exc.key_path}" if exc.key_path else key or None) from None
    return out
