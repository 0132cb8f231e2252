"""``neweul sensitivity FILE --task frf|modes|simulate --wrt NAME [--wrt NAME …] [-o S.csv]``:
parameter sensitivities from the generated module's analytic derivatives (docs/sensitivity.md).
"""

from __future__ import annotations

import argparse
import functools

from . import CAPS, count, number, range_type
from . import common as common

#: ``--task`` choices.
TASKS = ("frf", "modes", "simulate")
#: ``--method`` choices of ``--task simulate`` (= ``analysis.sensitivity_time.METHODS``).
METHODS = ("RK45", "DOP853", "RK23", "Radau", "BDF", "LSODA")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``sensitivity`` sub-command."""
    parser = subparsers.add_parser(
        "sensitivity",
        help="parameter sensitivities of a frequency response, the modes or a simulation",
        description="Derivatives with respect to parameters from the module's analytic "
        "parameter derivatives: frf writes frequency_hz and per parameter dlogmag_dlog_NAME "
        "(d ln|H| / d ln p) and dphase_deg_dlog_NAME; modes one row per oscillating mode with "
        "dlogf_dlog_NAME and dzeta_dlog_NAME; simulate the simulation's columns and "
        "COLUMN__dlog_NAME (p d(COLUMN)/dp), by the variational equations integrated with the "
        "state. Linear analyses are about the static equilibrium (--at), which moves with the "
        "parameters.",
    )
    common.add_model_arguments(parser)
    parser.add_argument("--task", choices=TASKS, required=True, help="what to differentiate")
    parser.add_argument("--wrt", action="append", metavar="NAME",
                        help="parameter to differentiate with respect to (repeatable; default: "
                        "all)")
    parser.add_argument("--input", action="append", metavar="U", help="frf: input (repeatable)")
    parser.add_argument("--response", action="append", metavar="Y",
                        help="frf: response (output, coordinate, d_/dd_coordinate; repeatable)")
    parser.add_argument("--f", type=range_type("--f", minimum=0.0), metavar="START:STOP:N",
                        help=f"frf: frequencies in Hz (or a comma list; at most {CAPS['--f']})")
    parser.add_argument("--log", action="store_true", help="frf: logarithmic frequencies")
    parser.add_argument("--damping", choices=("loss", "viscous"), default="loss",
                        help="frf: loss factors as K + iG (default) or viscous")
    parser.add_argument("--undamped", action="store_true",
                        help="modes: of the undamped pencil (damping dropped)")
    parser.add_argument("--t-end", type=functools.partial(number, option="--t-end",
                                                          positive=True), metavar="T",
                        help="simulate: final time [s]")
    parser.add_argument("--n-out", type=count("--n-out", minimum=2), default=501, metavar="N",
                        help="simulate: output times (default 501)")
    parser.add_argument("--method", choices=METHODS, default="RK45",
                        help="simulate: integrator (default RK45)")
    parser.add_argument("--rtol", type=functools.partial(number, option="--rtol", positive=True,
                                                         maximum=1.0), default=1e-8,
                        help="simulate: relative tolerance (default 1e-8)")
    parser.add_argument("--atol", type=functools.partial(number, option="--atol",
                                                         positive=True), default=1e-10,
                        help="simulate: absolute tolerance (default 1e-10)")
    common.add_output_argument(parser, "FILE", "write the sensitivities as .csv")
    parser.set_defaults(func=run)


def _check(args: argparse.Namespace) -> None:
    """The options each task needs, before any work."""
    from ..errors import NeweulError

    need = {"frf": ("--f", args.f), "simulate": ("--t-end", args.t_end)}
    if args.task in need and need[args.task][1] is None:
        raise NeweulError(f"--task {args.task} needs {need[args.task][0]}")
    wrong = [opt for opt, value, task in (("--f", args.f, "frf"), ("--input", args.input, "frf"),
                                          ("--response", args.response, "frf"),
                                          ("--t-end", args.t_end, "simulate"))
             if value is not None and task != args.task]
    if wrong:
        raise NeweulError(f"{', '.join(wrong)} do(es) not apply to --task {args.task}")


def run(args: argparse.Namespace) -> int:
    """Compute the sensitivities of ``--task``; print a table or write ``-o``."""
    import numpy as np

    from ..analysis import sensitivity as sens
    from ..analysis import sensitivity_response as response

    _check(args)
    common.check_files(args.output, (".csv",), "sensitivities")
    args.sensitivities = args.task != "simulate"    # a description: with second derivatives
    from ..analysis.module import as_model

    module = as_model(common.load_model(args))
    p = common.parameters(args)
    if args.task == "simulate":
        from ..analysis.protocol import resolve_parameters
        from ..analysis.sensitivity_time import simulate_sensitivity

        # names and nonzero values first
        sens.parameter_indices(module, args.wrt, resolve_parameters(module, p))
        res = simulate_sensitivity(module, args.t_end, args.wrt, p=p, u=common.inputs(args),
                                   method=args.method, rtol=args.rtol, atol=args.atol,
                                   n_out=args.n_out)
    else:
        from ..analysis.linearize import linearize

        kw = common.linearize_kwargs(module, args)
        lin = linearize(module, **kw)
        sens.parameter_indices(module, args.wrt, lin.p)
        ders, method = sens.linear_model_derivatives(
            module, lin, args.wrt, equilibrium_point=args.at == "equilibrium", fixed=args.fix,
            u=common.inputs(args), start=common.start(args))
        if method != sens.ANALYTIC:
            import sys

            print(f"neweul sensitivity: note: the linear model's derivatives are {method} "
                  "(the module has no directional derivatives, or constraints)",
                  file=sys.stderr)
        if args.task == "modes":
            res = response.modal_sensitivity(lin, ders, undamped=args.undamped, method=method)
        else:
            res = response.frequency_response_sensitivity(
                lin, ders, np.asarray(args.f.values(args.log)), args.input, args.response,
                damping=args.damping, method=method)
    cols = res.columns()
    if not all(np.all(np.isfinite(np.asarray(v, dtype=float))) for k, v in cols.items()
               if k != "coordinate"):
        from ..errors import SolverError

        raise SolverError("the sensitivities are not finite (a response that vanishes at a "
                          "frequency, a zero eigenvalue, or a singular model)")
    if args.output:
        print(f"sensitivities: {res.to_csv(args.output)}")
    else:
        print(res.summary())
        print(_table(cols), end="")
    return 0


def _table(cols: dict) -> str:
    """The columns as aligned text."""
    names = list(cols)
    width = [max(12, len(n)) for n in names]
    lines = ["  ".join(f"{n:>{w}}" for n, w in zip(names, width, strict=True))]
    for row in zip(*cols.values(), strict=True):
        lines.append("  ".join(f"{v:>{w}.6g}" if not isinstance(v, str) else f"{v:>{w}}"
                               for v, w in zip(row, width, strict=True)))
    return "\n".join(lines) + "\n"
