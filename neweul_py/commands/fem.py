"""``neweul fem middle-ear``: FE models of the TM and the middle-ear air over static pressures."""

from __future__ import annotations

import argparse
import sys

from . import CAPS, count, range_type
from . import _analysis_common as shared

__all__ = ["register"]


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``fem`` command (sub-command ``middle-ear``)."""
    parser = subparsers.add_parser(
        "fem", help="build acousto-structural FE models (tympanic membrane and middle-ear air)"
    )
    sub = parser.add_subparsers(dest="fem_command", metavar="MODEL", required=True)
    me = sub.add_parser(
        "middle-ear",
        help="TM + ear canal + tympanic cavity, linearized at static pressures",
        description="Solve the nonlinear static TM problem at each static pressure difference "
        "dp = p_canal - p_cavity and write one up-coupled FE model (Eq. (2)) per working "
        "point, the static results (static.csv) and sweep.json into DIR (atomically). A load step "
        "whose static state leaves the model's validity (TM reaching an air-space wall, cone "
        "inversion, |dV| > 5 % of an air volume) stops the sweep with an error; nothing is "
        "written. Progress goes to stderr.",
    )
    # "--pressures -4000:4000:9" gets through: cli.attach_negative_values
    pressures = range_type("--pressures", increasing=False)
    me.add_argument(
        "--pressures",
        type=pressures,
        default=pressures("-4000:4000:9"),
        metavar="START:STOP:N",
        help="static pressures [Pa]: START:STOP:N or a comma list (default -4000:4000:9, at "
        f"most {CAPS['--pressures']})",
    )
    shared.add_output_argument(me, "DIR", "output directory", required=True)
    me.add_argument("--refine", type=count("--refine", minimum=0), default=2,
                    help=f"mesh refinement level (default 2, at most {CAPS['--refine']})")
    me.add_argument("--plots", action="store_true", help="also write PNG pictures")
    me.add_argument(
        "--include-support",
        action="store_true",
        help="keep the ossicular-chain support springs in the exported stiffness",
    )
    me.set_defaults(func=_middle_ear)


def _progress(msg: str) -> None:
    """Progress of the long steps on stderr (as ``neweul reduce`` prints it)."""
    print(f"  {msg}", file=sys.stderr, flush=True)


def _middle_ear(args: argparse.Namespace) -> int:
    from ..fem.middle_ear import pressure_sweep

    result = pressure_sweep(
        args.pressures.values(),
        refine=args.refine,
        out_dir=args.output,
        plots=args.plots,
        include_support=args.include_support,
        verbose=True,
        progress=_progress,
    )
    print(f"wrote {len(result.models)} working points to {args.output}")
    return 0
