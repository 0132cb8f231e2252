"""Shared arguments of the analysis sub-commands (simulate, equilibrium, linearize, modes, frf).

FILE is a YAML description (generated into the cache first, or reused when unchanged) or an
already generated module ``.py`` (then no symbolic layer, no sympy, is imported). Result and plot
file names are checked before anything is computed (:func:`check_files`).
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from ..analysis.dae import consistent_initial_state
from ..analysis.equilibrium import equilibrium
from ..analysis.module import load_generated
from ..analysis.plot import check_plot_path
from ..analysis.results import check_output_path
from ..errors import NeweulError
from . import BACKENDS, FORMS


def assignment(text: str) -> tuple[str, float]:
    """``NAME=NUMBER`` → ``(name, value)`` (an argparse type)."""
    name, sep, value = text.partition("=")
    try:
        if not sep or not name.strip():
            raise ValueError
        return name.strip(), float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NAME=NUMBER, got {text!r}") from None


def add_model_arguments(parser: argparse.ArgumentParser, operating_point: bool = True) -> None:
    """FILE, --form, -p NAME=VALUE, -u NAME=VALUE, and (optionally) --at / --independent."""
    parser.add_argument("file", metavar="FILE", help="YAML description or generated module .py")
    parser.add_argument("--form", choices=FORMS, default="auto",
                        help="closed-form or recursive equations (default: auto)")
    parser.add_argument("--backend", choices=BACKENDS, default="numpy",
                        help="module of a description: NumPy or compiled C (cffi)")
    parser.add_argument("-p", "--param", type=assignment, action="append", default=[],
                        metavar="NAME=VALUE", help="override a parameter (repeatable)")
    parser.add_argument("-u", "--set-input", type=assignment, action="append", default=[],
                        metavar="NAME=VALUE",
                        help="hold an input at a value (repeatable; default: excitation at t=0)")
    parser.add_argument("--start", type=assignment, action="append", default=[],
                        metavar="COORD=VALUE",
                        help="start the equilibrium search here instead of the initial state "
                        "(repeatable)")
    parser.add_argument("--fix", action="append", default=[], metavar="COORD",
                        help="hold a coordinate at its initial value in the equilibrium search "
                        "(repeatable)")
    if operating_point:
        parser.add_argument("--at", choices=("equilibrium", "initial"), default="equilibrium",
                            help="operating point: static equilibrium (default) or the initial "
                            "state of the model")
        add_independent_argument(parser, "constrained models: the minimal coordinates "
                                 "(default: the first coordinates the constraints leave free)")


def add_independent_argument(parser: argparse.ArgumentParser, text: str) -> None:
    """``--independent NAME [NAME ...]`` (also repeatable), collected into one list."""
    parser.add_argument("--independent", nargs="+", action="extend", default=None,
                        metavar="NAME", help=text)


def check_files(
    output: str | None = None,
    suffixes: tuple[str, ...] = (),
    what: str = "results",
    plot: str | None = None,
) -> None:
    """Check ``-o`` (its suffix one of ``suffixes``) and ``--plot`` (matplotlib installed, a
    format it writes) before any computation, so that a typo fails at once."""
    if output:
        check_output_path(output, suffixes, what)
    if plot:
        check_plot_path(plot)


def load_model(args: argparse.Namespace) -> Any:
    """The generated module of ``args.file``."""
    if args.file.endswith(".py"):
        return load_generated(args.file)
    from ..api import generated_module  # the symbolic layers, only for a description

    return load_generated(generated_module(args.file, args.form,
                                           backend=getattr(args, "backend", "numpy")))


def parameters(args: argparse.Namespace) -> dict[str, float] | None:
    """``-p`` overrides as a mapping (None without any)."""
    return dict(args.param) or None


def inputs(args: argparse.Namespace) -> dict[str, float] | None:
    """``-u`` overrides as a mapping (None without any)."""
    return dict(args.set_input) or None


def start(args: argparse.Namespace) -> dict[str, float] | None:
    """``--start`` coordinates as a mapping (None without any)."""
    return dict(args.start) or None


def linearize_kwargs(module: Any, args: argparse.Namespace) -> dict[str, Any]:
    """Keyword arguments of :func:`~neweul_py.analysis.linearize.linearize` for ``--at``."""
    p, u = parameters(args), inputs(args)
    kw: dict[str, Any] = {"independent": args.independent}
    if args.at == "equilibrium":
        eq = equilibrium(module, p=p, u=u, y0=start(args), fixed=args.fix)
        kw.update(y0=eq, p=eq.p, u0=eq.u)
        return kw
    n = len(module.COORDINATES)
    x0 = np.asarray(module.INITIAL_STATE, dtype=float)
    y0, yd0 = x0[:n], x0[n : 2 * n]
    if module.CONSTRAINTS:
        if np.any(yd0):
            raise NeweulError(
                "--at initial: the initial state moves (ẏ0 ≠ 0); constrained models are "
                "linearized about rest points — use --at equilibrium"
            )
        y0, yd0 = consistent_initial_state(module, y0, yd0, p, independent=args.independent)
    kw.update(y0=y0, yd0=yd0, p=p, u0=u)
    return kw
