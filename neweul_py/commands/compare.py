"""``neweul compare RESULT REFERENCE [--signals NAME ...] [--rtol X|NAME=X ...]
[--atol X|NAME=X ...] [--mac MIN] [--plot FIG] [-o errors.csv]``: exit code 0 when every signal is
within its tolerance, 3 when the comparison ran and a signal is not (1 is an error of the input:
a missing file, no signal in common; for test suites and CI, docs/cli.md)."""

from __future__ import annotations

import argparse
import functools

from . import EXIT_CHECK_FAILED, number
from . import common as common


def tolerance(text: str) -> tuple[str, float]:
    """``1e-3`` (every signal) or ``NAME=1e-2`` (one signal) — an argparse type."""
    name, sep, value = text.rpartition("=")
    try:
        return (name.strip() if sep else "*"), number(value, name.strip() or "tolerance",
                                                      minimum=0.0)
    except (ValueError, argparse.ArgumentTypeError):
        raise argparse.ArgumentTypeError(f"expected a number or NAME=NUMBER, got {text!r}"
                                         ) from None


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``compare`` sub-command."""
    parser = subparsers.add_parser(
        "compare",
        help="compare a result with a reference (time histories, FRFs, equilibria, modes)",
        description="Compare RESULT with REFERENCE signal by signal: neweul-py .csv/.npz "
        "results, or plain CSV from other tools (a header row of names, the first column time "
        "or frequency). Time histories are resampled onto common times and judged against "
        "atol + rtol·max|ref|; frequency responses pointwise as complex numbers (magnitude and "
        "phase); modes are matched by MAC and frequency. Prints a per-signal error table; the "
        "exit code is 0 when everything passes, 3 when a signal is beyond its tolerance, 1 "
        "for an error of the input (a missing or unreadable file, no signal in common).",
    )
    parser.add_argument("result", metavar="RESULT", help="our result (.csv or .npz)")
    parser.add_argument("reference", metavar="REFERENCE", help="the reference (.csv or .npz)")
    parser.add_argument("--signals", nargs="+", action="extend", metavar="NAME",
                        help="signals to compare (default: all common ones)")
    parser.add_argument("--rtol", type=tolerance, action="append", default=[],
                        metavar="X|NAME=X", help="relative tolerance, for all or one signal "
                        "(repeatable; default 1e-3)")
    parser.add_argument("--atol", type=tolerance, action="append", default=[],
                        metavar="X|NAME=X", help="absolute tolerance (repeatable; default 1e-12)")
    parser.add_argument("--mac", type=functools.partial(number, option="--mac", minimum=0.0,
                                                        maximum=1.0),
                        default=0.9, metavar="MIN",
                        help="smallest MAC of matched modes (default 0.9)")
    parser.add_argument("--plot", metavar="FIG", help="overlay plot (.png/.pdf/.svg)")
    parser.add_argument("-o", "--output", "--out", dest="out", metavar="ERRORS.csv",
                        help="write the error table")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Compare, print the table, write the files; 0 when all pass, else
    :data:`~neweul_py.cli.EXIT_CHECK_FAILED` (3)."""
    from ..analysis.compare import compare

    common.check_files(args.out, (".csv",), "error tables", args.plot)
    common.refuse_overwrite(args.out, {"RESULT": args.result, "REFERENCE": args.reference})
    rtol = {"*": 1e-3, **dict(args.rtol)}
    atol = {"*": 1e-12, **dict(args.atol)}
    cmp = compare(args.result, args.reference, signals=args.signals, rtol=rtol, atol=atol,
                  mac_min=args.mac)
    print(cmp.table())
    failed = cmp.failed
    print(f"{cmp.kind}: {len(cmp.errors) - len(failed)} of {len(cmp.errors)} signals within "
          f"tolerance" + (f"; FAILED: {', '.join(failed)}" if failed else ""))
    if args.out:
        print(f"errors: {cmp.to_csv(args.out)}")
    if args.plot:
        print(f"plot: {cmp.plot(args.plot)}")
    return 0 if cmp.passed else EXIT_CHECK_FAILED
