"""``neweul sweep FILE --param NAME=VALUES … [--cases CASES.csv] --task simulate|equilibrium|
modes|frf [task options] [--scheduler ADDRESS | --workers N] [-o table.csv|.parquet|.npz]``."""

from __future__ import annotations

import argparse
import functools
import sys

from ..errors import NeweulError
from ..progress import QUIET_HELP, Tracker
from . import (
    CAPS,
    EXIT_CHECK_FAILED,
    FORMS,
    SIMULATE_METHODS,
    SWEEP_STATS,
    SWEEP_TASKS,
    count,
    number,
    range_type,
)
from .common import refuse_overwrite

#: Failures listed on stderr (the table holds all of them).
_SHOWN_FAILURES = 5


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``sweep`` sub-command."""
    parser = subparsers.add_parser(
        "sweep",
        help="run a task over a grid or list of parameter values on Dask; one table",
        description="Run simulate, equilibrium, modes or frf for every case — the grid of all "
        "--param values, times the rows of --cases — on a Dask cluster (a local one with "
        "--workers processes unless --scheduler names one). The generated module is shipped "
        "to each worker once; a failing case is recorded in the table (ok = 0, error) and the "
        "sweep goes on; the exit code is then 3 (unless --allow-failures).",
    )
    parser.add_argument("file", metavar="FILE", help="YAML description or generated module .py")
    parser.add_argument("--form", choices=FORMS, default="auto",
                        help="closed-form or recursive equations (default: auto)")
    parser.add_argument("--param", action="append", default=[], metavar="NAME=VALUES",
                        help="swept parameter: START:STOP:COUNT, a comma list or one value "
                        "(repeatable; the cases are all combinations)")
    parser.add_argument("--cases", metavar="CASES.csv",
                        help="CSV file with a header of parameter names and one case per row")
    parser.add_argument("--task", choices=SWEEP_TASKS, default="simulate",
                        help="what to run per case (default: simulate)")
    sim = parser.add_argument_group("simulate")
    sim.add_argument("--t-end", type=functools.partial(number, option="--t-end", positive=True),
                     metavar="T", help="final time [s]")
    sim.add_argument("--method", choices=SIMULATE_METHODS, default="RK45", help="integrator")
    sim.add_argument("--rtol", type=functools.partial(number, option="--rtol", positive=True),
                     default=1e-6, help="relative tolerance")
    sim.add_argument("--atol", type=functools.partial(number, option="--atol", positive=True),
                     default=1e-9, help="absolute tolerance")
    sim.add_argument("--n-out", type=count("--n-out", minimum=2), default=101, metavar="N",
                     help="output times per case (default 101)")
    sim.add_argument("--stats", default="final", metavar="LIST",
                     help=f"statistics of every column, comma list of {', '.join(SWEEP_STATS)} "
                     "(default: final)")
    lin = parser.add_argument_group("modes and frf")
    lin.add_argument("--at", choices=("equilibrium", "initial"), default="equilibrium",
                     help="operating point (default: static equilibrium)")
    lin.add_argument("--undamped", action="store_true", help="modes of the undamped pencil")
    lin.add_argument("--n-modes", type=count("--n-modes"), metavar="K",
                     help="modes per row (default ≤ 6)")
    lin.add_argument("--f", type=range_type("--f", minimum=0.0), metavar="START:STOP:N",
                     help="frf frequencies [Hz]: START:STOP:N or a comma list")
    lin.add_argument("--log", action="store_true", help="logarithmic frequency spacing")
    lin.add_argument("--input", action="append", metavar="NAME", help="frf input (repeatable)")
    lin.add_argument("--output", action="append", metavar="NAME",
                     help="frf output (repeatable)")
    dask = parser.add_argument_group(
        "Dask", "Without --scheduler the sweep starts its own local cluster on free ports of "
        "127.0.0.1, authenticated with temporary TLS credentials (Dask's "
        "Security.temporary): no other process can submit work to its workers.")
    dask.add_argument("--scheduler", metavar="ADDRESS",
                      help="address of a running scheduler (tls://host:8786) to use instead of "
                      "a local cluster; your choice: whoever can reach that scheduler can run "
                      "code on its workers (TLS settings come from the Dask configuration)")
    dask.add_argument("--workers", type=count("--workers"), default=2, metavar="N",
                      help=f"worker processes of the local cluster (default 2, at most "
                      f"{CAPS['--workers']})")
    dask.add_argument("--chunk-size", type=count("--chunk-size"), metavar="K",
                      help="cases per Dask task (default: about 4 tasks per worker)")
    dask.add_argument("--timeout", type=functools.partial(number, option="--timeout",
                                                          positive=True, maximum=3600.0),
                      default=5.0, metavar="S",
                      help="seconds to wait for --scheduler (default 5)")
    parser.add_argument("-o", "--out", metavar="TABLE",
                        help="write the table: .csv, .parquet (pyarrow) or .npz")
    parser.add_argument("--allow-failures", action="store_true",
                        help="exit 0 although some cases failed (default: exit 3, the "
                        "failures are in the table's error column either way)")
    parser.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    parser.set_defaults(func=run)


def _options(args: argparse.Namespace) -> dict:
    if args.task == "simulate":
        if args.t_end is None:
            raise NeweulError("--task simulate needs --t-end")
        return {"t_end": args.t_end, "method": args.method, "rtol": args.rtol,
                "atol": args.atol, "n_out": args.n_out,
                "stats": tuple(s.strip() for s in args.stats.split(",") if s.strip())}
    if args.task == "equilibrium":
        return {}
    opt: dict = {"at": args.at}
    if args.task == "modes":
        return opt | {"undamped": args.undamped, "n_modes": args.n_modes}
    if not args.f:
        raise NeweulError("--task frf needs --f (e.g. --f 10:1000:200 --log)")
    import numpy as np

    return opt | {"f": np.asarray(args.f.values(args.log)), "inputs": args.input,
                  "outputs": args.output}


def _cases(args: argparse.Namespace) -> list:
    from ..sweep import grid, parse_parameter, product, read_cases

    specs = dict(parse_parameter(t) for t in args.param)
    listed = read_cases(args.cases) if args.cases else []
    return product(listed, grid(specs) if specs else [])


def run(args: argparse.Namespace) -> int:
    """Check the inputs, run the sweep, report failures, write the table."""
    from ..sweep import check_sweep_output, sweep

    if args.out:
        check_sweep_output(args.out)
        refuse_overwrite(args.out, {"--cases": args.cases}, "-o/--out")
    options = _options(args)
    cases = _cases(args)
    if not args.file.endswith(".py"):
        from ..api import generated_module  # the symbolic layers, only for a description

        module = generated_module(args.file, args.form)
    else:
        module = args.file
    with Tracker("sweep", unit="case", quiet=args.quiet) as track:
        res = sweep(module, cases, args.task, scheduler=args.scheduler, workers=args.workers,
                    chunk_size=args.chunk_size, timeout=args.timeout, progress=track,
                    **options)
    bad = res.failures
    print(f"{res.model_name}: {res.ok.size} {args.task} cases on {res.workers} workers in "
          f"{res.seconds:.3g} s: {res.ok.size - len(bad)} ok, {len(bad)} failed")
    for case, msg in bad[:_SHOWN_FAILURES]:
        print(f"neweul sweep: case {case} failed: {msg}", file=sys.stderr)
    if len(bad) > _SHOWN_FAILURES:
        print(f"neweul sweep: … and {len(bad) - _SHOWN_FAILURES} more (see the error column)",
              file=sys.stderr)
    if args.out:
        print(f"table: {res.save(args.out)}")
    elif res.ok.size <= 50:
        print(res.to_text())
    return 0 if not bad or args.allow_failures else EXIT_CHECK_FAILED
