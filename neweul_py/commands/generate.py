"""``neweul generate FILE [-o DIR] [--form auto|closed|recursive] [--backend numpy|c]
[--sensitivities] [-q] [--no-cache]``."""

from __future__ import annotations

import argparse

from ..progress import QUIET_HELP
from . import BACKENDS, FORMS


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``generate`` sub-command."""
    parser = subparsers.add_parser(
        "generate",
        help="write the NumPy module of a description (DIR/<name>.py)",
        description="Derive the equations of motion of a description file and write the "
        "generated NumPy module DIR/<name>.py (atomically; nothing is written on error).",
    )
    parser.add_argument("file", metavar="FILE", help="YAML description file")
    parser.add_argument("-o", "--output", "--out-dir", dest="out_dir", metavar="DIR",
                        default="generated",
                        help="output directory (default: generated/)")
    parser.add_argument("--form", choices=FORMS, default="auto",
                        help="closed-form or recursive equations (default: auto)")
    parser.add_argument("--backend", choices=BACKENDS, default="numpy",
                        help="c: also compile the module (DIR/<name>_c.py, a C library via cffi)")
    parser.add_argument("--sensitivities", action="store_true",
                        help="also the second derivatives of the linear models' parameter "
                        "sensitivities (docs/sensitivity.md; rigid models)")
    parser.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    parser.add_argument("--no-cache", dest="cache", action="store_false",
                        help="derive even when the content-hash cache (the one of neweul "
                        "simulate) holds the module of this description (NumPy backend)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Generate and print the path written."""
    from ..api import generate  # the symbolic layers, only when generating
    from ..progress import Tracker

    with Tracker(quiet=args.quiet) as track:  # a bar per stage of the derivation on a terminal
        path = generate(args.file, args.out_dir, args.form, args.backend, progress=track,
                        cache=args.cache, sensitivities=args.sensitivities)
    print(path)
    return 0
