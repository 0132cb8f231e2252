"""Parameter values a model admits: the one check of every new parameter vector.

A description refuses a negative mass, an inertia that is not positive semidefinite, a
negative rest length or loss factor, and a default outside a parameter's declared range
(docs/description-format.md). The same model given other values — ``neweul simulate -p``,
``equilibrium``/``linearize``/``modes``/``frf -p``, every case of ``neweul sweep`` — must obey
the same rules, checked on the generated module alone (no sympy) by
:func:`check_parameters`:

* every value finite, of magnitude at most :data:`MAX_MAGNITUDE` (the rule of every number
  on the command line);
* within ``PARAMETER_RANGES`` (the declared ranges, and ``≥ 0`` for a parameter that is a
  rest length);
* the mass matrix at the initial state finite and (symmetric models) positive semidefinite —
  no negative mass or inertia, whatever expression it comes from;
* the hysteretic matrix ``G`` at the initial state positive semidefinite (no negative loss
  factor; docs/equations.md §1.1).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import NeweulError
from .module import GeneratedModel, ModelLike, as_model

__all__ = ["MAX_MAGNITUDE", "check_parameters", "describe_values"]

#: Largest magnitude of a parameter value: products of two such numbers stay finite in double
#: precision (= ``neweul_py.commands.MAX_MAGNITUDE``, the rule of command-line numbers).
MAX_MAGNITUDE = 1e150


def describe_values(names: Sequence[str], values: Sequence[float]) -> str:
    """``m = -1, l = 2`` (the values a message is about)."""
    return ", ".join(f"{n} = {float(v):g}" for n, v in zip(names, values, strict=True))


def _range_text(lo: float | None, hi: float | None) -> str:
    if lo is not None and hi is not None:
        return f"{lo:g} … {hi:g}"
    return f"≥ {lo:g}" if lo is not None else f"≤ {hi:g}"


def check_parameters(module: ModelLike, p: np.ndarray, given: str = "") -> None:
    """Refuse a parameter vector ``p`` (ordered as ``module.PARAMETERS``) that the model's
    description would refuse (see the module docstring).

    Parameters
    ----------
    module
        A generated module.
    p
        The full parameter vector.
    given
        What was given, for the message (``"m = -1"``, ``"sweep case 3 (m = -1)"``); default:
        the whole vector.

    Raises
    ------
    NeweulError
        One line: what was given and which rule it breaks.
    """
    module = as_model(module)
    names = list(module.PARAMETERS)
    p = np.asarray(p, dtype=float).reshape(-1)
    what = given or describe_values(names, p)
    for name, v in zip(names, p, strict=True):
        if not np.isfinite(v):
            raise NeweulError(f"with {what}: {name} must be a finite number")
        if abs(v) > MAX_MAGNITUDE:
            raise NeweulError(f"with {what}: {name} = {v:g} is out of range "
                              f"(|value| ≤ {MAX_MAGNITUDE:g})")
    for name, (lo, hi) in module.PARAMETER_RANGES.items():
        v = p[names.index(name)]
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            raise NeweulError(f"with {what}: {name} = {v:g} is outside its range "
                              f"{_range_text(lo, hi)} (the description's)")
    x0 = np.asarray(module.INITIAL_STATE, dtype=float)
    n = len(module.COORDINATES)
    with np.errstate(all="ignore"):
        try:
            m = np.asarray(module.mass_matrix(0.0, x0[:n], p), dtype=float)
        except ValueError as exc:     # e.g. a schedule value outside a body's sampled range
            raise NeweulError(f"with {what}: {exc}") from None
        except (ArithmeticError, np.linalg.LinAlgError):
            m = np.full((1, 1), np.nan)
    if not np.all(np.isfinite(m)):
        raise NeweulError(f"with {what} the mass matrix at the initial state is not finite")
    if module.MASS_MATRIX_SYMMETRIC and m.size:
        lo = float(np.linalg.eigvalsh(0.5 * (m + m.T))[0])
        if lo < -1e-12 * (float(np.abs(m).max()) or 1.0):
            raise NeweulError(
                f"with {what} the mass matrix at the initial state is not positive "
                f"semidefinite (smallest eigenvalue {lo:.3g}): a negative mass or inertia, "
                "which a description refuses"
            )
    _check_loss_matrix(module, x0, p, what)


def _check_loss_matrix(module: GeneratedModel, x0: np.ndarray, p: np.ndarray,
                       what: str) -> None:
    """Symmetric models: the hysteretic matrix ``G`` at the initial state must be positive
    semidefinite, as every ``loss_factor ≥ 0`` makes it (docs/equations.md §1.1)."""
    loss = module.loss_matrix
    if loss is None or not module.MASS_MATRIX_SYMMETRIC:
        return
    with np.errstate(all="ignore"):
        g = np.asarray(loss(0.0, x0, p), dtype=float)
    if g.size and np.all(np.isfinite(g)):
        lo = float(np.linalg.eigvalsh(0.5 * (g + g.T))[0])
        if lo < -1e-12 * (float(np.abs(g).max()) or 1.0):
            raise NeweulError(f"with {what} the loss matrix G at the initial state is not "
                              f"positive semidefinite (smallest eigenvalue {lo:.3g}): a "
                              "negative loss factor, which a description refuses")
