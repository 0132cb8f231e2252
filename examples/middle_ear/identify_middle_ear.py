"""The middle ear identified: its uncertain parameters fitted to a stated calibration set.

Run from the repository root after ``neweul middle-ear build --dir DATA --refine L`` (the build
gives the chain's description and the mesh's manubrium nodes; its FE sweep is not reused)::

    python examples/middle_ear/identify_middle_ear.py --build DATA [--refine 0]
        [--fit all|tympanogram|gyo-goode] [--evaluate NAME=VALUE ...] [--out FIT.json]

**Forward model.** For a parameter set: the FE static states and working-point models over
the pressures needed (:func:`~neweul_py.middle_ear.sweep.pressure_sweep`, refine ``L``), each
coupled directly with the EMBS's 3-D chain (the build's description with the TM body replaced
by free node translations, :func:`~neweul_py.middle_ear.embs.calibration_module`), its
stiffening factor ``φ`` set so that the chain's static stiffness at the umbo is the tangent
of the static characteristic there (docs/equations-middle-ear.md §7), solved in the
loss-factor form ``K + iG`` (the unreduced reference of the EMBS, as
:func:`~neweul_py.middle_ear.validation.reference_frf`). From it:

* the 226 Hz tympanogram at the probe tip, +200 → −400 daPa every 20 daPa, and its
  ``Ytm``, ``TW``, ``TPP``, ``Vea`` (:func:`~neweul_py.middle_ear.clinical.tympanometric_measures`);
* the middle-ear resonance: the lowest frequency where the compensated susceptance
  ``B(Δp = 0) − B(+200 daPa)`` at the probe tip changes sign from + to − (sweep-frequency
  method, Shanks 1984);
* the low-frequency change (mean 100–1000 Hz, dB re Δp = 0) of the umbo (TM node at the umbo),
  malleus and stapes velocity per probe pressure at ±1, ±2, ±3 kPa;
* the stapes velocity per probe pressure at Δp = 0: its peak and where.

**Calibration set** (:data:`CALIBRATION`; docs/middle-ear-measurements.md §2, §7): Margolis &
Heller 1987's 90 % ranges of ``TW`` (51–114 daPa) and ``Ytm`` (0.37–1.66 mmho, log-normal)
as a mean and standard deviation (the range is ±1.645 SD); Gyo & Goode 1987's umbo loss at
+1/+2/+3 kPa (mean ± SD); the middle-ear resonance 1049 ± 261 Hz (Valvik et al. 1994).
Residuals are ``(model − mean)/SD``; ``--fit tympanogram`` and ``--fit gyo-goode`` use
only one data set each, to show what each asks of the model.

**Fit.** Bounded nonlinear least squares (``scipy.optimize.least_squares``, trust region
reflective) in the logarithms of the parameters (:data:`PARAMETERS`, bounds from the
literature range of each), finite-difference Jacobian. Standard errors and correlations from
the Jacobian at the optimum, ``cov = (JᵀJ)⁻¹`` (the residuals are already in units of their
SD); a parameter whose standard error of ``ln θ`` exceeds 1 (a factor e either way) or that
lies in a direction of ``J`` with singular value below 0.1 is reported as undetermined.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.optimize as spo
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from neweul_py.analysis.acoustic import MMHO
from neweul_py.analysis.linearize import linearize
from neweul_py.middle_ear.clinical import tympanometric_measures
from neweul_py.middle_ear.embs import (
    PHI,
    PROBE_MASS,
    calibration_module,
    node_positions,
    umbo_stiffness,
)
from neweul_py.middle_ear.parameters import MiddleEarParameters
from neweul_py.middle_ear.sweep import pressure_sweep


@dataclass(frozen=True)
class Parameter:
    """A fitted parameter: a field of :class:`MiddleEarParameters`, its bounds and why."""

    name: str
    low: float
    high: float
    why: str


#: The uncertain parameters and the literature range that bounds each.
PARAMETERS = (
    Parameter("tm_E_static", 2.0e6, 15.1e6,
              "TM modulus of the static state: 2.1-4.4 MPa in situ at 0.2 Hz (Aernouts et al. "
              "2012) to 15.1 MPa on strips at 1 Hz (Zhang & Gan 2013)"),
    Parameter("chain_limit_medial", 40e-6, 2e-3, "s+ of the chain characteristic (no "
              "direct measurement)"),
    Parameter("chain_limit_lateral", 40e-6, 2e-3, "s- of the chain characteristic (no "
              "direct measurement)"),
    Parameter("k_chain", 800.0, 3000.0, "chain stiffness at the umbo k0: LVATB1 1683 N/m, "
              "the joints and ligaments of Hudde & Engel 1998 give other values"),
    Parameter("tm_E", 20e6, 30e6, "TM storage modulus: 22.5 MPa at 226 Hz to 27.6 MPa at "
              "3.8 kHz (Zhang & Gan 2013, power law)"),
    Parameter("tm_thickness", 40e-6, 120e-6, "TM thickness: thin central region 40, 50 and "
              "120 um in three ears (Kuypers et al. 2006)"),
    Parameter("mastoid_volume", 1.0e-6, 8.0e-6, "antrum + mastoid air: total middle-ear air "
              "2-6 cm3 (Molvaer 1978), mastoid 0.7-21 cm3 (Swarts 2011)"),
)

#: name → (mean, SD, source); ``ytm`` in ln(mmho).
CALIBRATION = {
    "tw": (82.5, 19.1, "Margolis & Heller 1987: TW 51-114 daPa (90 % range)"),
    "ytm": (float(np.log(np.sqrt(0.37 * 1.66))), float(np.log(1.66 / 0.37) / (2 * 1.645)),
            "Margolis & Heller 1987: Ytm 0.37-1.66 mmho (90 % range, log-normal)"),
    "gg1": (-5.0, 1.0, "Gyo & Goode 1987: umbo at +1 kPa (-100 mmH2O)"),
    "gg2": (-9.2, 1.3, "Gyo & Goode 1987: umbo at +2 kPa"),
    "gg3": (-13.1, 1.8, "Gyo & Goode 1987: umbo at +3 kPa"),
    "fres": (1049.0, 261.0, "Valvik et al. 1994: middle-ear resonance, 100 ears"),
}
#: Murakami et al. 1997 (qualitative): either sign of Δp loses at low frequencies, negative
#: middle-ear pressure (Δp > 0) more. One-sided residuals in units of this [dB]: the loss at
#: −k kPa below 0 (a gain), and the loss at −k kPa above that at +k kPa.
MURAKAMI_DB = 1.0
SETS = {"all": (*CALIBRATION, "murakami"), "tympanogram": ("tw", "ytm", "fres", "murakami"),
        "gyo-goode": ("gg1", "gg2", "gg3", "murakami")}

TYMP_DAPA = np.arange(200.0, -401.0, -20.0)
GG_PA = (-3000.0, -2000.0, -1000.0, 1000.0, 2000.0, 3000.0)
F_LOW = np.geomspace(100.0, 1000.0, 8)
F_RES = np.geomspace(300.0, 3000.0, 36)
F_STAPES = np.geomspace(300.0, 4000.0, 40)
OUTPUTS = ("probe_pressure", "entrance_pressure", "umbo_uz", "tm_volume_displacement")


class Chain:
    """The build's 3-D chain with ``φ`` as a parameter; ``φ(k_t)`` tabulated once."""

    def __init__(self, build: Path, work: Path) -> None:
        text = (build / "middle_ear.yaml").read_text(encoding="utf-8")
        self.mod = calibration_module(text, node_positions(build / "fem"), work)
        self.names = list(self.mod.PARAMETERS)
        self.p0 = np.array(self.mod.default_parameters(), dtype=float)
        i = self.names.index(PHI)
        phis = np.geomspace(0.05, 200.0, 60)
        ks = []
        for phi in phis:
            p = self.p0.copy()
            p[i] = phi
            ks.append(umbo_stiffness(self.mod, p)["k"])
        self.k_table, self.phi_table = np.log(ks), np.log(phis)

    def matrices(self, k_t: float) -> tuple[dict[str, np.ndarray], list[str], list[str]]:
        """``M``, ``D``, ``K + iG`` of the chain at the tangent ``k_t`` (coordinates: own,
        then node translations), and the two name lists."""
        p = self.p0.copy()
        p[self.names.index(PHI)] = float(np.exp(np.interp(np.log(k_t), self.k_table,
                                                          self.phi_table)))
        lin = linearize(self.mod, p=p)
        names = list(lin.coordinates)
        node = [n for n in names if n.startswith("n") and n[1:].split("_")[0].isdigit()]
        own = [n for n in names if n not in node]
        order = [names.index(n) for n in (*own, *node)]
        P, Q = lin.P, lin.Q
        if lin.has_loss:
            P = P - lin.G / (2 * np.pi * lin.loss_reference_frequency)
            Q = Q + 1j * lin.G
        ch = {k: a[np.ix_(order, order)] for k, a in (("M", lin.M0), ("D", P), ("K", Q))}
        k = np.arange(len(own), len(names))
        ch["M"][k, k] -= PROBE_MASS
        return ch, own, node


