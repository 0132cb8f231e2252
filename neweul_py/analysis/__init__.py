"""Analysis layer (see DESIGN.md): works on generated modules through the protocol of
docs/generated-module-protocol.md; never imports sympy or the symbolic layers.

``simulate(module, t_end, ...)`` integrates a generated module (or the path of one) and returns a
:class:`SimulationResult`; ``load_generated(path)`` imports and checks a generated module.
"""

from .module import load_generated
from .results import SimulationResult, load_npz
from .simulate import simulate

__all__ = ["SimulationResult", "load_generated", "load_npz", "simulate"]
