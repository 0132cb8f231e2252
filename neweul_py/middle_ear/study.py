"""``neweul middle-ear study``: the static and dynamic behaviour of a build versus Δp.

As the seed paper reviews its EMBS (docs/equations-middle-ear.md):

1. **static** umbo, malleus and stapes displacement versus Δp: the FE static state of the
   sweep (the TM held by the stiffening chain); the stapes from the 3-D chain's static
   stapes/umbo ratio at each working point (:func:`~neweul_py.middle_ear.embs.umbo_stiffness`),
   integrated along the load path from Δp = 0;
2. **transfer functions**: umbo velocity (TM node 1), malleus (at the umbo) and stapes
   velocity per probe pressure, 100 Hz–8 kHz, at the sampled pressures −4000…4000 Pa, from
   the generated EMBS linearized at each Δp with the loss factors as ``K + iG``
   (docs/equations.md §1.1); the low-frequency change (mean 100–1000 Hz, re Δp = 0) against
   Gyo & Goode 1987 (docs/middle-ear-measurements.md).

Writes ``results.md`` (the tables), ``frf.csv`` and the plots ``frf.png``, ``dp_trend.png``
and ``static.png`` (matplotlib, the ``plot`` extra).
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..analysis import load_generated
from ..analysis.linearize import linearize
from ..api import generate
from ..atomic import atomic_write
from ..errors import DataError
from ..files import read_text
from .embs import (
    PHI,
    calibration_module,
    factor_table,
    node_positions,
    parameters_at,
    sweep_tangents,
    umbo_stiffness,
)
from .parameters import MiddleEarParameters, check_parameters

__all__ = ["GYO_GOODE", "MAX_RECORD_BYTES", "PRESSURES", "build_parameters", "build_record",
           "embs_frf", "low_db", "read_record", "static_table", "study", "transfer"]

#: Largest build record read [bytes] (``build.json``, ``fem/sweep.json``: a few hundred kB).
MAX_RECORD_BYTES = 64 << 20

#: The pressures of the study [Pa].
PRESSURES = np.arange(-4000.0, 4001.0, 1000.0)
#: Gyo & Goode 1987: umbo change 100–1000 Hz [dB] (mean, SD) at Δp [Pa].
GYO_GOODE = {1000.0: (-5.0, 1.0), 2000.0: (-9.2, 1.3), 3000.0: (-13.1, 1.8)}

Progress = Callable[..., None]


def build_record(directory: str | Path, *dps: float) -> dict[str, Any]:
    """The record (``build.json``) of a complete build in ``directory``.

    Raises
    ------
    DataError
        ``directory`` holds no complete build, or its samples do not cover every Δp in
        ``dps`` (the body does not extrapolate).
    """
    record = Path(directory) / "build.json"
    if not record.is_file():
        raise DataError("no middle-ear build here (run neweul middle-ear build first)",
                        str(directory), "build.json")
    info = read_record(record)
    samples = info.get("samples_Pa")
    if (not isinstance(samples, list) or not samples
            or not all(isinstance(v, int | float) and not isinstance(v, bool)
                       and math.isfinite(v) for v in samples)):
        raise DataError("must be a list of the sampled Δp [Pa]", str(record), "samples_Pa")
    if not isinstance(info.get("module", ""), str | None):
        raise DataError("must be the generated module's path", str(record), "module")
    lo, hi = min(samples), max(samples)
    bad = [dp for dp in dps if not lo <= dp <= hi]
    if bad:
        raise DataError(f"the build covers Δp in [{lo:g}, {hi:g}] Pa, not {bad[0]:g} Pa (no "
                        "extrapolation)", str(record), "samples_Pa")
    return info


def read_record(path: Path) -> dict[str, Any]:
    """A build's JSON record (``build.json``, ``fem/sweep.json``) as a mapping.

    Raises
    ------
    DataError
        A missing, oversized or unreadable file, or one that is not a JSON object.
    """
    text = read_text(path, "build record", MAX_RECORD_BYTES)
    try:
        data = json.loads(text)
    except ValueError as exc:
        raise DataError(f"not a build record (JSON): {exc}", str(path)) from None
    if not isinstance(data, dict):
        raise DataError("not a build record: a JSON object was expected", str(path))
    return data


def build_parameters(directory: str | Path) -> MiddleEarParameters:
    """The physical data of a build: the ``parameters`` of its ``fem/sweep.json``.

    Raises
    ------
    DataError
        As :func:`read_record`, or parameters the model refuses (naming the key).
    """
    path = Path(directory) / "fem" / "sweep.json"
    if not path.is_file():
        raise DataError("no FE sweep record: not a complete build", str(path))
    data = read_record(path)
    return MiddleEarParameters(**check_parameters(data.get("parameters"), str(path),
                                                  "parameters"))


def embs_frf(mod: Any, dp: float, f: np.ndarray, damping: str = "loss"
             ) -> dict[str, np.ndarray]:
    """``p_probe``, ``umbo_uz``, ``stapes_velocity``, ``umbo_velocity_z`` per unit canal
    volume acceleration ``Q`` of the EMBS linearized at ``dp`` (``damping``: ``"loss"``, the
    loss factors as ``K + iG``, or ``"viscous"``, docs/equations.md §1.1)."""
    lin = linearize(mod, p=parameters_at(mod, dp))
    j = list(lin.inputs).index("Q")
    m = lin.M0.shape[0]
    z = lin.dynamic_stiffness(2 * np.pi * np.asarray(f, dtype=float), damping)
    xs = np.linalg.solve(z, np.broadcast_to(lin.B[:, j], (len(f), m))[..., None])[..., 0]
    w = 2 * np.pi * np.asarray(f, dtype=float)
    out = {}
    for name in ("p_probe", "umbo_uz", "stapes_velocity", "umbo_velocity_z"):
        c = lin.C[list(lin.outputs).index(name)]
        out[name] = xs @ c[:m] + (1j * w * xs.T).T @ c[m:]
    return out


def transfer(h: Mapping[str, np.ndarray], f: np.ndarray) -> dict[str, np.ndarray]:
    """Umbo (TM node 1), malleus (at the umbo) and stapes velocity per probe pressure
    [m/s/Pa] from :func:`embs_frf`."""
    w = 2 * np.pi * np.asarray(f, dtype=float)
    return {"umbo": 1j * w * h["umbo_uz"] / h["p_probe"],
            "malleus": h["umbo_velocity_z"] / h["p_probe"],
            "stapes": h["stapes_velocity"] / h["p_probe"]}


def low_db(h: np.ndarray, h0: np.ndarray, f: np.ndarray) -> float:
    """Mean over 100–1000 Hz of ``20 log10 |h/h0|``."""
    band = (f >= 100.0) & (f <= 1000.0)
    return float(np.mean(20 * np.log10(np.abs(h[band]) / np.abs(h0[band]))))


def static_table(fem: Path, text: str, gen: Path) -> list[dict[str, float]]:
    """Static umbo, malleus and stapes displacement per Δp (the sweep's ``static.csv``); the
    stapes integrated (trapezoid) from Δp = 0 along each sign of the load path with the
    chain's static stapes/umbo ratio at ``φ(Δp)`` (module docstring)."""
    with open(fem / "static.csv", newline="", encoding="utf-8") as fh:
        rows = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(fh)]
    rows.sort(key=lambda r: r["dp_Pa"])
    mod = calibration_module(text, node_positions(fem), gen)
    phi = factor_table(mod, sweep_tangents(fem))
    i_phi = list(mod.PARAMETERS).index(PHI)

    def ratio(dp: float) -> float:
        p = parameters_at(mod, dp)
        p[i_phi] = phi[dp]
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


