"""Low-frequency loss vs Δp on the unreduced FE model + the 3-D chain, for trial values of
the FE model's parameters (the ``s₊`` fit of README.md, "The static modulus").

Run from the repository root::

    python examples/middle_ear/fit_chain_limit.py --refine 1 --out /tmp/fit \\
        --set chain_limit_medial=150e-6 --set chain_limit_medial=200e-6

For each ``--set NAME=VALUE[,NAME=VALUE]`` (``MiddleEarParameters`` fields): the FE sweep at
0, +1, +2, +3 kPa (``--pressures``) in ``OUT/<label>/fem``, ``φ(Δp)`` of the 3-D chain to its
tangents (:func:`chain_factor.factor_table`, one generated chain module with ``φ`` as a
parameter), the chain coupled to the unreduced FE model of each working point
(:func:`validate_embs.reference_frf`, ``K + iG``), and the mean change 100–1000 Hz re Δp = 0
of the TM node at the umbo, the malleus at the umbo and the stapes; then the malleus's
deviations from Gyo & Goode 1987 in units of their standard deviations and their RMS.
An existing ``OUT/<label>/fem`` is reused (delete ``OUT`` after changing the code's defaults).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import fields, replace
from pathlib import Path

import numpy as np

from neweul_py.middle_ear.parameters import MiddleEarParameters
from neweul_py.middle_ear.sweep import pressure_sweep

sys.path.insert(0, str(Path(__file__).resolve().parent))
import chain_factor as cf
from studies import low_db
from validate_embs import DESCRIPTION, fe_model_at, parameters_at, reference_frf, transfer

#: Gyo & Goode 1987, umbo loss below 2 kHz [dB]: mean and standard deviation at +1/+2/+3 kPa.
GYO_GOODE = {1000.0: (-5.0, 1.0), 2000.0: (-9.2, 1.3), 3000.0: (-13.1, 1.8)}


def trial(params: MiddleEarParameters, refine: int, out: Path, pressures: list[float],
          f: np.ndarray) -> dict[str, dict[float, float]]:
    """Mean change [dB] per output (``umbo``, ``malleus``, ``stapes``) and Δp."""
    if not (out / "fem" / "static.csv").exists():
        pressure_sweep(pressures, params, refine, out_dir=str(out / "fem"))
    gen = out / "generated"
    mod = cf.calibration_module(cf.retarget(DESCRIPTION.read_text(), out, gen), out, gen)
    table = cf.factor_table(mod, cf.sweep_tangents(out))
    names = list(mod.PARAMETERS)
    H = {}
    for dp in pressures:
        p = parameters_at(mod, dp)
        p[names.index(cf.PHI)] = table[dp]
        r = reference_frf(mod, fe_model_at(dp, out), dp, f, "loss", p=p)
        H[dp] = transfer(r, f) | {"malleus": r["umbo_velocity_z"] / r["p_probe"]}
    return {k: {dp: low_db(H[dp][k], H[0.0][k], f) for dp in pressures}
            for k in ("umbo", "malleus", "stapes")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--refine", type=int, default=1)
    ap.add_argument("--out", type=Path, required=True, help="FE sweeps and generated modules")
    ap.add_argument("--set", action="append", default=[], help="NAME=VALUE[,NAME=VALUE]")
    ap.add_argument("--pressures", default="0,1000,2000,3000", help="Δp [Pa], comma separated")
    ap.add_argument("--nf", type=int, default=12, help="log frequencies 100–1000 Hz")
    args = ap.parse_args()
    known = {fl.name for fl in fields(MiddleEarParameters)}
    pressures = sorted({0.0, *(float(x) for x in args.pressures.split(","))})
    f = np.geomspace(100.0, 1000.0, args.nf)
    for text in args.set or [""]:
        kw = {}
        for item in filter(None, text.split(",")):
            name, _, value = item.partition("=")
            if name not in known:
                raise SystemExit(f"--set {text}: MiddleEarParameters has no field {name!r}")
            try:
                kw[name] = float(value)
            except ValueError:
                raise SystemExit(f"--set {text}: {value!r} is not a number") from None
        label = "_".join(f"{k}={v:g}" for k, v in kw.items()) or "defaults"
        low = trial(replace(MiddleEarParameters(), **kw), args.refine, args.out / label,
                    pressures, f)
        print(f"{label} (refine {args.refine})")
        for key, row in low.items():
            print(f"  {key:8s}" + " ".join(f"{dp / 1000:+.0f} kPa {v:+.2f}" for dp, v in row.items()
                                           if dp))
        z = [(low["malleus"][dp] - m) / s for dp, (m, s) in GYO_GOODE.items()
             if dp in low["malleus"]]
        if z:
            print("  malleus − Gyo & Goode [SD]: " + " ".join(f"{v:+.2f}" for v in z)
                  + f"  RMS {float(np.sqrt(np.mean(np.square(z)))):.2f}", flush=True)


if __name__ == "__main__":
    main()
