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
3-D. Every result has ``to_dataframe()``, ``save(path)`` and a short
``repr`` with a notebook display.
"""

from .animate import animate
from .compare import Comparison, compare
from .dae import ConstrainedSimulation, consistent_initial_state, simulate_constrained
from .equilibrium import EquilibriumResult, equilibrium
from .frf import FrequencyResponse, frequency_response, frequency_vector, frf
from .linearize import LinearModel, linearize
from .modes import ModalResult, modes
from .module import GeneratedModel, as_model, check_protocol, load_generated
from .plot import plot_result
from .results import SimulationResult, load_npz, read_units
from .simulate import METHODS, simulate
from .sweep import SweepResult, sweep
from .sweep_cases import grid, read_cases

__all__ = [
    "METHODS",
    "Comparison",
    "ConstrainedSimulation",
    "EquilibriumResult",
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
    "frequency_response",
    "frequency_vector",
    "frf",
    "grid",
    "linearize",
    "load_generated",
    "load_npz",
    "modes",
    "plot_result",
    "read_cases",
    "read_units",
    "simulate",
    "simulate_constrained",
    "sweep",
]
