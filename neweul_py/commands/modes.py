"""``neweul modes FILE [--at equilibrium|initial] [--undamped] [-o modes.csv|.npz]``."""

from __future__ import annotations

import argparse
import sys

from . import common as common


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``modes`` sub-command."""
    parser = subparsers.add_parser(
        "modes",
        help="eigenfrequencies, damping ratios and mode shapes",
        description="Eigenvalues of the linearized model (first-order form, generalized "
        "eigenproblem), sorted by natural frequency.",
    )
    common.add_model_arguments(parser)
    common.add_output_argument(parser, "FILE", ".csv, one row per oscillating mode "
                               "(frequency_hz, damping_ratio, …), or .npz with all eigenvalues "
                               "and shapes")
    parser.add_argument("--undamped", action="store_true",
                        help="eigenvalues of the undamped pencil det(Q - w^2 M0) = 0 (damping "
                        "and gyroscopic terms dropped): the undamped natural frequencies")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Print the modal table (and a warning at an unstable operating point); write ``-o``."""
    from ..analysis.linearize import linearize
    from ..analysis.modes import SUFFIXES, modes

    common.check_files(args.output, SUFFIXES, "modes")
    module = common.load_model(args)
    res = modes(linearize(module, **common.linearize_kwargs(module, args)),
                undamped=args.undamped)
    print(res.table())
    warning = res.stability_warning()
    if warning:
        print(f"neweul modes: warning: {warning}", file=sys.stderr)
    note = res.overdamped_note()
    if note:
        print(f"neweul modes: note: {note}", file=sys.stderr)
    if args.output:
        print(f"modes: {res.save(args.output)}")
    return 0
