"""Write ``middle_ear_chain.yaml``: the lumped four-mass middle-ear chain of Lobato et al.
("LVATB1", values in ``docs/middle-ear-data.md``, repeated below).

Topology (motion along the piston axis x, medial positive)::

    ground ─ TM ─ malleus ─ incus ─ stapes ─ ground
                     │         │
                  ground     ground

Every spring is a bushing (stiffness ``diag(k, 0, 0)``) between two frames that translate
along x by their coordinate; the ear-canal sound pressure ``p_ec`` (input) times the TM area acts
on the TM mass; the output is the stapes velocity.

Damping. LVATB1 gives *modal* loss factors (0.62, 0.32, 0.32, 0.0032), assigned here to the modes
in ascending frequency. Each is turned into viscous modal damping at its own resonance,
``2 ζ_i ω_i = η_i ω_i``, i.e. the damping matrix ``D = M Φ diag(η_i ω_i) Φᵀ M`` (Φ the
mass-normalized undamped modes at the default parameters). ``D`` enters as generalized forces
``−D ẋ`` with its entries as parameters ``c_<i><j>`` (so a parameter sweep of a stiffness keeps
this ``D``: regenerate the file for consistent modal damping). A hysteretic (structural) loss
factor would be ``η`` times the stiffness at every frequency; the viscous form equals it at each
resonance and is what a time-domain model can use.

Run ``python examples/make_middle_ear_chain.py`` from the repository root.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: LVATB1 (Lobato et al.; docs/middle-ear-data.md), SI units.
MASSES = {"tm": 5.95e-6, "malleus": 34.8e-6, "incus": 33.7e-6, "stapes": 2.12e-6}  # kg
SPRINGS = {  # name: (frame A, frame B, N/m, source wording)
    "tm_annulus": ("ISYS", "tm", 162.0, "TM + annulus"),
    "tm_manubrium": ("tm", "malleus", 36933.0, "TM-manubrium"),
    "malleus_ligaments": ("ISYS", "malleus", 893.0, "malleus ligaments"),
    "incudomalleolar_joint": ("malleus", "incus", 11410.0, "incudomalleolar joint"),
    "incus_ligament": ("ISYS", "incus", 129.0, "incus ligament"),
    "incudostapedial_joint": ("incus", "stapes", 12581.0, "incudostapedial joint"),
    "annular_ligament": ("stapes", "ISYS", 764.0, "annular ligament"),
}
LOSS_FACTORS = (0.62, 0.32, 0.32, 0.0032)  # modal, ascending frequency
TM_AREA = 60.7e-6  # m^2


def matrices() -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Mass and stiffness matrices of the chain (coordinates x_tm, x_malleus, …)."""
    names = list(MASSES)
    idx = {n: i for i, n in enumerate(names)}
    k = np.zeros((4, 4))
    for a, b, value, _ in SPRINGS.values():
        ia, ib = idx.get(a), idx.get(b)
        for i in (ia, ib):
            if i is not None:
                k[i, i] += value
        if ia is not None and ib is not None:
            k[ia, ib] -= value
            k[ib, ia] -= value
    return np.diag(list(MASSES.values())), k, names


def modal_damping() -> tuple[np.ndarray, np.ndarray]:
    """``D = M Φ diag(η ω) Φᵀ M`` and the undamped eigenfrequencies (Hz)."""
    m, k, _ = matrices()
    ms = np.diag(np.diag(m) ** -0.5)
    w2, v = np.linalg.eigh(ms @ k @ ms)
    omega = np.sqrt(w2)
    phi = ms @ v
    d = m @ phi @ np.diag(np.asarray(LOSS_FACTORS) * omega) @ phi.T @ m
    return 0.5 * (d + d.T), omega / (2 * np.pi)


def description() -> str:
    """The YAML text."""
    _, _, names = matrices()
    d, freqs = modal_damping()
    lines = [
        "# Written by examples/make_middle_ear_chain.py — edit that script, not this file.",
        "name: middle_ear_chain",
        "description: >",
        "  Lumped four-mass middle-ear chain (Lobato et al., LVATB1;",
        "  docs/middle-ear-data.md): ground-TM-malleus-incus-stapes-ground with malleus",
        "  and incus ligaments to ground, all springs as bushings along the piston axis x; modal",
        "  loss factors 0.62, 0.32, 0.32, 0.0032 as viscous modal damping at each resonance",
        "  (undamped modes at "
        + ", ".join(f"{f:.0f}" for f in freqs) + " Hz).",
        "  Input: ear-canal sound pressure p_ec (Pa) times the TM area on the TM mass.",
        "  Output: stapes velocity (m/s).",
        "parameters:",
    ]
    for n, m in MASSES.items():
        lines.append(f"  m_{n}: {m!r}   # kg")
    for n, (_, _, k, src) in SPRINGS.items():
        lines.append(f"  k_{n}: {k!r}   # N/m, {src}")
    lines.append(f"  A_tm: {TM_AREA!r}   # m^2, TM area")
    for i in range(4):
        for j in range(i, 4):
            lines.append(f"  c_{i}{j}: {float(d[i, j]):.12g}   # N s/m, modal damping matrix entry")
    lines.append("coordinates:")
    lines += [f"  x_{n}: 0.0   # m" for n in names]
    lines += ["inputs:", "  p_ec: 0   # Pa, ear-canal sound pressure", "frames:"]
    lines += [f"  {n}: {{translation: [x_{n}, 0, 0]}}" for n in names]
    lines.append("bodies:")
    lines += [f"  {n}_mass: {{frame: {n}, mass: m_{n}}}" for n in names]
    lines.append("forces:")
    for n, (a, b, _, _) in SPRINGS.items():
        lines.append(f"  {n}: {{type: bushing, between: [{a}, {b}], stiffness: "
                     f"{{diag: [k_{n}, 0, 0]}}}}")
    lines.append("  sound: {type: force, frame: tm, vector: [A_tm*p_ec, 0, 0], in: ISYS}")
    for i, n in enumerate(names):
        terms = " + ".join(f"c_{min(i, j)}{max(i, j)}*d_x_{m}" for j, m in enumerate(names))
        lines.append(f"  damping_{n}: {{type: generalized, coordinate: x_{n}, value: "
                     f"-({terms})}}")
    lines += [
        "outputs:",
        "  stapes_velocity: d_x_stapes   # m/s",
        "  umbo_velocity: d_x_malleus    # m/s",
        "",
    ]
    return "\n".join(lines)


if __name__ == "__main__":
    out = Path(__file__).with_name("middle_ear_chain.yaml")
    out.write_text(description(), encoding="utf-8")
    print(f"wrote {out}")
