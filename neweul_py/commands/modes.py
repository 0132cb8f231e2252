"""``neweul modes FILE [--at equilibrium|initial] [-o modes.csv]``."""

from __future__ import annotations

import argparse

from ..analysis.linearize import linearize
from ..analysis.modes import modes
from . import _analysis_common as common


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``modes`` sub-command."""
    parser = subparsers.add_parser(
        "modes",
        help="eigenfrequencies, damping ratios and mode shapes",
        description="Eigenvalues of the linearized model (first-order form, generalized "
        "eigenproblem), sorted by natural frequency.",
    )
    common.add_model_arguments(parser)
    parser.add_argument("-o", "--output", metavar="FILE",
                        help="CSV, one row per oscillating mode (frequency_hz, damping_ratio, …)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Print the modal table; write the CSV with ``-o``."""
    module = common.load_model(args)
    res = modes(linearize(module, **common.linearize_kwargs(module, args)))
    print(res.table())
    if args.output:
        res.to_csv(args.output)
        print(f"modes: {args.output}")
    return 0
