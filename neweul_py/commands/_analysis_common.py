"""Shared arguments of the analysis sub-commands (equilibrium, linearize, modes, frf).

FILE is a YAML description (generated into the cache first, or reused when unchanged) or an
already generated module ``.py``.
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from ..analysis.dae import consistent_initial_state
from ..analysis.equilibrium import equilibrium
from ..analysis.module import load_generated
from ..api import FORMS, generated_module
from ..errors import NeweulError


def _assignment(text: str) -> tuple[str, float]:
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
    parser.add_argument("-p", "--param", type=_assignment, action="append", default=[],
                        metavar="NAME=VALUE", help="override a parameter (repeatable)")
    parser.add_argument("-u", "--set-input", type=_assignment, action="append", default=[],
                        metavar="NAME=VALUE",
                        help="hold an input at a value (repeatable; default: excitation at t=0)")
    parser.add_argument("--start", type=_assignment, action="append", default=[],
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
        parser.add_argument("--independent", action="append", default=None, metavar="COORD",
                            help="constrained models: a minimal coordinate (repeatable; default: "
                            "the first coordinates the constraints leave free)")


def load_model(args: argparse.Namespace) -> Any:
    """The generated module of ``args.file``."""
    if args.file.endswith(".py"):
        return load_generated(args.file)
    return load_generated(generated_module(args.file, args.form))


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
