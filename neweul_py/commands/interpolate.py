"""``neweul interpolate BODY1.npz BODY2.npz … --parameter NAME [--values V1,V2,…]
[--interpolation linear|cubic] [--basis auto|full|kept] [--row-scaling kind|none]
[--pressure-weight W] [--weights W1,…] [--store-bases] -o pbody.npz``: local reduced bodies →
parametric body (``docs/equations.md`` §4)."""

from __future__ import annotations

import argparse
import functools
import sys
import time

from ..errors import NeweulError
from . import _analysis_common as shared
from . import number, values_type

#: ``--interpolation`` and ``--basis`` choices and the default ``--pressure-weight``; the same as
#: :mod:`neweul_py.elastic.interpolation` (kept here so that building the parser imports no
#: elastic code; a test checks they agree).
INTERPOLATIONS: tuple[str, ...] = ("linear", "cubic")
BASES: tuple[str, ...] = ("auto", "full", "kept")
PRESSURE_WEIGHT = 1e-3


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``interpolate`` sub-command."""
    parser = subparsers.add_parser(
        "interpolate",
        help="combine reduced bodies at parameter samples into a parametric body",
        description="Parametric model order reduction by matrix interpolation (Panzer et al. "
        "2010): bring the local reduced bodies (one per sample of the parameter, same FE "
        "discretization and order) to common coordinates and write the parametric body "
        "(.npz, see docs/reduced-body-format.md) atomically.",
    )
    parser.add_argument("bodies", nargs="+", metavar="BODY",
                        help="reduced-body files (.npz), in increasing parameter order")
    parser.add_argument("--parameter", required=True, metavar="NAME",
                        help="name of the parameter")
    parser.add_argument("--values", type=values_type("--values"), metavar="V1,V2,…",
                        help="sample values, one per body (default: the values the bodies "
                        "record in their parameters)")
    parser.add_argument("--interpolation", choices=INTERPOLATIONS, default="linear",
                        help="default weights between samples (default linear)")
    parser.add_argument("--basis", choices=BASES, default="auto",
                        help="basis rows for the common subspace: full bases (needs "
                        "--store-bases at reduction) or the kept rows (default auto)")
    parser.add_argument("--row-scaling", choices=("kind", "none"), default=None,
                        help="row metric of the common subspace: kind = one factor per "
                        "group of DOF kinds (translations, rotations, pressure), balanced, "
                        "pressure down-weighted (structure first); none = plain rows "
                        "(default: kind when the bodies record the DOF kinds of their "
                        "bases, else none)")
    parser.add_argument("--pressure-weight", default=PRESSURE_WEIGHT,
                        type=functools.partial(number, option="--pressure-weight",
                                               positive=True),
                        metavar="W", help="factor of the pressure rows on top of the "
                        f"balanced kind scaling (default {PRESSURE_WEIGHT:g}; 1 = balanced)")
    parser.add_argument("--weights", type=values_type("--weights", minimum=0.0),
                        metavar="W1,W2,…",
                        help="SVD weights of the samples (default all 1)")
    parser.add_argument("--store-bases", action="store_true",
                        help="also store the transformed full bases")
    shared.add_output_argument(parser, "PBODY.npz", "parametric-body file to write",
                               required=True)
    parser.set_defaults(func=run)


def _progress(msg: str) -> None:
    print(f"  {msg}", file=sys.stderr, flush=True)


def run(args: argparse.Namespace) -> int:
    """Read the bodies, interpolate, write; print a summary."""
    from ..elastic.interpolation import interpolate
    from ..elastic.reduced_body import load_reduced_body

    shared.check_files(args.output, (".npz",), "parametric bodies")
    if args.values is not None and len(args.values) != len(args.bodies):
        raise NeweulError(f"--values has {len(args.values)} entries for {len(args.bodies)} "
                          "bodies")
    t0 = time.perf_counter()
    bodies = []
    for path in args.bodies:
        _progress(f"reading {path}")
        bodies.append(load_reduced_body(path))
    pb = interpolate(bodies, args.values, parameter=args.parameter, basis=args.basis,
                     row_scaling=args.row_scaling or "auto",
                     pressure_weight=args.pressure_weight, weights=args.weights,
                     interpolation=args.interpolation, store_bases=args.store_bases,
                     progress=_progress)
    pb.save(args.output)
    lo, hi = pb.range
    sv = pb.singular_values
    cut = sv[pb.order] / sv[0] if sv.size > pb.order else 0.0
    print(f"{args.output}: {pb.n_samples} samples of {pb.parameter} in [{lo:g}, {hi:g}], "
          f"order {pb.order} ({'two' if pb.two_sided else 'one'}-sided, {pb.basis} bases, "
          f"row scaling {pb.row_scaling}, "
          f"σ_r+1/σ_1 = {cut:.3g}), {time.perf_counter() - t0:.2f} s")
    return 0
