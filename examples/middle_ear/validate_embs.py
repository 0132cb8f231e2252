"""Validation of the middle-ear EMBS against the unreduced FE model with the same chain.

Run from the repository root after ``neweul middle-ear build --dir DATA``::

    python examples/middle_ear/validate_embs.py --dir DATA [--pressures -4000,0,2000,2500]
        [--nf 40] [--damping loss|viscous]

For each Δp: the build's generated EMBS, linearized, against the full FE model of that working
point (between samples, e.g. 2500 Pa, the FE model linearized *there*, solved alone) coupled
directly with the **same** chain (:mod:`neweul_py.middle_ear.validation`). Printed: max
relative error of the umbo velocity (TM node 1) and of the stapes velocity per probe pressure,
below 2 kHz and 2–5 kHz.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from neweul_py.analysis import load_generated
from neweul_py.middle_ear import validation
from neweul_py.middle_ear.study import build_record


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", type=Path, required=True, help="a build of neweul middle-ear build")
    ap.add_argument("--pressures", default="-4000,0,2000,2500")
    ap.add_argument("--nf", type=int, default=40)
    ap.add_argument("--damping", choices=("loss", "viscous"), default="loss",
                    help="loss factors as K + iG (default) or their viscous equivalent")
    args = ap.parse_args()
    pressures = [float(v) for v in args.pressures.split(",")]
    record = build_record(args.dir, *pressures)
    mod = load_generated(args.dir / record["module"])
    chain = validation.chain_module(args.dir / "middle_ear.yaml", args.dir / "fem",
                                    args.dir / "validation")
    f = np.geomspace(100.0, 5000.0, args.nf)
    low = f < 2000
    print("relative error of the EMBS against the unreduced FE model + the same chain "
          f"({f.size} log frequencies 100 Hz-5 kHz)")
    print(f"{'dp [Pa]':>8} {'umbo <2k':>10} {'umbo 2-5k':>10} {'stapes <2k':>11} "
          f"{'stapes 2-5k':>11}")
    for dp in pressures:
        fe = validation.fe_model_at(dp, args.dir, int(record["refine"]))
        e = validation.errors(mod, chain, dp, f, fe, args.damping)
        print(f"{dp:>+8.0f} {e['umbo'][low].max():>10.2e} {e['umbo'][~low].max():>10.2e} "
              f"{e['stapes'][low].max():>11.2e} {e['stapes'][~low].max():>11.2e}")


if __name__ == "__main__":
    main()
