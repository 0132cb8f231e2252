"""``neweul linearize FILE [--at equilibrium|initial] [-o lin.npz]``."""

from __future__ import annotations

import argparse

from . import common as common


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``linearize`` sub-command."""
    parser = subparsers.add_parser(
        "linearize",
        help="M0, P, Q, B, C, D about an operating point",
        description="Linearize M0 δÿ + P δẏ + Q δy = B δu, δy_out = C δx + D δu from the "
        "symbolically generated Jacobians (constrained models: in minimal coordinates).",
    )
    common.add_model_arguments(parser)
    common.add_output_argument(parser, "FILE", "write the matrices, names and operating point "
                               "to .npz")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Linearize; print the matrices or write them to ``-o``."""
    import numpy as np

    from ..analysis.linearize import linearize

    common.check_files(args.output, (".npz",), "linear models")
    module = common.load_model(args)
    lin = linearize(module, **common.linearize_kwargs(module, args))
    print(f"{module.MODEL_NAME}: linearized at {args.at}; coordinates "
          f"{', '.join(lin.coordinates)}; inputs {', '.join(lin.inputs) or '-'}; "
          f"outputs {', '.join(lin.outputs) or '-'}")
    if args.output:
        print(f"linear model: {lin.save(args.output)}")
        return 0
    with np.printoptions(precision=6, linewidth=100, suppress=False):
        for name in ("M0", "P", "Q", "B", "C", "D"):
            print(f"{name} =\n{getattr(lin, name)}")
    return 0
