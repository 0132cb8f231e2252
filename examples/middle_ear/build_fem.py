"""Build the middle-ear FE models: one up-coupled (Eq. (2)) model per static pressure.

Run from the repository root (see README.md in this directory)::

    python examples/middle_ear/build_fem.py                    # refine 2, -4000:4000:9 Pa
    python examples/middle_ear/build_fem.py --refine 1 --plots

The same as ``neweul fem middle-ear --pressures -4000:4000:9 -o examples/middle_ear/data/fem``.
Output (not committed, ≈ 30 MB per working point at refine 2): ``data/fem/model_dp±NNNNN.npz``,
``static.csv``, ``sweep.json`` (+ ``mesh.png``, ``static.png``, ``tm_modes.png``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from neweul_py.middle_ear.parameters import MiddleEarParameters
from neweul_py.middle_ear.sweep import parse_pressures, pressure_sweep

HERE = Path(__file__).resolve().parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pressures", default="-4000:4000:9")
    parser.add_argument("--refine", type=int, default=2)
    parser.add_argument("--plots", action="store_true")
    parser.add_argument("-o", "--output", default=str(HERE / "data" / "fem"))
    args = parser.parse_args()
    result = pressure_sweep(
        parse_pressures(args.pressures),
        params=MiddleEarParameters(),  # every value: README.md, "Values and sources"
        refine=args.refine,
        out_dir=args.output,
        plots=args.plots,
        verbose=True,
        progress=lambda msg: print(f"  {msg}", file=sys.stderr, flush=True),
    )
    print(f"wrote {len(result.models)} FE models to {args.output}")


if __name__ == "__main__":
    main()
