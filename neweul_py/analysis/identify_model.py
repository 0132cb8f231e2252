"""The residuals of a parameter fit and their analytic Jacobian (docs/sensitivity.md §7).

The fitted parameters are the coordinates ``θ`` of the least-squares problem: ``θ = ln p``
(log scale) or ``θ = p``. For a frequency response the residuals are the real and imaginary
parts of ``ln(H_model/H_data)`` — the log-magnitude error and the phase error in radians, the
latter weighted by ``phase_weight`` — so that every frequency counts alike whatever the
magnitude; their Jacobian is ``p ∂ln H/∂p = p ∂H/∂p / H``
(:func:`~neweul_py.analysis.sensitivity.frequency_response_sensitivity`). For a time history
they are ``(x_model − x_data)/s`` per signal, ``s`` the signal's RMS in the data, with the
forward sensitivities of :func:`~neweul_py.analysis.sensitivity_time.simulate_sensitivity` as
Jacobian. A row's weight ``w`` multiplies its squared residuals.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import NeweulError
from . import protocol as proto
from .equilibrium import equilibrium
from .identify_data import FrequencyData, TimeData
from .linearize import linearize
from .module import GeneratedModel
from .sensitivity import linear_model_derivatives
from .sensitivity_response import frequency_response_sensitivity
from .sensitivity_time import simulate_sensitivity

__all__ = ["FitProblem", "Residuals", "column_index"]


@dataclass(frozen=True)
class FitProblem:
    """What a fit needs besides the module: picklable, so that Dask workers get it whole.

    Attributes
    ----------
    names : tuple of str
        The fitted parameters.
    log : tuple of bool
        Per parameter: fitted as ``ln p``.
    lower, upper : ndarray (k,)
        Bounds in ``θ``.
    p : ndarray
        The parameter vector the fitted values are put into (the others stay).
    data : FrequencyData or TimeData
    options : dict
        ``at`` (``"equilibrium"``/``"initial"``), ``u``, ``fixed``, ``start``, ``damping``,
        ``phase_weight`` (frequency responses); ``t_end``, ``method``, ``rtol``, ``atol``, ``u``
        (time histories).
    """

    names: tuple[str, ...]
    log: tuple[bool, ...]
    lower: np.ndarray
    upper: np.ndarray
    p: np.ndarray
    data: FrequencyData | TimeData
    options: dict[str, Any] = field(default_factory=dict)

    def parameters(self, module: GeneratedModel, theta: np.ndarray) -> np.ndarray:
        """The full parameter vector at ``θ``."""
        p = self.p.copy()
        idx = [list(module.PARAMETERS).index(n) for n in self.names]
        p[idx] = [np.exp(v) if lg else v for v, lg in zip(theta, self.log, strict=True)]
        return p

    def values(self, theta: np.ndarray) -> np.ndarray:
        """The fitted parameters' values at ``θ``."""
        return np.array([np.exp(v) if lg else v for v, lg in zip(theta, self.log,
                                                                 strict=True)])

    def counted_residuals(self) -> int:
        """The residuals that carry weight: a data row of weight zero, and the phase rows
        with ``phase_weight`` zero, give residuals that are identically zero, not data."""
        rows = int(np.count_nonzero(self.data.weight))
        if isinstance(self.data, FrequencyData):
            return rows * (2 if self.options.get("phase_weight", 1.0) else 1)
        return rows * len(self.data.columns)


