"""Parameter sweeps on Dask: ``neweul_py.sweep.sweep(model, cases, task, ...)``.

The engine lives in :mod:`neweul_py.analysis.sweep` (generated modules only, no sympy); this
module adds what a script wants at the top level: a description file (``.yaml``) is generated
(cached) first, as ``neweul sweep FILE`` does.

Examples
--------
>>> from neweul_py.sweep import grid, sweep
>>> res = sweep("examples/pendulum.yaml", grid({"l": [0.5, 1.0, 2.0]}), "modes")  # doctest: +SKIP
>>> res.to_dataframe()                                                            # doctest: +SKIP
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from types import ModuleType
from typing import Any

from .analysis.sweep import SUFFIXES, SweepResult, check_sweep_output, connect
from .analysis.sweep import sweep as sweep_module
from .analysis.sweep_cases import grid, parse_parameter, parse_values, product, read_cases

__all__ = [
    "SUFFIXES",
    "SweepResult",
    "check_sweep_output",
    "connect",
    "grid",
    "parse_parameter",
    "parse_values",
    "product",
    "read_cases",
    "sweep",
]


def sweep(
    model: ModuleType | str | os.PathLike[str],
    cases: Sequence[Mapping[str, float]],
    task: Any = "simulate",
    *,
    form: str = "auto",
    **kwargs: Any,
) -> SweepResult:
    """:func:`neweul_py.analysis.sweep.sweep` of a generated module, or of a description file
    (``.yaml``/``.yml``, generated into the cache first with ``form``)."""
    if isinstance(model, str | os.PathLike) and os.fspath(model).lower().endswith(
            (".yaml", ".yml")):
        from .api import generated_module

        model = generated_module(model, form)  # type: ignore[arg-type]
    return sweep_module(model, cases, task, **kwargs)