def coupled(fe, G, f_ref, chain, k_t, freqs) -> dict[str, np.ndarray]:
    """FE + chain in the loss-factor form: the FE outputs :data:`OUTPUTS` and the malleus
    (``m_z``) and stapes (``s_z``) velocities per unit canal volume acceleration."""
    ch, own, node = chain.matrices(k_t)
    n = fe.n_dofs
    dofs = np.array([fe.inputs[f"manubrium.{nm[1:].split('_')[0]}.u{nm[-1]}"][0][0]
                     for nm in node])
    m = ch["K"].shape[0]
    nc = m - dofs.size
    E = sps.csr_matrix((np.ones(m), (np.r_[n + np.arange(nc), dofs], np.arange(m))),
                       shape=(n + nc, m))

    def total(a, key):
        return (sps.block_diag([a, sps.csr_matrix((nc, nc))], format="csr")
                + E @ sps.csr_matrix(ch[key]) @ E.T).tocsc()

    K = total(fe.K + 1j * G, "K")
    D = total(fe.D - G / (2 * np.pi * f_ref), "D")
    M = total(fe.M, "M")
    b = np.zeros(n + nc, dtype=complex)
    b[:n] = fe.B("canal_volume_acceleration")[:, 0]
    rows = np.zeros((len(OUTPUTS), n + nc))
    for r, name in enumerate(OUTPUTS):
        for i, w in fe.outputs[name]:
            rows[r, i] += w
    w = 2 * np.pi * np.asarray(freqs, dtype=float)
    x = np.array([spla.spsolve(K + 1j * wk * D - wk * wk * M, b) for wk in w])
    out = {name: x @ rows[r] for r, name in enumerate(OUTPUTS)}
    out["m_z"] = 1j * w * x[:, n + own.index("m_z")]
    out["s_z"] = 1j * w * x[:, n + own.index("s_z")]
    return out


