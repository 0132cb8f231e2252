"""The static state of the EMBS under Δp against the FE static solution.

Run from the repository root after ``neweul middle-ear build --dir DATA``::

    python examples/middle_ear/static_embs.py --dir DATA [--pressures -3600,-1400,600,2600]

For each working point of the body and each extra Δp (whose FE static solution is solved
alone): the body at Δp carries its static state; the malleus is tied to the manubrium nodes by
the TM–manubrium springs and held by the chain's static characteristic — the closed form
``F(s)`` of the FE static solution or the table of the description's ossicles
(:func:`neweul_py.middle_ear.validation.static_errors`, docs/equations-middle-ear.md §5) —, and
its umbo displacement and swept volume are compared with the FE static solution.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from neweul_py.middle_ear.validation import static_errors


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", type=Path, required=True, help="a build of neweul middle-ear build")
    ap.add_argument("--pressures", default="-3600,-1400,600,2600",
                    help="Δp between samples, their FE static solution solved alone")
    args = ap.parse_args()
    extra = [float(v) for v in args.pressures.split(",")] if args.pressures else []
    print("relative error of the body + chain static state against the FE static solution")
    print(f"{'dp [Pa]':>8} {'':>7} {'F_c':>6} {'umbo u_z':>10} {'volume':>10}")
    for dp, sample, kind, eu, ev in static_errors(args.dir, extra):
        print(f"{dp:>+8.0f} {'sample' if sample else 'between':>7} {kind:>6} {eu:>+10.2e} "
              f"{ev:>+10.2e}")


if __name__ == "__main__":
    main()
