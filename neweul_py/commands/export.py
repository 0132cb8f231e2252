"""``neweul export FILE --fmu OUT.fmu [--kind me|cs|both] [--form F] [--independent NAME …]
[-q]``: an FMI 2.0 FMU of a description (docs/fmu-export.md)."""

from __future__ import annotations

import argparse

from ..progress import QUIET_HELP
from . import FORMS
from . import common as common

#: ``--kind`` choices (= ``neweul_py.api.FMU_KINDS``; not imported: the CLI starts fast).
FMU_KINDS: tuple[str, ...] = ("me", "cs", "both")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``export`` sub-command."""
    parser = subparsers.add_parser(
        "export",
        help="export a description as an FMI 2.0 FMU (model exchange, co-simulation)",
        description="Write an FMI 2.0 FMU of a description: the compiled equations with the "
        "parameters as tunable parameters, the inputs and outputs, the analytic Jacobian as "
        "directional derivatives, and for co-simulation an embedded Dormand-Prince stepper at "
        "the importer's tolerance; built for this platform with the system C compiler and "
        "written atomically (docs/fmu-export.md).",
    )
    parser.add_argument("file", metavar="FILE", help="YAML description file")
    parser.add_argument("--fmu", required=True, metavar="OUT.fmu", help="the FMU to write")
    parser.add_argument("--kind", choices=FMU_KINDS, default="both",
                        help="model exchange (me), co-simulation (cs) or one FMU with both "
                        "(default)")
    parser.add_argument("--form", choices=FORMS, default="auto",
                        help="closed-form or recursive equations (default: auto)")
    common.add_independent_argument(
        parser, "constrained models: the coordinates that are the FMU's states (default: the "
        "first ones in COORDINATES order the constraints leave free)")
    parser.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Export and print the FMU written."""
    from ..api import export_fmu
    from ..progress import Tracker

    with Tracker(quiet=args.quiet) as track:
        path = export_fmu(args.file, args.fmu, args.kind, form=args.form,
                          independent=args.independent, progress=track)
    print(path)
    return 0
