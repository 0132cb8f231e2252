"""Analysis layer: works on generated modules through the protocol of
docs/generated-module-protocol.md, seen as a typed :class:`GeneratedModel`; never imports sympy
or the symbolic layers.

Everything a script or notebook needs is importable from here::

    from neweul_py.analysis import (load_generated, simulate, equilibrium, linearize, modes,
                                    frequency_response)

``simulate(module, t_end, ...)`` integrates a generated module (or the path of one) and returns a
:class:`SimulationResult`; ``equilibrium`` → :class:`EquilibriumResult`; ``linearize`` →
:class:`LinearModel`; ``modes`` → :class:`ModalResult`; ``frequency_response`` (alias ``frf``)
→ :class:`FrequencyResponse`; ``sweep`` runs any of them over parameter cases on Dask →
:class:`SweepResult`; ``compare(result, reference)`` judges a result against a reference →
:class:`Comparison`; ``animate(result, module, "movie.gif")`` draws the simulated model in
3-D; the parameter sensitivities (``frequency_response_sensitivity``, ``modal_sensitivity``,
``simulate_sensitivity`` …, docs/sensitivity.md) and ``identify`` (``identify_function`` for a
model given as a residual function) → :class:`FitResult` fit
parameters to measurements. Every result has ``to_dataframe()``, ``save(path)`` and a short
``repr`` with a notebook display.
"""

import importlib
import sys
import types
from typing import Any

#: Where each public name lives: imported at its first use (PEP 562), so that ``neweul
#: simulate`` of a cached model imports the integrator, not the FRF, linearization, animation
#: or scipy.optimize code (docs/cli.md, start-up).
_EXPORTS: dict[str, str] = {
    "animate": "animate",
    "Comparison": "compare", "compare": "compare",
    "ConstrainedSimulation": "dae", "consistent_initial_state": "dae",
    "simulate_constrained": "dae",
    "EquilibriumResult": "equilibrium", "equilibrium": "equilibrium",
    "FrequencyResponse": "frf", "frequency_response": "frf", "frequency_vector": "frf",
    "frf": "frf",
    "LinearModel": "linearize", "linearize": "linearize",
    "ModalResult": "modes", "modes": "modes",
    "GeneratedModel": "module", "as_model": "module", "check_protocol": "module",
    "load_generated": "module",
    "plot_result": "plot",
    "SimulationResult": "results", "load_npz": "results", "read_units": "results",
    "METHODS": "simulate", "simulate": "simulate",
    "SweepResult": "sweep", "sweep": "sweep",
    "grid": "sweep_cases", "read_cases": "sweep_cases",
    "Bound": "identify", "FitResult": "identify", "identify": "identify",
    "identify_function": "identify_function",
    "equilibrium_sensitivity": "sensitivity", "linear_model_derivatives": "sensitivity",
    "frequency_response_sensitivity": "sensitivity_response",
    "modal_sensitivity": "sensitivity_response",
    "simulate_sensitivity": "sensitivity_time",
}


class _Package(types.ModuleType):
    """This package's module type: eight submodules share their name with the function they
    export (``linearize``, ``modes``, ``simulate`` …). Importing such a submodule binds its
    name on the package to the submodule; the package keeps the function there instead, as
    ``from .linearize import linearize`` did (``neweul_py.analysis.linearize`` is the
    function, the module is ``sys.modules["neweul_py.analysis.linearize"]``)."""

    def __setattr__(self, name: str, value: Any) -> None:
        if (isinstance(value, types.ModuleType) and _EXPORTS.get(name) == name
                and value.__name__ == f"{__name__}.{name}"):
            value = getattr(value, name)
        super().__setattr__(name, value)


def __getattr__(name: str) -> Any:
    """The public name ``name``, from its module (imported now)."""
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value          # the next lookup is a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})


__all__ = [
    "METHODS",
    "Bound",
    "Comparison",
    "ConstrainedSimulation",
    "EquilibriumResult",
    "FitResult",
    "FrequencyResponse",
    "GeneratedModel",
    "LinearModel",
    "ModalResult",
    "SimulationResult",
    "SweepResult",
    "animate",
    "as_model",
    "check_protocol",
    "compare",
    "consistent_initial_state",
    "equilibrium",
    "equilibrium_sensitivity",
    "frequency_response",
    "frequency_response_sensitivity",
    "frequency_vector",
    "frf",
    "grid",
    "identify",
    "identify_function",
    "linear_model_derivatives",
    "linearize",
    "load_generated",
    "load_npz",
    "modal_sensitivity",
    "modes",
    "plot_result",
    "read_cases",
    "read_units",
    "simulate",
    "simulate_constrained",
    "simulate_sensitivity",
    "sweep",
]

sys.modules[__name__].__class__ = _Package