class Residuals:
    """The residuals and Jacobian of a :class:`FitProblem` at ``θ``, evaluated together and
    kept for the last ``θ`` (least squares asks for both at one point)."""

    def __init__(self, module: GeneratedModel, problem: FitProblem) -> None:
        self.module = module
        self.problem = problem
        self._last: tuple[bytes, np.ndarray, np.ndarray, Any] | None = None
        self.evaluations = 0

    def evaluate(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, Any]:
        """``(r, ∂r/∂θ, model)``: the residuals, their Jacobian and the model's curve."""
        theta = np.asarray(theta, dtype=float)
        key = theta.tobytes()
        if self._last is not None and self._last[0] == key:
            return self._last[1], self._last[2], self._last[3]
        self.evaluations += 1
        pb = self.problem
        p = pb.parameters(self.module, theta)
        if isinstance(pb.data, FrequencyData):
            r, J, curve = self._frequency(p)
        else:
            r, J, curve = self._time(p)
        # ∂/∂ln p (what the sensitivities give) → ∂/∂θ
        values = pb.values(theta)
        scale = np.array([1.0 if lg else 1.0 / v for v, lg in zip(values, pb.log, strict=True)])
        J = J * scale[None, :]
        self._last = (key, r, J, curve)
        return r, J, curve

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        return self.evaluate(theta)[0]

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        return self.evaluate(theta)[1]

    def _frequency(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, Any]:
        pb, mod, opt = self.problem, self.module, self.problem.options
        data: FrequencyData = pb.data  # type: ignore[assignment]
        if opt.get("at", "equilibrium") == "equilibrium":
            eq = equilibrium(mod, p=p, u=opt.get("u"), y0=opt.get("start"),
                             fixed=opt.get("fixed", ()))
            lin = linearize(mod, eq, p=p, u0=eq.u)
        else:
            lin = linearize(mod, None, None, opt.get("u"), p)
        ders, _ = linear_model_derivatives(
            mod, lin, list(pb.names), equilibrium_point=opt.get("at", "equilibrium")
            == "equilibrium", fixed=opt.get("fixed", ()), u=opt.get("u"),
            start=opt.get("start"))
        res = frequency_response_sensitivity(lin, ders, data.frequency_hz, [data.input],
                                             [data.response],
                                             damping=opt.get("damping", "loss"))
        H = res.H[:, 0, 0]
        if not np.all(np.isfinite(H)) or np.any(H == 0):
            raise NeweulError("the model's frequency response vanishes or is not finite at "
                              "a data frequency")
        rel = res.relative[:, :, 0, 0].T                       # (nf, k): ∂ln H/∂ln p
        err = np.log(H / data.H)
        w = np.sqrt(data.weight)
        wp = float(opt.get("phase_weight", 1.0))
        r = np.concatenate([w * err.real, wp * w * err.imag])
        J = np.vstack([w[:, None] * rel.real, wp * w[:, None] * rel.imag])
        return r, J, H

    def _time(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, Any]:
        pb, mod, opt = self.problem, self.module, self.problem.options
        data: TimeData = pb.data  # type: ignore[assignment]
        res = simulate_sensitivity(mod, opt["t_end"], list(pb.names), p=p, u=opt.get("u"),
                                   method=opt.get("method", "RK45"),
                                   rtol=opt.get("rtol", 1e-8), atol=opt.get("atol", 1e-10),
                                   t_eval=data.t)
        table = np.hstack([res.result.y, res.result.yd, res.result.outputs])
        dtable = np.concatenate([res.dx_dp, res.dout_dp], axis=1) * res.values[None, None, :]
        where = column_index(mod, list(data.columns))
        w = np.sqrt(data.weight)
        rs, Js, curve = [], [], {}
        for name, j in where.items():
            measured = data.columns[name]
            s = float(np.sqrt(np.mean(measured**2))) or 1.0
            rs.append(w * (table[:, j] - measured) / s)
            Js.append(w[:, None] * dtable[:, j, :] / s)
            curve[name] = table[:, j]
        return np.concatenate(rs), np.vstack(Js), curve


def column_index(module: GeneratedModel, names: Sequence[str]) -> dict[str, int]:
    """Column of each signal name in ``[y, ẏ, outputs]`` (coordinates, ``d_<coordinate>``,
    outputs; one error listing the valid names otherwise)."""
    coords = list(module.COORDINATES)
    valid = [*coords, *(f"d_{c}" for c in coords), *list(module.OUTPUTS)]
    return {nm: proto.name_index(valid, nm, "signal") for nm in names}