def forward(params: MiddleEarParameters, chain: Chain, refine: int) -> dict:
    """The model's measures (module docstring) for ``params``."""
    t0 = time.perf_counter()
    dps = sorted({*(10.0 * TYMP_DAPA), *GG_PA, 0.0})
    res = pressure_sweep(dps, params, refine=refine)
    bands = {"226": np.array([226.0]), "low": F_LOW, "res": F_RES, "stapes": F_STAPES}
    h = {}
    for dp, fe, G, grp in zip(dps, res.models, res.damping, res.static_groups, strict=True):
        need = ["226"] + (["low"] if dp in GG_PA or dp == 0.0 else []) + (
            ["res"] if dp in (0.0, 2000.0) else []) + (["stapes"] if dp == 0.0 else [])
        freqs = np.concatenate([bands[b] for b in need])
        out = coupled(fe, G, params.f_ref, chain, float(grp["chain_tangent"][2, 2]), freqs)
        edges = np.cumsum([0] + [bands[b].size for b in need])
        h[dp] = {b: {k: v[edges[i]:edges[i + 1]] for k, v in out.items()}
                 for i, b in enumerate(need)}

    def pick(dp, band, key):
        f, out = bands[band], h[dp][band]
        if key == "y_probe":
            return 1 / (1j * 2 * np.pi * f * out["entrance_pressure"])
        if key == "umbo":
            v = 1j * 2 * np.pi * f * out["umbo_uz"]
        else:
            v = out[{"malleus": "m_z", "stapes": "s_z"}[key]]
        return v / out["probe_pressure"]

    y = np.array([pick(10.0 * p, "226", "y_probe")[0] for p in TYMP_DAPA])
    ytm = np.array([2j * np.pi * 226 * h[10.0 * p]["226"]["tm_volume_displacement"][0]
                    / h[10.0 * p]["226"]["probe_pressure"][0] for p in TYMP_DAPA])
    m = tympanometric_measures(TYMP_DAPA, y, 226.0, params.rho_air, params.c_air)
    loss = {}
    for key in ("umbo", "malleus", "stapes"):
        ref = pick(0.0, "low", key)
        loss[key] = {dp: float(np.mean(20 * np.log10(np.abs(pick(dp, "low", key) / ref))))
                     for dp in GG_PA}
    db = (pick(0.0, "res", "y_probe") - pick(2000.0, "res", "y_probe")).imag
    cross = np.flatnonzero((db[:-1] > 0) & (db[1:] <= 0))
    fres = (float(F_RES[cross[0]] - db[cross[0]] * (F_RES[cross[0] + 1] - F_RES[cross[0]])
                  / (db[cross[0] + 1] - db[cross[0]])) if cross.size else float("nan"))
    st = np.abs(pick(0.0, "stapes", "stapes"))
    k = int(np.argmax(st))
    return {"tw": m.width_daPa, "ytm_mmho": m.peak_admittance_mmho, "tpp": m.peak_pressure_daPa,
            "vea": m.ear_canal_volume_cm3, "fres": fres, "loss": loss,
            "ytm_tm0_mmho": float(np.abs(ytm[TYMP_DAPA == 0.0][0]) / MMHO),
            "ytm_tm_ratio_200": float(np.abs(ytm[0] / ytm[TYMP_DAPA == 0.0][0])),
            "stapes_peak_hz": float(F_STAPES[k]), "stapes_peak_mm_s_Pa": 1e3 * float(st[k]),
            "stapes_1k_mm_s_Pa": 1e3 * float(np.interp(1000.0, F_STAPES, st)),
            "tympanogram_mmho": (np.abs(y) / MMHO).tolist(),
            "seconds": round(time.perf_counter() - t0, 1)}


