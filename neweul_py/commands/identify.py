"""``neweul identify FILE --data DATA.csv --task frf|simulate --param NAME=LO:HI[:START] …
[-o FIT.json] [--plot FIG]``: fit parameters to measured data (docs/howto/identify.md)."""

from __future__ import annotations

import argparse
import functools

from . import BACKENDS, FORMS, count, number
from . import common as common

#: ``--task`` choices.
TASKS = ("frf", "simulate")
#: ``--method`` choices of ``--task simulate``.
METHODS = ("RK45", "DOP853", "RK23", "Radau", "BDF", "LSODA")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``identify`` sub-command."""
    parser = subparsers.add_parser(
        "identify",
        help="fit parameters to a measured frequency response or time history",
        description="Bounded nonlinear least squares (scipy.optimize.least_squares, "
        "trust-region reflective) with the analytic sensitivities as Jacobian. frf: DATA as "
        "neweul frf -o writes it (frequency_hz, magnitude, phase_deg), residuals "
        "ln(H_model/H_data) (log magnitude and phase); simulate: DATA as neweul simulate -o "
        "writes it (t and signals), residuals per signal scaled by its RMS. An optional DATA "
        "column 'weight' weights each row. Parameters the data do not determine are reported "
        "as such (null, with the reason).",
    )
    parser.add_argument("file", metavar="FILE", help="YAML description or generated module .py")
    parser.add_argument("--data", required=True, metavar="DATA", help="measured data (.csv)")
    parser.add_argument("--task", choices=TASKS, required=True, help="what the data are")
    parser.add_argument("--param", dest="fit", action="append", required=True,
                        metavar="NAME=LO:HI[:START]",
                        help="a fitted parameter, its bounds and start (repeatable)")
    parser.add_argument("--scale", choices=("auto", "log", "linear"), default="auto",
                        help="fit ln p (log) or p (linear); auto: log where LO > 0")
    parser.add_argument("--set", dest="param", type=common.assignment, action="append",
                        default=[], metavar="NAME=VALUE",
                        help="hold a parameter that is not fitted at a value (repeatable)")
    parser.add_argument("--input", metavar="U", help="frf: the model input of the data")
    parser.add_argument("--response", action="append", metavar="Y",
                        help="frf: the model output of the data; simulate: a fitted signal "
                        "(repeatable; default: every signal column of DATA)")
    parser.add_argument("--phase-weight", type=functools.partial(number, option="--phase-weight",
                                                                 minimum=0.0), default=1.0,
                        metavar="W", help="frf: weight of the phase residuals [rad] against "
                        "the log-magnitude ones (default 1; 0: magnitude only)")
    parser.add_argument("--damping", choices=("loss", "viscous"), default="loss",
                        help="frf: loss factors as K + iG (default) or viscous")
    parser.add_argument("--at", choices=("equilibrium", "initial"), default="equilibrium",
                        help="frf: operating point (default: the static equilibrium, found "
                        "again for every trial)")
    parser.add_argument("--t-end", type=functools.partial(number, option="--t-end",
                                                          positive=True), metavar="T",
                        help="simulate: final time [s] (at least DATA's last time)")
    parser.add_argument("--method", choices=METHODS, default="RK45",
                        help="simulate: integrator (default RK45)")
    parser.add_argument("--rtol", type=functools.partial(number, option="--rtol", positive=True,
                                                         maximum=1.0), default=1e-8,
                        help="simulate: relative tolerance of the state and its sensitivities "
                        "(default 1e-8)")
    parser.add_argument("--atol", type=functools.partial(number, option="--atol",
                                                         positive=True), default=1e-10,
                        help="simulate: absolute tolerance (default 1e-10)")
    parser.add_argument("--starts", type=count("--starts", cap=10_000), default=1, metavar="N",
                        help="starts: the given one, then a Latin hypercube in the bounds")
    parser.add_argument("--seed", type=count("--seed", minimum=0, cap=2**32 - 1), default=0,
                        help="seed of the starts (default 0)")
    parser.add_argument("--workers", type=count("--workers", minimum=0, cap=256), default=0,
                        metavar="W", help="run the starts on a local Dask cluster of W "
                        "processes (the sweep extra; default 0: in this process)")
    parser.add_argument("--scheduler", metavar="ADDR", help="run the starts on this Dask "
                        "scheduler")
    parser.add_argument("--max-nfev", type=count("--max-nfev", cap=100_000), default=100,
                        metavar="N", help="model evaluations per start (default 100)")
    parser.add_argument("--form", choices=FORMS, default="auto",
                        help="closed-form or recursive equations (default: auto)")
    parser.add_argument("--backend", choices=BACKENDS, default="numpy",
                        help="module of a description: NumPy or compiled C (cffi)")
    parser.add_argument("-u", "--set-input", type=common.assignment, action="append",
                        default=[], metavar="NAME=VALUE", help="hold an input at a value")
    parser.add_argument("--start", type=common.assignment, action="append", default=[],
                        metavar="COORD=VALUE", help="frf: start of the equilibrium search")
    parser.add_argument("--fix", action="append", default=[], metavar="COORD",
                        help="frf: hold a coordinate in the equilibrium search")
    common.add_output_argument(parser, "FIT", "write the fit as .json")
    parser.add_argument("--plot", metavar="FIG", help="data and fit (.png/.pdf/.svg)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Fit, print the estimates, write ``-o`` and ``--plot``; exit 1 when the fit did not
    converge (the report says so)."""
    import sys

    from ..analysis.identify import Bound, identify
    from ..errors import NeweulError

    common.check_files(args.output, (".json",), "fits", args.plot)
    common.refuse_overwrite(args.output, {"--data": args.data, "FILE": args.file})
    common.refuse_overwrite(args.plot, {"--data": args.data, "FILE": args.file}, "--plot")
    bounds = [Bound.parse(text, args.scale) for text in args.fit]
    for b in bounds:
        b.check()
    held = sorted({b.name for b in bounds} & {name for name, _ in args.param})
    if held:
        raise NeweulError(f"{', '.join(held)}: fitted (--param) and held (--set) at once; give "
                          "a start as --param NAME=LO:HI:START")
    if args.task == "frf":
        if not args.input or not args.response or len(args.response) != 1:
            raise NeweulError("--task frf needs --input U and one --response Y (the model's "
                              "names for the data's input and output)")
        if args.t_end is not None:
            raise NeweulError("--t-end does not apply to --task frf")
    elif args.t_end is None:
        raise NeweulError("--task simulate needs --t-end T")
    args.sensitivities = args.task == "frf"     # a description: with second derivatives
    module = common.load_model(args)
    fit = identify(
        module, args.data, bounds, args.task, input=args.input,
        response=args.response[0] if args.task == "frf" else None,
        columns=args.response if args.task == "simulate" else None, t_end=args.t_end,
        p=common.parameters(args), u=common.inputs(args), at=args.at, fixed=args.fix,
        start=common.start(args), damping=args.damping, phase_weight=args.phase_weight,
        method=args.method, rtol=args.rtol, atol=args.atol, starts=args.starts,
        seed=args.seed, workers=args.workers, scheduler=args.scheduler, max_nfev=args.max_nfev)
    width = max(len(n) for n in fit.parameters)
    for name, value in fit.parameters.items():
        if value is None:
            print(f"{name:<{width}}  undetermined: {fit.undetermined[name]}")
        else:
            se = fit.standard_errors[name]
            spread = f" ± {se:.3g}" if se is not None else ""
            print(f"{name:<{width}}  {value:.8g}{spread}")
    print(f"# cost {fit.cost:.6g}, residual rms {fit.residual_rms:.3g} of {fit.n_residuals}, "
          f"{fit.iterations} iterations, {len(fit.starts)} start(s)")
    if fit.at_bounds:
        print(f"neweul identify: note: on a bound: {', '.join(fit.at_bounds)}", file=sys.stderr)
    if args.plot:                     # first: the report is the last file written
        print(f"plot: {fit.plot(args.plot)}")
    if args.output:
        print(f"fit: {fit.to_json(args.output)}")
    if not fit.converged:
        print(f"neweul identify: error: the fit did not converge ({fit.message}; raise "
              "--max-nfev or narrow the bounds)"
              + (f"; the report in {args.output} says so" if args.output else ""),
              file=sys.stderr)
        return 1
    return 0
