"""The pressure sweep: static states and linearized FE models over Δp, written atomically."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sps

from ..elastic.fe_model import FEModel
from ..elastic.io.fe_delta import base_name, check_base
from ..elastic.io.working_point import write_working_point
from ..elastic.reductors.projection import Progress
from ..errors import ModelError
from ..fem.nonlinear import NewtonOptions, StaticState
from ..ffrf.parametric import MAX_KNOTS
from ..progress import report
from .model import MiddleEar, build_middle_ear
from .parameters import MiddleEarParameters
from .static import solve_static, static_summary, tm_displacements
from .working_point import hysteretic_damping, loss_info, static_data, working_point_model

__all__ = ["SweepResult", "curve_pressures", "parse_pressures", "pressure_sweep"]


@dataclass(frozen=True, eq=False)
class SweepResult:
    """The result of :func:`pressure_sweep`: the model, the static states, the table and the
    linearized FE models (one per working point, in the order of ``pressures``)."""

    middle_ear: MiddleEar
    states: tuple[StaticState, ...]
    static: tuple[dict[str, float], ...]
    models: tuple[FEModel, ...]
    out_dir: str | None = None
    damping: tuple[sps.csr_matrix, ...] = ()  # hysteretic G per working point
    static_groups: tuple[dict, ...] = ()  # static_data per working point
    curve: tuple[dict[str, float], ...] = ()  # static_summary on the static curve, if asked


def parse_pressures(text: str) -> list[float]:
    """``"start:stop:count"`` (inclusive, like ``numpy.linspace``) or a comma list, in Pa."""
    try:
        if ":" in text:
            parts = text.split(":")
            if len(parts) != 3:
                raise ValueError
            start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
            if count < 1:
                raise ValueError
            return [float(v) for v in np.linspace(start, stop, count)]
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ModelError(
            f"pressures must be 'start:stop:count' or a comma list of numbers, got {text!r}",
            "pressures",
        ) from None


def curve_pressures(pressures: Sequence[float], step: float) -> list[float]:
    """The pressures of the static curve: every ``step`` Pa from the lowest to the highest
    working point (a multiple of ``step``), the working points themselves included.

    Raises
    ------
    ModelError
        ``step`` not positive, or more than 10 001 points.
    """
    if not (math.isfinite(step) and step > 0):
        raise ModelError(f"the static-curve step must be a positive number of Pa, got {step!r}",
                         "static_curve")
    lo, hi = min(pressures), max(pressures)
    if (hi - lo) / step > MAX_KNOTS - 1:
        raise ModelError(f"a static curve of step {step:g} Pa over [{lo:g}, {hi:g}] would hold "
                         f"more than {MAX_KNOTS} points (the most knots of an interpolation "
                         "coordinate)", "static_curve")
    grid = step * np.arange(math.ceil(lo / step), math.floor(hi / step) + 1)
    return sorted({*map(float, pressures), *map(float, grid)})


def pressure_sweep(
    pressures: Sequence[float],
    params: MiddleEarParameters | None = None,
    refine: int = 2,
    out_dir: str | None = None,
    plots: bool = False,
    include_support: bool = False,
    options: NewtonOptions | None = None,
    verbose: bool = False,
    progress: Progress = None,
    static_curve: float | None = None,
    base: str | os.PathLike | None = None,
) -> SweepResult:
    """Static solutions and linearized ``up-coupled`` FE models over static pressures ``Δp``.

    Parameters
    ----------
    pressures
        Static pressure differences ``Δp = p_canal − p_cavity`` [Pa].
    params, refine
        See :func:`build_middle_ear`.
    out_dir
        If given, write (atomically, see :mod:`neweul_py.middle_ear.output`) ``model_dp±NNNNN.npz``
        per working point (the ``neweul-fe`` file with the optional ``static`` and ``loss``
        groups of :mod:`neweul_py.elastic.io.working_point`; of the working points whose
        matrices store the most entries the one nearest ``Δp = 0`` complete, the others as
        delta files of it, or all as delta files of
        ``base``: docs/fe-file-format.md), ``static.csv``,
        ``static_displacements.npz`` (TM node displacements per working point) and
        ``sweep.json`` (and PNGs with ``plots``).
    plots
        Also draw the mesh, the static deflection at the extreme pressures and the first TM
        modes at ``Δp = 0`` (needs matplotlib).
    include_support
        Keep the ossicular support in the exported ``Ks`` (see :func:`working_point_model`).
    options
        Newton options.
    verbose
        Print the DOF counts and the static results (stdout).
    progress
        Called with a short message per converged load step and per working point (the CLI
        prints them on stderr).
    static_curve
        A step [Pa]: also solve the static state on :func:`curve_pressures` (static solves
        only, no FE models: 81 points over ±4 kPa take ≈ 4 s at refine 1, 21 s at refine 2)
        and write its :func:`static_summary` rows as ``static_curve.csv`` — the table of an
        interpolation coordinate such as the TM's static volume displacement
        (``docs/equations.md`` §4.1, ``neweul interpolate --coordinate``).
    base
        A complete working-point file of the same mesh in a directory next to ``out_dir``
        (e.g. of an earlier sweep of one build): every working point is written as a delta
        file of it, so a build stores the shared matrices once.

    Returns
    -------
    SweepResult

    Raises
    ------
    ModelError
        Bad parameters or pressures; SolverError: a pressure beyond Newton convergence or
        beyond the physical validity of the model (:func:`static_validity`, checked after every
        load step). In either case nothing is written.

    Examples
    --------
    >>> res = pressure_sweep([-4000.0, 0.0, 4000.0], refine=0)
    >>> [m.kind for m in res.models]
    ['up-coupled', 'up-coupled', 'up-coupled']
    >>> res.static[2]["volume_displacement_m3"] > 0  # Δp > 0 pushes the TM medially
    True
    """
    dps = [float(v) for v in pressures]
    if not dps or not all(math.isfinite(v) for v in dps):
        raise ModelError("need at least one finite pressure", "pressures")
    if len(set(dps)) != len(dps):
        raise ModelError("pressures must be distinct", "pressures")
    if plots:
        from .plots import require_matplotlib

        require_matplotlib()
    if out_dir is not None:
        from .output import check_output_dir

        check_output_dir(out_dir)  # fail before the work, checked again when writing
        if base is not None:
            check_base(base, Path(out_dir) / "sweep.json")
    me = build_middle_ear(params, refine, verbose=verbose)
    grid = None if static_curve is None else curve_pressures(dps, float(static_curve))
    states = solve_static(me, dps, options, progress=progress)
    table = tuple(static_summary(me, s) for s in states)
    if verbose:
        for row in table:
            print(
                "  Δp = {:+8.1f} Pa: ΔV = {:+.4g} mm³, umbo u_z = {:+.4g} µm".format(
                    row["dp_Pa"], row["volume_displacement_m3"] * 1e9, row["umbo_uz_m"] * 1e6
                )
            )
    curve: tuple[dict[str, float], ...] = ()
    if grid is not None:
        report(progress, f"static curve: {len(grid)} pressures, every {static_curve:g} Pa")
        curve = tuple(static_summary(me, s) for s in solve_static(me, grid, options))
    models, damping, groups = [], [], []
    for i, s in enumerate(states):
        report(progress, f"working point {i + 1}/{len(states)}: FE model at Δp = {s.load:+g} Pa",
               i + 1, len(states))
        models.append(working_point_model(me, s, include_support))
        damping.append(hysteretic_damping(me, s, include_support))
        groups.append(static_data(me, s))
    if out_dir is not None:
        if progress is not None:
            progress(f"writing {out_dir}")
        _write_sweep(me, states, table, models, damping, groups, out_dir, plots, include_support,
                     curve, base)
    return SweepResult(
        me, tuple(states), table, tuple(models), out_dir, tuple(damping), tuple(groups), curve
    )


def _write_sweep(
    me, states, table, models, damping, groups, out_dir, plots, include_support, curve, base
) -> None:
    from dataclasses import asdict

    from .output import write_directory_atomically, write_static_csv

    p = me.params
    names = [f"model_dp{s.load:+06.0f}.npz" for s in states]
    # the base of the others (unless one is given): of the working points whose matrices
    # store the most entries, the one nearest dp = 0 (at dp = 0 the membrane's stress is
    # zero, and at refine 2 a few entries cancel exactly and are not stored: a base with
    # another pattern would leave the others' matrices whole in their deltas)
    stored = [sum(getattr(fe, k).nnz for k in ("M", "K", "D", "G") if getattr(fe, k, None)
                  is not None) for fe in models]
    first = (min(range(len(states)), key=lambda i: (-stored[i], abs(states[i].load)))
             if base is None else None)
    order = ([first] if first is not None else []) + [
        i for i in range(len(states)) if i != first]

    def fill(tmp):
        files: list[dict | None] = [None] * len(states)
        own = None if first is None else tmp / names[first]
        for i in order:
            s, fe = states[i], models[i]
            # the base is read from its final place; a base of this sweep is still in tmp
            ref = base if first is None else (None if i == first else own)
            write_working_point(fe, tmp / names[i], damping[i], loss_info(p), groups[i], ref)
            files[i] = {"dp_Pa": s.load, "file": names[i], "n_dofs": fe.n_dofs}
        write_static_csv(list(table), tmp / "static.csv")
        if curve:
            write_static_csv(list(curve), tmp / "static_curve.csv")
        disp = np.stack([tm_displacements(me, s) for s in states])
        np.savez(
            tmp / "static_displacements.npz",
            dp_Pa=np.array([s.load for s in states]),
            node_id=np.arange(1, me.tm.points.shape[0] + 1),
            reference=me.tm.points,
            u=disp,
        )
        pictures = []
        if plots:
            from .plots import plot_mesh, plot_static, plot_tm_modes

            pictures.append(plot_mesh(me, tmp / "mesh.png").name)
            loads = [s.load for s in states]
            ext = sorted({int(np.argmin(loads)), int(np.argmax(loads))})
            pictures.append(plot_static(me, [states[i] for i in ext], tmp / "static.png").name)
            zero = int(np.argmin(np.abs(loads)))
            pictures.append(plot_tm_modes(me, states[zero], tmp / "tm_modes.png").name)
        return {
            "format": "neweul-fem-sweep",
            "version": 2,
            "description": "TM + ear canal + tympanic cavity + antrum/mastoid, the TM held by "
            "the stiffening ossicular chain, linearized at static pressures "
            "dp = p_canal - p_cavity (Eq. (2) of the seed paper, u-p form); dp > 0 = negative "
            "middle-ear pressure",
            "refine": me.refine,
            "parameters": asdict(me.params),
            "dof_counts": me.dof_counts(),
            "support_in_K": include_support,
            "interface_nodes": {
                "manubrium": [int(n) + 1 for n in me.tm.line],
                "umbo": int(me.umbo) + 1,
            },
            "working_points": files,
            "fe_base": names[first] if first is not None else base_name(
                Path(out_dir) / "sweep.json", base),
            "static_results": "static.csv",
            **({"static_curve": "static_curve.csv (the static.csv columns on a finer grid of "
                "static pressures)"} if curve else {}),
            "static_displacements": "static_displacements.npz (dp_Pa, node_id, reference, "
            "u[point, node, xyz]) of the TM nodes [m]",
            "pictures": pictures,
        }

    write_directory_atomically(out_dir, fill)