def model_values(r: dict) -> dict[str, float]:
    """The calibrated quantities of a forward result, in the units of :data:`CALIBRATION`."""
    tw = r["tw"] if np.isfinite(r["tw"]) else 400.0   # not reached: as wide as the sweep
    return {"tw": tw, "ytm": float(np.log(max(r["ytm_mmho"], 1e-3))),
            "gg1": r["loss"]["umbo"][1000.0], "gg2": r["loss"]["umbo"][2000.0],
            "gg3": r["loss"]["umbo"][3000.0],
            "fres": r["fres"] if np.isfinite(r["fres"]) else 3000.0}


def residuals(r: dict, keys) -> np.ndarray:
    """``(model − mean)/SD`` per calibration key; ``"murakami"`` adds the six one-sided
    residuals of :data:`MURAKAMI_DB` (zero when the model does as measured)."""
    v = model_values(r)
    out = [(v[k] - CALIBRATION[k][0]) / CALIBRATION[k][1] for k in keys if k != "murakami"]
    if "murakami" in keys:
        umbo = r["loss"]["umbo"]
        for k in (1000.0, 2000.0, 3000.0):
            gain_neg, gain_pos = umbo[-k], umbo[k]          # dB re Δp = 0 (a loss < 0)
            out.append(max(0.0, gain_neg) / MURAKAMI_DB)
            out.append(max(0.0, gain_pos - gain_neg) / MURAKAMI_DB)
    return np.array(out)


def summary(r: dict) -> str:
    lo = r["loss"]
    return (f"TW {r['tw']:.0f} daPa, Ytm {r['ytm_mmho']:.3f} mmho, TPP {r['tpp']:+.0f} daPa, "
            f"Vea {r['vea']:.2f} cm3, |Y_TM(0)| {r['ytm_tm0_mmho']:.3f} mmho "
            f"(+200 daPa: {r['ytm_tm_ratio_200']:.2f} of it), f_res {r['fres']:.0f} Hz; "
            "umbo/malleus/stapes dB "
            + "; ".join(f"{dp / 1e3:+.0f} kPa {lo['umbo'][dp]:+.1f}/{lo['malleus'][dp]:+.1f}/"
                        f"{lo['stapes'][dp]:+.1f}" for dp in GG_PA)
            + f"; stapes peak {r['stapes_peak_mm_s_Pa']:.3f} mm/s/Pa at "
              f"{r['stapes_peak_hz']:.0f} Hz ({r['seconds']:.0f} s)")


