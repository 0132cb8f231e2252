"""The ``neweul`` command: a thin layer over the Python API.

Each sub-command lives in its own module under :mod:`neweul_py.commands` and exposes
``register(subparsers)``, which adds its parser and sets ``func`` (called with the parsed
arguments, returning an exit code). The CLI catches :class:`~neweul_py.errors.NeweulError` and
:class:`OSError` (a file that cannot be written: disk full, permissions) and prints one line; any
other exception is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import importlib
import re
import sys
from collections.abc import Sequence

from .errors import NeweulError

#: Modules of :mod:`neweul_py.commands` that provide sub-commands, in help order.
COMMAND_MODULES: tuple[str, ...] = (
    "generate",
    "simulate",
    "equilibrium",
    "linearize",
    "modes",
    "frf",
    "reduce",
    "compare_frf",
    "frf_body",
    "interpolate",
    "fem",
    "sweep", "compare",
)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every available sub-command registered."""
    parser = argparse.ArgumentParser(
        prog="neweul",
        description="Equations of motion of elastic multibody systems: generate, simulate, "
        "analyse, reduce.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(f"neweul_py.commands.{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"neweul_py.commands.{name}":
                continue  # command not built yet
            raise
        module.register(sub)
    _accept_negative_lists(parser)
    return parser


#: Words that are values, not options: ``-4000``, ``-4000:4000:9``, ``-4000,0,4000``, ``-1e-3``.
_NEGATIVE_VALUE = re.compile(r"^-\d[\d.:,eE+-]*$")


def _accept_negative_lists(parser: argparse.ArgumentParser) -> None:
    """Let every (sub-)parser take negative number lists and ranges as option values
    (``--values -4000,0,4000``): argparse by itself only accepts plain ``-4000``-like words."""
    parser._negative_number_matcher = _NEGATIVE_VALUE
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                _accept_negative_lists(child)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``neweul`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except NeweulError as exc:
        print(f"neweul {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:
        name = exc.filename2 or exc.filename  # os.replace: the target is filename2
        where = f"{name}: " if name else ""
        print(f"neweul {args.command}: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"neweul {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
