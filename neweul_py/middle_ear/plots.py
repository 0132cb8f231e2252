"""Pictures of the middle-ear FE model (matplotlib, the optional ``plot`` extra).

Each function writes one PNG and returns its path; matplotlib is imported lazily with the
non-interactive Agg backend.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse.linalg as spla

from ..errors import NeweulError
from ..fem.mesh import manubrium_section

if TYPE_CHECKING:
    from ..fem.nonlinear import StaticState
    from .model import MiddleEar

__all__ = ["calibration_figure", "plot_mesh", "plot_static", "plot_tm_modes", "require_matplotlib",
           "tm_modes"]


def require_matplotlib():
    """Import ``matplotlib.pyplot`` (Agg) or raise a :class:`NeweulError` saying how to get it."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:  # pragma: no cover - depends on the environment
        raise NeweulError("plots need matplotlib: pip install 'neweul-py[plot]'") from None
    return plt


def plot_mesh(me: MiddleEar, path: str | Path) -> Path:
    """The TM triangulation (manubrium and probe marked) and an axial section of the air meshes."""
    plt = require_matplotlib()
    tm = me.tm
    mm = 1e3
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.8))
    x = tm.points * mm
    ax1.triplot(x[:, 0], x[:, 1], tm.triangles, lw=0.4, color="0.3")
    ax1.plot(x[tm.line, 0], x[tm.line, 1], "o", ms=3, color="tab:red", label="manubrium")
    ax1.plot(x[me.umbo, 0], x[me.umbo, 1], "s", ms=5, color="tab:red", label="umbo")
    ax1.set_aspect("equal")
    ax1.set_xlabel("x (superior) [mm]")
    ax1.set_ylabel("y [mm]")
    ax1.set_title(f"TM: {tm.points.shape[0]} nodes, {tm.triangles.shape[0]} facets")
    ax1.legend(loc="lower left", fontsize=8)
    for mesh, colour, label in (
        (me.canal, "tab:blue", "ear canal"),
        (me.cavity, "tab:green", "tympanic cavity"),
    ):
        p = mesh.points * mm
        sec = np.abs(p[:, 1]) < 1e-9
        ax2.plot(p[sec, 2], p[sec, 0], ".", ms=1.5, color=colour, label=label)
    ax2.plot(
        x[:, 2][np.abs(x[:, 1]) < 1e-9], x[:, 0][np.abs(x[:, 1]) < 1e-9], "k.", ms=3, label="TM"
    )
    probe = (me.canal.points[me.probe_nodes].T @ me.probe_weights) * mm
    ax2.plot(probe[2], probe[0], "r*", ms=6, label="probe")
    ax2.set_xlabel("z (medial) [mm]")
    ax2.set_ylabel("x [mm]")
    ax2.set_title("section y = 0: air-mesh nodes")
    ax2.legend(fontsize=8, markerscale=4)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def plot_static(me: MiddleEar, states: list[StaticState], path: str | Path) -> Path:
    """Static TM deflection: the section through the umbo along the manubrium
    (:func:`~neweul_py.fem.mesh.manubrium_section`) and ``u_z`` over the TM for each state."""
    plt = require_matplotlib()
    tm = me.tm
    n = len(states)
    fig, axes = plt.subplots(1, n + 1, figsize=(4.2 * (n + 1), 4))
    sec, along = manubrium_section(tm)
    ax = axes[0]
    ax.plot(along * 1e3, tm.points[sec, 2] * 1e3, "k-", label="unloaded")
    for s in states:
        u = np.zeros(me.shell.n_dof)
        u[me.free_dofs] = s.u
        x = tm.points + u.reshape(-1, 3)
        ax.plot(along * 1e3, x[sec, 2] * 1e3, label=f"Δp = {s.load:+.0f} Pa")
        k = axes[1 + states.index(s)]
        tc = k.tripcolor(
            tm.points[:, 0] * 1e3,
            tm.points[:, 1] * 1e3,
            tm.triangles,
            u.reshape(-1, 3)[:, 2] * 1e6,
            shading="gouraud",
            cmap="RdBu_r",
        )
        fig.colorbar(tc, ax=k, label="u_z [µm] (medial +)")
        k.set_aspect("equal")
        k.set_title(f"Δp = {s.load:+.0f} Pa")
        k.set_xlabel("x [mm]")
    ax.set_xlabel("from the umbo along the manubrium (+ superior) [mm]")
    ax.set_ylabel("z (medial) [mm]")
    ax.set_title("TM section through the umbo")
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def tm_modes(me: MiddleEar, state: StaticState, n: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """In-vacuo TM modes at a working point, with the ossicular support: (f [Hz], modes (3N, n))."""
    from .working_point import working_point_model

    fe = working_point_model(me, state, include_support=True)
    nu = me.n_u
    ks, ms = fe.K[:nu][:, :nu], fe.M[:nu][:, :nu]
    lam, vec = spla.eigsh(ks, M=ms, k=n, sigma=0.0, which="LM")
    order = np.argsort(lam)
    full = np.zeros((me.shell.n_dof, n))
    full[me.free_dofs] = vec[:, order]
    return np.sqrt(np.abs(lam[order])) / (2 * np.pi), full


def plot_tm_modes(me: MiddleEar, state: StaticState, path: str | Path, n: int = 4) -> Path:
    """The first ``n`` in-vacuo TM modes (normal component) at a working point."""
    plt = require_matplotlib()
    f, modes = tm_modes(me, state, n)
    tm = me.tm
    fig, axes = plt.subplots(1, n, figsize=(3.6 * n, 3.6))
    for j, ax in enumerate(np.atleast_1d(axes)):
        uz = modes[:, j].reshape(-1, 3)[:, 2]
        uz = uz / np.abs(uz).max()
        ax.tripcolor(
            tm.points[:, 0] * 1e3,
            tm.points[:, 1] * 1e3,
            tm.triangles,
            uz,
            shading="gouraud",
            cmap="RdBu_r",
            vmin=-1,
            vmax=1,
        )
        ax.plot(tm.points[tm.line, 0] * 1e3, tm.points[tm.line, 1] * 1e3, "k.", ms=2)
        ax.set_aspect("equal")
        ax.set_title(f"mode {j + 1}: {f[j]:.0f} Hz")
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(f"TM in vacuo with ossicular support, Δp = {state.load:+.0f} Pa")
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def calibration_figure(start: dict, end: dict, refine: int, path: str | Path) -> Path:
    """The identified middle ear against its calibration set (docs/middle-ear-clinical.md §5):
    the compensated 226 Hz tympanogram with the normal ``Ytm`` range, the low-frequency umbo
    and stapes change under static pressure with Gyo & Goode's means ± SD, and the stapes
    velocity at Δp = 0 with the 0.6–1.5 kHz peak band; ``start`` (the shipped parameters)
    dashed, ``end`` (the fit) solid (measures of
    :func:`~neweul_py.middle_ear.calibration.calibration_measures`).
    """
    from matplotlib.ticker import NullFormatter

    plt = require_matplotlib()
    fig, (ax_t, ax_l, ax_s) = plt.subplots(1, 3, figsize=(14, 4.2), layout="constrained")
    for m, style, name in ((start, "--", "shipped"), (end, "-", "fit")):
        ty = m["tympanogram"]
        y = np.asarray(ty["admittance_mmho"])
        ax_t.plot(ty["pressure_daPa"], y - y[0], style, color="C0",
                  label=f"{name}: Ytm {m['ytm_mmho']:.2f} mmho, TW {m['tw']:.0f} daPa")
        for key, color in (("umbo", "C0"), ("stapes", "C1")):
            lo = m["loss"][key]
            dps = sorted(lo)
            ax_l.plot([0.0, *[d / 1e3 for d in dps]], [0.0, *[lo[d] for d in dps]], style + "o",
                      color=color, ms=3, label=f"{key} ({name})")
        st = m["stapes"]
        ax_s.loglog(st["frequency_hz"], st["velocity_mm_s_Pa"], style, color="C1",
                    label=f"{name}: peak {m['stapes_peak_hz']:.0f} Hz")
    ax_t.axhspan(0.37, 1.66, color="0.9", zorder=0, label="normal Ytm (Margolis & Heller 1987)")
    ax_t.set_xlabel("ear-canal pressure [daPa]")
    ax_t.set_ylabel("compensated |Y| at 226 Hz [mmho]")
    ax_t.legend(fontsize=7)
    ax_l.errorbar([1, 2, 3], [-5.0, -9.2, -13.1], yerr=[1.0, 1.3, 1.8], fmt="ks", ms=4,
                  capsize=3, label="umbo, Gyo & Goode 1987")
    ax_l.set_xlabel("Δp = p_canal − p_cavity [kPa]")
    ax_l.set_ylabel("mean change 100–1000 Hz [dB]")
    ax_l.legend(fontsize=7)
    ax_s.axvspan(600.0, 1500.0, color="0.9", zorder=0, label="peak band 0.6–1.5 kHz")
    ax_s.axhspan(0.1, 0.3, color="0.95", zorder=0)
    ax_s.xaxis.set_minor_formatter(NullFormatter())
    ax_s.set_xlabel("frequency [Hz]")
    ax_s.set_ylabel("|stapes velocity / probe pressure| [mm/s/Pa]")
    ax_s.legend(fontsize=7)
    fig.suptitle(f"Middle ear identified (FE refine {refine})")
    path = Path(path)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path