def fit(base: MiddleEarParameters, chain: Chain, refine: int, keys, names, max_nfev: int,
        log=print) -> dict:
    """Least squares over ``names`` (log parameters) against the calibration ``keys``."""
    par = {p.name: p for p in PARAMETERS}
    ref = np.log([getattr(base, n) for n in names])     # x = ln(θ/θ_start): steps in ln θ
    lo = np.log([par[n].low for n in names]) - ref
    hi = np.log([par[n].high for n in names]) - ref
    x0 = np.clip(np.zeros(len(names)), lo + 1e-9, hi - 1e-9)
    cache: dict[tuple, dict] = {}

    def run(x):
        key = tuple(np.round(x, 12))
        if key not in cache:
            p = dataclasses.replace(base, **dict(zip(names, np.exp(x + ref).tolist(),
                                                     strict=True)))
            cache[key] = forward(p, chain, refine)
            log("  " + ", ".join(f"{n}={v:.4g}" for n, v in zip(names, np.exp(x + ref),
                                                                  strict=True))
                + f" → {np.round(residuals(cache[key], keys), 2).tolist()}")
        return cache[key]

    sol = spo.least_squares(lambda x: residuals(run(x), keys), x0, bounds=(lo, hi),
                            diff_step=0.03, method="trf", x_scale=1.0, max_nfev=max_nfev)
    J = sol.jac
    u, s, vt = np.linalg.svd(J, full_matrices=False)
    cov = np.linalg.pinv(J.T @ J)
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    d = np.where(se > 0, se, 1.0)
    corr = cov / np.outer(d, d)
    weak = [names[int(np.argmax(np.abs(v)))] for sv, v in zip(s, vt, strict=True) if sv < 0.1]
    return {"names": list(names), "keys": list(keys), "x": (sol.x + ref).tolist(),
            "values": np.exp(sol.x + ref).tolist(), "se_log": se.tolist(), "corr": corr.tolist(),
            "singular_values": s.tolist(), "weak_directions": vt[s < 0.1].tolist(),
            "undetermined": sorted({*weak, *(n for n, e in zip(names, se, strict=True)
                                             if e > 1.0)}),
            "at_bound": [n for n, x, a, b in zip(names, sol.x, lo, hi, strict=True)
                         if min(x - a, b - x) < 1e-3],
            "cost": float(2 * sol.cost), "nfev": int(sol.nfev), "status": int(sol.status),
            "message": sol.message, "residuals": sol.fun.tolist(),
            "result": run(sol.x)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", type=Path, required=True, help="a middle-ear build (its chain)")
    ap.add_argument("--refine", type=int, default=0)
    ap.add_argument("--fit", choices=(*SETS, "none"), default="all")
    ap.add_argument("--params", default=",".join(p.name for p in PARAMETERS),
                    help="the parameters to fit (comma list)")
    ap.add_argument("--evaluate", nargs="*", default=[], metavar="NAME=VALUE",
                    help="start (or, with --fit none, evaluate) at these values")
    ap.add_argument("--max-nfev", type=int, default=60)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    base = MiddleEarParameters(**{k: float(v) for k, v in
                                  (a.split("=") for a in args.evaluate)})
    chain = Chain(args.build, args.build / "identify_chain")
    if args.fit == "none":
        r = forward(base, chain, args.refine)
        print(summary(r))
        print("residuals (SD):", dict(zip(CALIBRATION, np.round(residuals(
            r, tuple(CALIBRATION)), 2).tolist(), strict=True)))
        out = {"parameters": dataclasses.asdict(base), "result": r}
    else:
        names = args.params.split(",")
        out = fit(base, chain, args.refine, SETS[args.fit], names, args.max_nfev)
        print(summary(out["result"]))
        print(json.dumps({k: out[k] for k in ("names", "values", "se_log", "undetermined",
                                              "at_bound", "cost", "residuals",
                                              "singular_values")}, indent=1))
    if args.out:
        args.out.write_text(json.dumps(out, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
