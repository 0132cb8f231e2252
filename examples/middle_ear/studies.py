"""Studies of the middle-ear EMBS, as the seed paper does (issue 13 item 6).

Run from the repository root after ``build_embs.py`` (README.md, "Studies")::

    python examples/middle_ear/studies.py --dir DATA [--out OUT] [--no-time] [--nf 60]

``DATA`` (the sweep and body of ``build_embs.py``) is only read: the description retargeted to
it (:func:`chain_factor.retarget`: manubrium nodes, per-node attachment, ``φ(Δp)``) and the
generated module are written under ``OUT`` (default ``DATA/studies``).

1. **static** umbo and stapes displacement vs Δp (the FE static state of the sweep: TM held by
   the stiffening chain; the stapes from the 3-D chain's static stapes/umbo ratio at each
   working point, integrated along the load path);
2. **FRFs** umbo velocity (TM node 1), malleus (at the umbo) and stapes velocity per probe
   pressure, 100 Hz–8 kHz, at the 9 pressures −4000…4000 Pa, magnitude and phase, from the
   generated EMBS linearized at each Δp, loss factors as ``K + iG``; the low-frequency change
   (mean 100–1000 Hz, dB re Δp = 0) against Gyo & Goode 1987
   (``docs/middle-ear-measurements.md``);
3. the **time simulation** (a tone under a Δp ramp) is ``time_study.py``.

Writes ``results.md`` (the tables), ``frf.png``, ``dp_trend.png``, ``static.png`` and
``frf.csv`` into ``--out``.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

from neweul_py.analysis import load_generated
from neweul_py.api import generate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from chain_factor import (
    PHI,
    calibration_module,
    factor_table,
    retarget,
    sweep_tangents,
    umbo_stiffness,
)
from validate_embs import DESCRIPTION, HERE, embs_frf, parameters_at, require_build, transfer

PRESSURES = np.arange(-4000.0, 4001.0, 1000.0)
GYO_GOODE = {1000.0: (-5.0, 1.0), 2000.0: (-9.2, 1.3), 3000.0: (-13.1, 1.8)}  # dB, mean ± sd



def static_table(data: Path, gen: Path, text: str) -> list[dict[str, float]]:
    """Static umbo, malleus and stapes displacement per Δp (the sweep's ``static.csv``).

    The stapes: the 3-D chain of the description (TM removed), stiffened by ``φ(Δp)``,
    transmits ``dx_s/dx_m`` of a static malleus increment at the umbo
    (:func:`chain_factor.umbo_stiffness`); integrated (trapezoid) from Δp = 0 along each sign
    of the load path."""
    with open(data / "fem" / "static.csv", newline="") as fh:
        rows = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(fh)]
    rows.sort(key=lambda r: r["dp_Pa"])
    mod = calibration_module(text, data, gen)
    phi = factor_table(mod, sweep_tangents(data))

    def ratio(dp: float) -> float:
        p = parameters_at(mod, dp)
        p[list(mod.PARAMETERS).index(PHI)] = phi[dp]
        return umbo_stiffness(mod, p)["stapes_ratio"]

    i0 = next(i for i, r in enumerate(rows) if r["dp_Pa"] == 0.0)
    stapes = np.zeros(len(rows))
    for rng in (range(i0 + 1, len(rows)), range(i0 - 1, -1, -1)):
        prev = i0
        for i in rng:
            a, b = rows[prev], rows[i]
            r = 0.5 * (ratio(a["dp_Pa"]) + ratio(b["dp_Pa"]))
            stapes[i] = stapes[prev] + r * (b["malleus_qz_m"] - a["malleus_qz_m"])
            prev = i
    return [{"dp": r["dp_Pa"], "umbo_um": 1e6 * r["umbo_uz_m"],
             "malleus_um": 1e6 * r["malleus_qz_m"], "stapes_um": 1e6 * s,
             "volume_mm3": 1e9 * r["volume_displacement_m3"],
             "tangent": r["chain_tangent_z_N_per_m"], "phi": phi[r["dp_Pa"]]}
            for r, s in zip(rows, stapes, strict=True)]


def frf_study(mod, f: np.ndarray, damping: str = "loss") -> dict[float, dict[str, np.ndarray]]:
    """Umbo (TM node 1), malleus (at the umbo) and stapes velocity per probe pressure at every
    sample pressure; loss factors as ``K + iG`` (``damping="viscous"``: the time-domain
    equivalent ``G/ω_ref``)."""
    out = {}
    for dp in PRESSURES:
        h = embs_frf(mod, dp, f, damping)
        out[dp] = transfer(h, f) | {"malleus": h["umbo_velocity_z"] / h["p_probe"]}
    return out


def embs_module(data: Path, out: Path):
    """The EMBS of ``middle_ear.yaml`` retargeted to the sweep and body in ``data``
    (:func:`chain_factor.retarget`: its manubrium nodes and factor table); everything is
    written under ``out`` (``data`` is only read)."""
    gen = out / "generated"
    text = retarget(DESCRIPTION.read_text(), data, gen)
    path = out / "middle_ear.yaml"
    path.write_text(text)
    return load_generated(generate(path, gen)), text


def low_db(h: np.ndarray, h0: np.ndarray, f: np.ndarray) -> float:
    """Mean over 100–1000 Hz of ``20 log10 |h/h0|``."""
    band = (f >= 100.0) & (f <= 1000.0)
    return float(np.mean(20 * np.log10(np.abs(h[band]) / np.abs(h0[band]))))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", type=Path, default=HERE / "data",
                    help="the build of build_embs.py (read only; default examples/middle_ear/data)")
    ap.add_argument("--out", type=Path, default=None,
                    help="tables, CSV, plots and generated modules (default DIR/studies)")
    ap.add_argument("--nf", type=int, default=80,
                    help="log-spaced frequencies 100 Hz–8 kHz (default 80)")
    ap.add_argument("--no-time", action="store_true",
                    help="accepted and ignored (the time study is time_study.py)")
    args = ap.parse_args()
    require_build(args.dir, float(PRESSURES.min()), float(PRESSURES.max()))
    out = args.out or args.dir / "studies"
    out.mkdir(parents=True, exist_ok=True)
    lines = ["# Middle-ear EMBS studies (examples/middle_ear/studies.py)", ""]
    mod, text = embs_module(args.dir, out)
    st = static_table(args.dir, out / "generated", text)
    lines += ["## Static state vs Δp (Δp > 0: negative middle-ear pressure; + = medial)", "",
              "| Δp [Pa] | umbo u_z [µm] | malleus [µm] | stapes [µm] | TM volume [mm³] |"
              " chain tangent [N/m] | φ |", "|---|---|---|---|---|---|---|"]
    lines += [f"| {r['dp']:+.0f} | {r['umbo_um']:+.1f} | {r['malleus_um']:+.1f} | "
              f"{r['stapes_um']:+.2f} | {r['volume_mm3']:+.2f} | {r['tangent']:.0f} | "
              f"{r['phi']:.3f} |" for r in st]
    f = np.geomspace(100.0, 8000.0, args.nf)
    H = frf_study(mod, f)
    h0 = H[0.0]
    lines += ["", "## Low-frequency change (mean 100–1000 Hz, re Δp = 0) and values at 1 kHz",
              "", "| Δp [Pa] | umbo [dB] | malleus [dB] | stapes [dB] |"
              " Gyo & Goode 1987 umbo [dB] | umbo 1 kHz [mm/s/Pa] | stapes 1 kHz [mm/s/Pa] |"
              " stapes peak [mm/s/Pa] at [Hz] |",
              "|---|---|---|---|---|---|---|---|"]
    at_1k = frf_study(mod, np.array([1000.0]))  # exactly 1 kHz, whatever the grid
    for dp, h in H.items():
        gg = GYO_GOODE.get(dp)
        ref = f"{gg[0]:+.1f} ± {gg[1]:.1f}" if gg else ""
        ks = int(np.argmax(np.abs(h["stapes"])))
        lines.append(f"| {dp:+.0f} | {low_db(h['umbo'], h0['umbo'], f):+.2f} | "
                     f"{low_db(h['malleus'], h0['malleus'], f):+.2f} | "
                     f"{low_db(h['stapes'], h0['stapes'], f):+.2f} | {ref} | "
                     f"{1e3 * abs(at_1k[dp]['umbo'][0]):.3f} | "
                     f"{1e3 * abs(at_1k[dp]['stapes'][0]):.3f} | "
                     f"{1e3 * abs(h['stapes'][ks]):.3f} at {f[ks]:.0f} |")
    with open(out / "frf.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["dp_Pa", "frequency_Hz", "umbo_re", "umbo_im", "stapes_re", "stapes_im"])
        for dp, h in H.items():
            for i, fi in enumerate(f):
                w.writerow([dp, fi, h["umbo"][i].real, h["umbo"][i].imag,
                            h["stapes"][i].real, h["stapes"][i].imag])
    (out / "results.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    _plots(out, f, H, st)


def _plots(out: Path, f, H, st) -> None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:  # pragma: no cover - matplotlib is in the test extra
        print("matplotlib missing: no plots", file=sys.stderr)
        return
    fig, ax = plt.subplots(2, 2, figsize=(10, 6), sharex=True)
    cmap = plt.get_cmap("coolwarm")
    for dp, h in H.items():
        c = cmap((dp + 4000) / 8000)
        for j, key in enumerate(("umbo", "stapes")):
            ax[0, j].loglog(f, 1e3 * np.abs(h[key]), color=c, label=f"{dp:+.0f} Pa")
            ax[1, j].semilogx(f, np.degrees(np.unwrap(np.angle(h[key]))), color=c)
    for j, key in enumerate(("umbo", "stapes")):
        ax[0, j].set_title(f"{key} velocity / probe pressure")
        ax[0, j].set_ylabel("mm/s/Pa")
        ax[1, j].set_ylabel("phase [deg]")
        ax[1, j].set_xlabel("frequency [Hz]")
        for a in ax[:, j]:
            a.grid(True, which="both", lw=0.3)
    ax[0, 0].legend(fontsize=6, ncol=2)
    fig.tight_layout()
    fig.savefig(out / "frf.png", dpi=120)
    fig, ax = plt.subplots(figsize=(5, 3.5))
    dps = np.array(list(H))
    for key in ("umbo", "malleus", "stapes"):
        ax.plot(dps, [low_db(H[d][key], H[0.0][key], f) for d in dps], "o-", label=key)
    gg = np.array([(d, m, s) for d, (m, s) in GYO_GOODE.items()])
    ax.errorbar(gg[:, 0], gg[:, 1], yerr=gg[:, 2], fmt="ks", label="Gyo & Goode 1987 umbo")
    ax.set_xlabel("Δp = p_canal − p_cavity [Pa]")
    ax.set_ylabel("change 100–1000 Hz [dB]")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "dp_trend.png", dpi=120)
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.plot([r["dp"] for r in st], [r["umbo_um"] for r in st], "o-", label="umbo")
    ax.plot([r["dp"] for r in st], [r["stapes_um"] for r in st], "s-", label="stapes")
    ax.set_xlabel("Δp [Pa]")
    ax.set_ylabel("static displacement (medial +) [µm]")
    ax.grid(True, lw=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "static.png", dpi=120)
    print(f"plots in {out}")


if __name__ == "__main__":
    main()
