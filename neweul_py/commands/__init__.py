"""Sub-commands of the ``neweul`` CLI, one module each (see :mod:`neweul_py.cli`).

Building the parser imports no symbolic layer (sympy), no ``scipy.integrate``, no matplotlib and
no analysis or elastic code: command modules import what they need inside ``run``. This module
holds what every command shares, so that the same thing is spelled and checked the same way
everywhere (docs/cli.md):

* numbers from the command line go through :func:`number` (finite, sign, range — the checks a
  description applies to its numbers), ``NAME=VALUE`` through :func:`assignment`;
* one range syntax, ``START:STOP:N`` (``N`` points, both ends included) or a comma list,
  parsed by :func:`parse_range` for ``--f``, ``--pressures`` …, with a cap on ``N``;
* counts through :func:`count` with a documented cap (:data:`CAPS`, docs/limits.md).

Every checker raises :class:`argparse.ArgumentTypeError` (argparse prints it as one usage
line naming the option) or, called outside argparse, :class:`~neweul_py.errors.NeweulError`.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from dataclasses import dataclass

__all__ = [
    "CAPS",
    "EXIT_CHECK_FAILED",
    "FORMS",
    "MAX_MAGNITUDE",
    "SIMULATE_METHODS",
    "SWEEP_STATS",
    "SWEEP_TASKS",
    "Range",
    "assignment",
    "comma_floats",
    "count",
    "interval",
    "number",
    "parse_range",
    "range_type",
    "values_type",
]

#: Forms of the equations offered by ``--form``; the same as :data:`neweul_py.api.FORMS` (kept
#: here so that registering the sub-commands needs no symbolic layer; a test checks they agree).
FORMS: tuple[str, ...] = ("auto", "closed", "recursive")
#: Backends offered by ``--backend``; the same as :data:`neweul_py.api.BACKENDS`.
BACKENDS: tuple[str, ...] = ("numpy", "c")

#: Integrators of ``simulate --method``; the same as
#: :data:`neweul_py.analysis.simulate.METHODS` (a test checks they agree).
SIMULATE_METHODS: tuple[str, ...] = ("RK45", "DOP853", "RK23", "Radau", "BDF", "LSODA",
                                     "generalized-alpha", "c-dopri5")

#: ``sweep --task`` choices and ``--stats`` names; the same as
#: :data:`neweul_py.analysis.sweep_tasks.TASKS` and ``STATS`` (a test checks they agree).
SWEEP_TASKS: tuple[str, ...] = ("simulate", "equilibrium", "modes", "frf")
SWEEP_STATS: tuple[str, ...] = ("final", "max", "min", "rms")

#: Exit code of a command whose check ran and failed (``compare`` beyond its tolerances,
#: ``sweep`` with failed cases): 0 success, 1 an error of the input or the model, 2 a malformed
#: command line (argparse), 3 this (docs/cli.md).
EXIT_CHECK_FAILED = 3

#: Largest magnitude of a number given on the command line (parameters, inputs, coordinates,
#: frequencies …): products of two such numbers stay finite in double precision.
MAX_MAGNITUDE = 1e150

#: Caps of requested work (docs/limits.md): option → largest accepted value.
CAPS: dict[str, int] = {
    "--n-out": 10_000_000,      # output times of simulate (80 MB per state)
    "--f": 1_000_000,           # frequencies of frf / compare-frf
    "--pressures": 1_000,       # working points of fem middle-ear
    "--refine": 3,              # mesh refinement of fem middle-ear (4x the DOFs per level)
    "--order": 200,             # Krylov moments per point and input
    "--modes": 10_000,          # modes of reduce --method modal
    "--points": 1_000,          # Krylov expansion points
    "--max-steps": 10**9,       # integrator steps of simulate
    "--frames": 10_000,         # pictures of simulate --animate (≈ 0.1 s each)
    "--workers": 256,           # processes of sweep's local cluster (analysis.sweep.MAX_WORKERS)
}


def _fail(message: str) -> argparse.ArgumentTypeError:
    return argparse.ArgumentTypeError(message)


def number(text: str, option: str = "value", *, minimum: float | None = None,
           positive: bool = False, maximum: float | None = None) -> float:
    """A finite number of magnitude at most :data:`MAX_MAGNITUDE` (and ≥ ``minimum``, > 0
    with ``positive``, ≤ ``maximum``).

    Raises
    ------
    argparse.ArgumentTypeError
        Naming ``option`` and the rule broken (``nan``, ``inf``, ``1e308``, ``-1`` …).
    """
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise _fail(f"{option}: expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise _fail(f"{option}: must be a finite number, got {text!r}")
    if abs(value) > MAX_MAGNITUDE:
        raise _fail(f"{option}: {value:g} is out of range (|value| ≤ {MAX_MAGNITUDE:g})")
    if positive and value <= 0:
        raise _fail(f"{option}: must be positive, got {value:g}")
    if minimum is not None and value < minimum:
        raise _fail(f"{option}: must be ≥ {minimum:g}, got {value:g}")
    if maximum is not None and value > maximum:
        raise _fail(f"{option}: must be ≤ {maximum:g}, got {value:g}")
    return value


def count(option: str, *, minimum: int = 1, cap: int | None = None) -> Callable[[str], int]:
    """Argument type of an integer count in ``minimum … cap`` (default ``CAPS[option]``)."""
    limit = CAPS.get(option) if cap is None else cap

    def parse(text: str) -> int:
        try:
            value = float(text)
            if not value.is_integer():
                raise ValueError
        except (TypeError, ValueError, OverflowError):
            raise _fail(f"{option}: expected a whole number, got {text!r}") from None
        if value < minimum:
            raise _fail(f"{option}: must be at least {minimum}, got {text}")
        if limit is not None and value > limit:
            raise _fail(f"{option}: {text} exceeds the cap of {limit} (docs/limits.md)")
        return int(value)

    parse.__name__ = "count"
    return parse


def assignment(text: str, option: str = "-p/-u") -> tuple[str, float]:
    """``NAME=NUMBER`` → ``(name, value)`` (an argparse type); the number as :func:`number`."""
    name, sep, value = text.partition("=")
    if not sep or not name.strip():
        raise _fail(f"{option}: expected NAME=NUMBER, got {text!r}")
    return name.strip(), number(value, name.strip())


def comma_floats(text: str, option: str = "list") -> list[float]:
    """Argument type of comma-separated numbers (``--points 100,200``, ``--values -4000,0``),
    each as :func:`number`."""
    items = [x for x in text.split(",") if x.strip()]
    if not items:
        raise _fail(f"{option}: expected comma-separated numbers, got {text!r}")
    try:
        return [number(x, option) for x in items]
    except argparse.ArgumentTypeError:
        raise _fail(f"{option}: expected comma-separated finite numbers, got {text!r}") from None


@dataclass(frozen=True)
class Range:
    """A parsed ``START:STOP:N`` range or an explicit list (``values`` set)."""

    start: float
    stop: float
    n: int
    values_given: tuple[float, ...] | None = None
    option: str = "range"

    def values(self, log: bool = False) -> list[float]:
        """The points: explicit values, or ``N`` linearly (or, with ``log``, logarithmically)
        spaced points from START to STOP inclusive."""
        import numpy as np

        if self.values_given is not None:
            return list(self.values_given)
        if log:
            if self.start <= 0:
                from ..errors import NeweulError

                raise NeweulError(f"{self.option}: log-spaced values need a positive start, "
                                  f"got {self.start:g}")
            return [float(v) for v in np.geomspace(self.start, self.stop, self.n)]
        return [float(v) for v in np.linspace(self.start, self.stop, self.n)]


def parse_range(text: str, option: str, *, cap: int | None = None, minimum: float | None = None,
                increasing: bool = True) -> Range:
    """``START:STOP:N`` or ``V1,V2,…`` → :class:`Range`, the one range syntax of every command.

    Numbers are checked as :func:`number` (finite, ≥ ``minimum``), ``N`` (or the length of the
    list) is at most ``cap`` (default ``CAPS[option]``); with ``increasing`` STOP ≥ START.
    """
    limit = CAPS.get(option) if cap is None else cap
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise _fail(f"{option}: expected START:STOP:N or a comma list, got {text!r}")
        start = number(parts[0], f"{option} START", minimum=minimum)
        stop = number(parts[1], f"{option} STOP", minimum=minimum)
        n = count(option, cap=limit)(parts[2])
        if increasing and stop < start:
            raise _fail(f"{option}: STOP ({stop:g}) is below START ({start:g})")
        return Range(start, stop, n, None, option)
    values = tuple(number(v, option, minimum=minimum) for v in text.split(",") if v.strip())
    if not values:
        raise _fail(f"{option}: expected START:STOP:N or a comma list, got {text!r}")
    if limit is not None and len(values) > limit:
        raise _fail(f"{option}: {len(values)} values exceed the cap of {limit} (docs/limits.md)")
    return Range(values[0], values[-1], len(values), values, option)


def range_type(option: str, **kwargs: object) -> Callable[[str], Range]:
    """An argparse type parsing ``option`` with :func:`parse_range`."""

    def parse(text: str) -> Range:
        return parse_range(text, option, **kwargs)  # type: ignore[arg-type]

    parse.__name__ = "range"
    return parse


def values_type(option: str, **kwargs: object) -> Callable[[str], list[float]]:
    """An argparse type giving the points of :func:`parse_range` (a comma list, or
    ``START:STOP:N``) as a list (``interpolate --values``, ``--weights``)."""

    def parse(text: str) -> list[float]:
        return parse_range(text, option, increasing=False, **kwargs).values()  # type: ignore

    parse.__name__ = "values"
    return parse


def interval(option: str, *, minimum: float | None = None,
             maximum: float | None = None) -> Callable[[str], tuple[float, float]]:
    """Argument type of ``LOW:HIGH`` (a band, not a grid): finite numbers, LOW ≤ HIGH."""

    def parse(text: str) -> tuple[float, float]:
        lo, sep, hi = text.partition(":")
        if not sep or ":" in hi:
            raise _fail(f"{option}: expected LOW:HIGH, got {text!r}")
        a = number(lo, f"{option} LOW", minimum=minimum, maximum=maximum)
        b = number(hi, f"{option} HIGH", minimum=minimum, maximum=maximum)
        if b < a:
            raise _fail(f"{option}: HIGH ({b:g}) is below LOW ({a:g})")
        return a, b

    parse.__name__ = "interval"
    return parse
