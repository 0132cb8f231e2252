"""``neweul fem middle-ear``: FE models of the TM and the middle-ear air over static pressures."""

from __future__ import annotations

import argparse

from ..progress import QUIET_HELP, Tracker

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
    # "--pressures -4000:4000:9" gets through: cli.build_parser accepts negative lists
    me.add_argument(
        "--pressures",
        default="-4000:4000:9",
        help="static pressures [Pa]: start:stop:count or a comma list (default -4000:4000:9)",
    )
    me.add_argument("-o", "--output", required=True, metavar="DIR", help="output directory")
    me.add_argument("--refine", type=int, default=2, help="mesh refinement level (default 2)")
    me.add_argument("--plots", action="store_true", help="also write PNG pictures")
    me.add_argument(
        "--include-support",
        action="store_true",
        help="keep the ossicular-chain support springs in the exported stiffness",
    )
    me.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    me.set_defaults(func=_middle_ear)


def _middle_ear(args: argparse.Namespace) -> int:
    from ..fem.middle_ear import parse_pressures, pressure_sweep

    with Tracker("FE sweep", unit="point", quiet=args.quiet) as track:  # a bar on a terminal
        result = pressure_sweep(
            parse_pressures(args.pressures),
            refine=args.refine,
            out_dir=args.output,
            plots=args.plots,
            include_support=args.include_support,
            verbose=True,
            progress=track,
        )
    print(f"wrote {len(result.models)} working points to {args.output}")
    return 0
