"""``neweul simulate FILE --t-end T [--method M] [--rtol R] [--atol A] [--n-out N]
[--independent NAME ...] [-o results.csv|.npz] [--plot fig.png]``."""

from __future__ import annotations

import argparse

from ..analysis.results import SUFFIXES
from ..analysis.simulate import METHODS, simulate
from . import FORMS
from . import _analysis_common as common
from ._signals import input_assignment, input_function


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``simulate`` sub-command."""
    parser = subparsers.add_parser(
        "simulate",
        help="generate (cached) and integrate a model; write results and a plot",
        description="Integrate a description file (its module is generated into the cache, "
        "or reused when the description is unchanged) or an already generated module (.py) "
        "with scipy.integrate.solve_ivp. Closed loops start from a consistent state that keeps "
        "the independent coordinates (default: the first ones the constraints leave free) at "
        "their given positions and velocities.",
    )
    parser.add_argument("file", metavar="FILE", help="YAML description or generated module .py")
    parser.add_argument("--t-end", type=float, required=True, metavar="T", help="final time [s]")
    parser.add_argument("--method", choices=METHODS, default="RK45",
                        help="integrator (Radau, BDF, LSODA use the analytic Jacobian)")
    parser.add_argument("--rtol", type=float, default=1e-6, help="relative tolerance")
    parser.add_argument("--atol", type=float, default=1e-9, help="absolute tolerance")
    parser.add_argument("--n-out", type=int, default=501, metavar="N",
                        help="number of equally spaced output times (default 501)")
    parser.add_argument("-p", "--param", type=common.assignment, action="append", default=[],
                        metavar="NAME=VALUE", help="override a parameter (repeatable)")
    parser.add_argument("-u", "--set-input", type=input_assignment, action="append", default=[],
                        metavar="NAME=EXPR", help="drive an input by an expression of t and the "
                        "parameters, e.g. -u 'F=2*sin(3*t)' (repeatable)")
    parser.add_argument("--form", choices=FORMS, default="auto",
                        help="closed-form or recursive equations (default: auto)")
    common.add_independent_argument(
        parser, "constrained models: coordinates whose initial positions and velocities are "
        "kept exactly (default: the first ones in COORDINATES order the constraints leave free)")
    parser.add_argument("-o", "--output", metavar="FILE",
                        help="write results as .csv (with a units line) or .npz")
    parser.add_argument("--plot", metavar="FIG",
                        help="plot coordinates and outputs (.png/.pdf/.svg; matplotlib)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Simulate, write the requested files and print a one-line summary per file."""
    common.check_files(args.output, SUFFIXES, "results", args.plot)
    module = common.load_model(args)
    p = dict(args.param) or None
    u = input_function(module, args.set_input, p)
    result = simulate(module, args.t_end, method=args.method, rtol=args.rtol, atol=args.atol,
                      n_out=args.n_out, p=p, u=u, independent=args.independent)
    print(f"{result.model_name}: t = {result.t[0]:g} … {result.t[-1]:g} s with {result.method}, "
          f"{result.nfev} right-hand-side evaluations")
    if args.output:
        print(f"results: {result.save(args.output)}")
    if args.plot:
        from ..analysis.plot import plot_result

        print(f"plot: {plot_result(result, args.plot)}")
    if not args.output and not args.plot:
        final = ", ".join(f"{n} = {v:.6g}" for n, v in zip(result.names[1:],
                                                           result.table[-1, 1:], strict=True))
        print(f"final state: {final}")
    return 0
