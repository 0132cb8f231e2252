"""``neweul equilibrium FILE [-p NAME=VALUE] [-u NAME=VALUE] [--start COORD=VALUE] [--fix COORD]
[-o eq.csv|.npz]``."""

from __future__ import annotations

import argparse

from . import common as common


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``equilibrium`` sub-command."""
    parser = subparsers.add_parser(
        "equilibrium",
        help="static equilibrium (Newton with the analytic stiffness)",
        description="Find the static equilibrium F(y) = (q − k)(y, 0, u) = 0 (with constraint "
        "forces where the model has loops) by Newton's method, starting at the initial state; "
        "where Newton fails, pseudo-transient continuation follows the damped motion from the "
        "start to the stable equilibrium it settles in.",
    )
    common.add_model_arguments(parser, operating_point=False)
    common.add_output_argument(parser, "FILE", "write name,value rows (coordinates, "
                               "lambda_<constraint>) as .csv, or .npz")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Solve and print the equilibrium table."""
    from ..analysis.equilibrium import SUFFIXES, equilibrium

    common.check_files(args.output, SUFFIXES, "equilibria")
    module = common.load_model(args)
    eq = equilibrium(module, p=common.parameters(args), u=common.inputs(args),
                     y0=common.start(args), fixed=args.fix)
    print(eq.table())
    if args.output:
        print(f"equilibrium: {eq.save(args.output)}")
    return 0

