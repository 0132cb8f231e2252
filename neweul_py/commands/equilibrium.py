"""``neweul equilibrium FILE [-p NAME=VALUE] [-u NAME=VALUE] [--start COORD=VALUE] [--fix COORD]
[-o eq.csv]``."""

from __future__ import annotations

import argparse

from ..analysis.equilibrium import equilibrium
from ..atomic import atomic_write
from . import _analysis_common as common


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``equilibrium`` sub-command."""
    parser = subparsers.add_parser(
        "equilibrium",
        help="static equilibrium (Newton with the analytic stiffness)",
        description="Find the static equilibrium F(y) = (q − k)(y, 0, u) = 0 (with constraint "
        "forces where the model has loops) by Newton's method, starting at the initial state.",
    )
    common.add_model_arguments(parser, operating_point=False)
    parser.add_argument("-o", "--output", metavar="FILE",
                        help="write name,value rows (coordinates, lambda_<constraint>) as CSV")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Solve and print the equilibrium table."""
    module = common.load_model(args)
    eq = equilibrium(module, p=common.parameters(args), u=common.inputs(args),
                     y0=common.start(args), fixed=args.fix)
    print(eq.table())
    if args.output:
        rows = [["name", "value"], *([k, repr(v)] for k, v in eq.as_dict().items())]
        text = "".join(",".join(r) + "\n" for r in rows)
        print(f"equilibrium: {atomic_write(args.output, text.encode())}")
    return 0

