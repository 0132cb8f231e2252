"""Time study of the middle-ear EMBS (issue 13 item 6): a tone under a slow Δp ramp.

A 1 kHz tone in the canal while Δp goes 0 → +2000 Pa → 0 (a middle-ear pressure of −2 kPa,
swallow-like: ``2000 sin²(πt/350 ms)``) — a copy of the description in which every ``dp`` is
the ramp ``dp(t)`` (schedule and chain factor alike); the frozen-parameter assumption
(README, docs/equations-middle-ear.md §7). Moved out of ``studies.py``.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

import numpy as np

from neweul_py.analysis import load_generated, simulate
from neweul_py.api import generate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from validate_embs import DESCRIPTION, HERE

#: A smooth swallow-like bump 0 → 1 → 0 over 0 ≤ t ≤ 0.35 s (no piecewise(): the chain
#: factor compares dp in its own piecewise(), and comparisons may not contain one).
RAMP = "sin(pi*t/0.35)**2"


def ramp_description(out: Path) -> Path:
    """``middle_ear.yaml`` with every ``dp`` (schedule, chain factor) replaced by
    ``dp + dp_ramp*ramp(t)``; written next to the original's data (same relative data path)."""
    text = DESCRIPTION.read_text()
    head, body = text.split("\ncoordinates:", 1)
    body = re.sub(r"\bdp\b", f"(dp + dp_ramp*{RAMP})", body)
    head = head.replace("parameters:\n", "parameters:\n  dp_ramp: 2000.0   # Pa, ramp amplitude\n",
                        1).replace("name: middle_ear", "name: middle_ear_ramp")
    path = HERE / "middle_ear_ramp.yaml.tmp"
    path.write_text(head + "\ncoordinates:" + body)
    return path


def time_study(out: Path, f_tone: float = 1000.0, t_end: float = 0.35):
    """The tone under the Δp ramp (module docstring); returns (t, results, seconds)."""
    desc = ramp_description(out)
    try:
        mod = load_generated(generate(desc, out / "generated_ramp"))
    finally:
        desc.unlink()
    p = {"Q_amp": 1e-5, "f_tone": f_tone}
    t0 = time.perf_counter()
    res = simulate(mod, t_end, method="BDF", rtol=1e-5, atol=1e-12, p=p,
                   n_out=int(t_end * f_tone * 20) + 1, max_step=1.0 / (f_tone * 10))
    return res, time.perf_counter() - t0


def envelope(t: np.ndarray, x: np.ndarray, period: float) -> tuple[np.ndarray, np.ndarray]:
    """RMS·√2 over consecutive periods."""
    n = int(np.floor((t[-1] - t[0]) / period))
    edges = t[0] + period * np.arange(n + 1)
    idx = np.searchsorted(t, edges)
    sums = np.add.reduceat(x**2, idx[:-1])[: n]
    amp = np.sqrt(2 * sums / np.maximum(np.diff(idx), 1))
    return 0.5 * (edges[:-1] + edges[1:]), amp


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", type=Path, default=HERE / "data")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    out = args.out or args.dir / "studies"
    out.mkdir(parents=True, exist_ok=True)
    lines = []
    res, secs = time_study(out)
    t = np.asarray(res.t)
    names = list(res.output_names)
    pp = np.asarray(res.outputs)[:, names.index("p_probe")]
    vs = np.asarray(res.outputs)[:, names.index("stapes_velocity")]
    tc, ap_ = envelope(t, pp, 1e-3)
    _, av = envelope(t, vs, 1e-3)
    ratio = av / ap_
    lines += ["", f"## Time simulation: 1 kHz tone, Δp = 2000 sin²(πt/0.35 s) Pa "
              f"(BDF, {secs:.0f} s)", "",
              "| t [ms] | Δp(t) [Pa] | stapes/probe amplitude [mm/s/Pa] |", "|---|---|---|"]
    for tm in (0.02, 0.09, 0.175, 0.26, 0.33):
        i = int(np.argmin(np.abs(tc - tm)))
        lines.append(f"| {1e3 * tc[i]:.0f} | {2000 * _ramp(tc[i]):.0f} | "
                     f"{1e3 * ratio[i]:.4f} |")
    (out / "time_results.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.asarray(res.t)
    names = list(res.output_names)
    fig, ax = plt.subplots(2, 1, figsize=(7, 4.5), sharex=True)
    ax[0].plot(1e3 * t, np.asarray(res.outputs)[:, names.index("p_probe")], lw=0.3)
    ax[0].set_ylabel("probe pressure [Pa]")
    ax[1].plot(1e3 * t, 1e3 * np.asarray(res.outputs)[:, names.index("stapes_velocity")],
               lw=0.3)
    ax[1].set_ylabel("stapes velocity [mm/s]")
    ax[1].set_xlabel("t [ms] (Δp = 2000 sin²(πt/350 ms) Pa)")
    fig.tight_layout()
    fig.savefig(out / "time.png", dpi=120)


def _ramp(t: float) -> float:
    return float(np.sin(np.pi * t / 0.35) ** 2) if 0.0 <= t <= 0.35 else 0.0


if __name__ == "__main__":
    main()