def _tables(st: list[dict[str, float]], H: Mapping[float, Mapping[str, np.ndarray]],
            at_1k: Mapping[float, Mapping[str, np.ndarray]], f: np.ndarray) -> list[str]:
    lines = ["# Middle-ear EMBS study", "",
             "## Static state vs Δp (Δp > 0: negative middle-ear pressure; + = medial)", "",
             "| Δp [Pa] | umbo u_z [µm] | malleus [µm] | stapes [µm] | TM volume [mm³] |"
             " chain tangent [N/m] | φ |", "|---|---|---|---|---|---|---|"]
    lines += [f"| {r['dp']:+.0f} | {r['umbo_um']:+.1f} | {r['malleus_um']:+.1f} | "
              f"{r['stapes_um']:+.2f} | {r['volume_mm3']:+.2f} | {r['tangent']:.0f} | "
              f"{r['phi']:.3f} |" for r in st]
    h0 = H[0.0]
    lines += ["", "## Low-frequency change (mean 100–1000 Hz, re Δp = 0) and values at 1 kHz",
              "", "| Δp [Pa] | umbo [dB] | malleus [dB] | stapes [dB] |"
              " Gyo & Goode 1987 umbo [dB] | umbo 1 kHz [mm/s/Pa] | stapes 1 kHz [mm/s/Pa] |"
              " stapes peak [mm/s/Pa] at [Hz] |", "|---|---|---|---|---|---|---|---|"]
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
    return lines


