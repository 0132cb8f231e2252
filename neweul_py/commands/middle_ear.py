"""``neweul middle-ear build|study``: the flagship application in two commands.

``build --dir DIR [--refine L]`` makes the middle-ear EMBS from nothing (FE sweep → reduction
→ interpolation → description ``DIR/middle_ear.yaml`` → generated module), with progress;
``study --dir DIR`` writes the studies' tables and plots of a build
(docs/equations-middle-ear.md). Both are thin layers over :mod:`neweul_py.middle_ear`.
"""

from __future__ import annotations

import argparse
import functools
from pathlib import Path

from ..progress import QUIET_HELP, Tracker
from . import CAPS, count, number, range_type


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``middle-ear`` with its sub-commands ``build`` and ``study``."""
    parser = subparsers.add_parser(
        "middle-ear", help="the middle-ear EMBS: build it from nothing, study it",
        description="The flagship application: the nonlinear middle ear (ossicles on the "
        "parametric TM + ear-canal + tympanic-cavity body scheduled by the static pressure "
        "difference dp).")
    sub = parser.add_subparsers(dest="middle_ear_command", metavar="{build,study}",
                                required=True)
    b = sub.add_parser(
        "build", help="FE sweep → reduction → parametric body → description → module",
        description="Build the middle-ear EMBS into DIR (atomically: an interrupted build leaves "
        "the previous complete DIR or none; FE working points of a previous build of the same "
        "refinement are reused).")
    b.add_argument("--dir", type=Path, required=True, help="the build directory")
    b.add_argument("--refine", type=count("--refine", minimum=0), default=1,
                   help="mesh refinement of the FE model (default 1)")
    b.add_argument("--pressures", type=range_type("--pressures"),
                   default=None, metavar="START:STOP:N",
                   help="working points of the FE sweep [Pa] (default -4000:4000:9)")
    b.add_argument("--tol", type=functools.partial(number, option="--tol", minimum=0.0),
                   default=3e-4,
                   help="refinement tolerance of the interpolation (default 3e-4; 0: none)")
    b.add_argument("--coordinate", choices=("volume", "dp"), default="volume",
                   help="the variable of the interpolation weights (default: the TM's static "
                   "volume displacement)")
    b.add_argument("--slope-step",
                   type=functools.partial(number, option="--slope-step", minimum=0.0),
                   default=20.0, metavar="PA",
                   help="slopes and curvatures from FE models at every working point ∓ PA "
                   "(default 20; 0: cubic weights through the values alone)")
    b.add_argument("--interpolation", choices=("quintic-hermite", "hermite"),
                   default="quintic-hermite", help="Hermite weights (default quintic)")
    b.add_argument("--order", type=count("--order", cap=100_000),
                   default=None, help="cap on the number of basis directions")
    b.add_argument("--no-generate", action="store_true", help="skip the generated module")
    b.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    b.set_defaults(func=_build)
    s = sub.add_parser("study", help="static and dynamic studies of a build vs Δp",
                       description="Tables (results.md, frf.csv) and plots of a build: the "
                       "static state vs dp, the transfer functions at the sampled pressures, "
                       "the low-frequency change against Gyo & Goode 1987.")
    s.add_argument("--dir", type=Path, required=True, help="a build of neweul middle-ear build")
    s.add_argument("--out", type=Path, default=None, help="output directory (default DIR/study)")
    s.add_argument("--nf", type=count("--nf", minimum=2, cap=CAPS["--f"]),
                   default=80, help="log-spaced frequencies 100 Hz–8 kHz (default 80)")
    s.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    s.set_defaults(func=_study)


def _build(args: argparse.Namespace) -> int:
    from ..middle_ear.build import BuildOptions, build

    options = BuildOptions(
        refine=args.refine, tol=args.tol, coordinate=args.coordinate,
        slope_step=args.slope_step, interpolation=args.interpolation, order=args.order,
        generate=not args.no_generate,
        **({"pressures": tuple(args.pressures.values())} if args.pressures else {}))
    with Tracker("middle-ear build", quiet=args.quiet) as track:
        record = build(args.dir, options, progress=track)
    print(f"wrote {args.dir}: body of order {record['order']} at {len(record['samples_Pa'])} "
          f"working points, {record['description']}"
          + (f", {record['module']}" if record["module"] else "")
          + f" ({record['seconds']:.0f} s)")
    return 0


def _study(args: argparse.Namespace) -> int:
    from ..middle_ear.study import study

    out = args.out or args.dir / "study"
    with Tracker("middle-ear study", quiet=args.quiet) as track:
        files = study(args.dir, out, nf=args.nf, progress=track)
    print(f"wrote {', '.join(str(f) for f in files)}")
    return 0