def _write_frf(path: Path, f: np.ndarray, H: Mapping[float, Mapping[str, np.ndarray]]) -> None:
    rows = ["dp_Pa,frequency_Hz,umbo_re,umbo_im,stapes_re,stapes_im"]
    rows += [f"{dp!r},{fi!r},{h['umbo'][i].real!r},{h['umbo'][i].imag!r},"
             f"{h['stapes'][i].real!r},{h['stapes'][i].imag!r}"
             for dp, h in H.items() for i, fi in enumerate(f)]
    atomic_write(path, "\n".join(rows) + "\n")


def _plots(out: Path, f: np.ndarray, H: Mapping[float, Mapping[str, np.ndarray]],
           st: list[dict[str, float]]) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    files = []
    fig, ax = plt.subplots(2, 2, figsize=(10, 6), sharex=True, layout="constrained")
    cmap = plt.get_cmap("coolwarm")
    for dp, h in H.items():
        c = cmap((dp + 4000) / 8000)
        for j, key in enumerate(("umbo", "stapes")):
            ax[0, j].loglog(f, 1e3 * np.abs(h[key]), color=c, label=f"{dp:+.0f} Pa")
            ax[1, j].semilogx(f, np.degrees(np.unwrap(np.angle(h[key]))), color=c)
    for j, key in enumerate(("umbo", "stapes")):
        ax[0, j].set_title(f"{key} velocity / probe pressure")
        ax[0, j].set_ylabel("magnitude [mm/s/Pa]")
        ax[1, j].set_ylabel("phase [deg]")
        ax[1, j].set_xlabel("frequency [Hz]")
        for a in ax[:, j]:
            a.grid(True, which="both", lw=0.3)
    ax[0, 0].legend(fontsize=6, ncol=2)
    files.append(out / "frf.png")
    fig.savefig(files[-1], dpi=120)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(5, 3.5), layout="constrained")
    dps = np.array(list(H))
    for key in ("umbo", "malleus", "stapes"):
        ax.plot(dps, [low_db(H[d][key], H[0.0][key], f) for d in dps], "o-", label=key)
    gg = np.array([(d, m, s) for d, (m, s) in GYO_GOODE.items()])
    ax.errorbar(gg[:, 0], gg[:, 1], yerr=gg[:, 2], fmt="ks", label="Gyo & Goode 1987 umbo")
    ax.set_xlabel("Δp = p_canal − p_cavity [Pa]")
    ax.set_ylabel("change 100–1000 Hz [dB]")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=7)
    files.append(out / "dp_trend.png")
    fig.savefig(files[-1], dpi=120)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(5, 3.5), layout="constrained")
    ax.plot([r["dp"] for r in st], [r["umbo_um"] for r in st], "o-", label="umbo")
    ax.plot([r["dp"] for r in st], [r["stapes_um"] for r in st], "s-", label="stapes")
    ax.set_xlabel("Δp [Pa]")
    ax.set_ylabel("static displacement (medial +) [µm]")
    ax.grid(True, lw=0.3)
    ax.legend()
    files.append(out / "static.png")
    fig.savefig(files[-1], dpi=120)
    plt.close(fig)
    return files


def study(directory: str | Path, out: str | Path, nf: int = 80,
          progress: Progress | None = None) -> list[Path]:
    """Run the study of a build (module docstring) and write its files into ``out``.

    Parameters
    ----------
    directory
        A build of :func:`~neweul_py.middle_ear.build.build` (only read).
    out
        Output directory (created).
    nf
        Log-spaced frequencies 100 Hz–8 kHz.
    progress
        ``progress(message)`` hook.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    DataError
        ``directory`` is not a complete build, or its sweep does not cover the study's
        pressures (the body does not extrapolate).
    """
    say = progress or (lambda *_a, **_k: None)
    d, out = Path(directory), Path(out)
    info = build_record(d, float(PRESSURES.min()), float(PRESSURES.max()))
    out.mkdir(parents=True, exist_ok=True)
    built = d / info["module"] if info.get("module") else None
    if built is not None and built.is_file():
        mod = load_generated(built)
    else:
        say("generating the EMBS module")
        mod = load_generated(generate(d / info["description"], out / "generated"))
    text = (d / info["description"]).read_text(encoding="utf-8")
    say("static state vs Δp")
    st = static_table(d / "fem", text, out / "generated")
    f = np.geomspace(100.0, 8000.0, nf)
    H, at_1k = {}, {}
    for i, dp in enumerate(PRESSURES):
        say("transfer functions", i + 1, PRESSURES.size)
        H[float(dp)] = transfer(embs_frf(mod, dp, f), f)
        at_1k[float(dp)] = transfer(embs_frf(mod, dp, np.array([1000.0])), np.array([1000.0]))
    files = [out / "results.md", out / "frf.csv"]
    atomic_write(files[0], "\n".join(_tables(st, H, at_1k, f)) + "\n")
    _write_frf(files[1], f, H)
    return files + _plots(out, f, H, st)
