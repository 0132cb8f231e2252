"""The middle-ear EMBS against the unreduced FE model coupled with the same chain.

For a Δp, the generated EMBS linearized there (:func:`~neweul_py.middle_ear.study.embs_frf`)
against the full FE model of that working point (between samples: the FE model linearized
*there*) coupled directly with the **same** chain: the description with the TM body removed
and each node frame ``tm.mK`` replaced by a frame on three free translations
(:func:`~neweul_py.middle_ear.embs.chain_description`), generated and linearized, its matrices
attached to the FE DOFs of the manubrium nodes (:func:`~neweul_py.middle_ear.coupled.coupled_frf`).
Both use the loss factors as ``K + iG`` (the body's ``Le``, the FE model's ``G``, the chain's
``loss_factor``: docs/equations.md §1.1; ``damping="viscous"``: both the viscous equivalent).

The reduced side may also be assembled by hand (:func:`body_coupled`): the body at Δp attached
to the same linearized chain through its node rows (``u_n = Φ_n q``, node forces ``Ψ_nᵀ f``,
``Φ``/``Ψ`` the right/left rows) — the coupled EMBS's linearization without generating a module
per body, for comparing reductions (its poles: :func:`coupled_poles`).

The static state likewise (:func:`static_errors`): the body with its static state tied to the
malleus held by the chain's static characteristic, against the FE static solution.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from scipy.interpolate import CubicSpline

from ..analysis import load_generated
from ..analysis.linearize import linearize
from ..api import generate
from ..elastic.bodies.static import node_rows
from ..elastic.io.body_files import load_parametric_body
from ..elastic.io.fe_files import read_fe_model
from ..elastic.io.working_point import read_static
from ..elastic.quality.frf_sweep import frequency_form
from ..elastic.quality.measures import right_half_plane_poles
from ..elastic.quality.static_equilibrium import tied_static_equilibrium
from ..errors import DataError
from ..ffrf.loss_form import loss_form
from .coupled import coupled_frf
from .embs import (
    PROBE_MASS,
    chain_description,
    model_path,
    node_positions,
    parameters_at,
    template,
)
from .parameters import MiddleEarParameters
from .study import build_parameters, build_record, embs_frf, transfer
from .sweep import pressure_sweep

__all__ = ["body_coupled", "body_coupled_frf", "chain_matrices", "chain_module",
           "chain_restoring", "coupled_poles", "errors", "fe_model_at", "linear_chain",
           "reference_frf", "static_errors"]

#: The canal source of the transfer functions and the body outputs they read.
SOURCE = "canal_volume_acceleration"


def chain_module(description: Path, fem: Path, gen: Path) -> Any:
    """The chain of a built description alone (:func:`chain_description`), generated in
    ``gen``."""
    gen.mkdir(parents=True, exist_ok=True)
    path = gen / "middle_ear_chain.yaml"
    path.write_text(chain_description(description.read_text(encoding="utf-8"),
                                      node_positions(fem)), encoding="utf-8")
    return load_generated(generate(path, gen))


def fe_model_at(dp: float, build: Path, refine: int) -> Path:
    """The FE model of a working point: from a sweep of the build, or solved alone (between
    samples) into ``build/fem_dp<dp>`` with the build's data (the ``parameters`` of its
    ``fem/sweep.json``)."""
    for d in sorted(build.glob("fem*")):
        path = model_path(d, dp)
        if path.is_file():
            return path
    extra = build / f"fem_dp{dp:+06.0f}"
    path = model_path(extra, dp)
    if not path.is_file():
        pressure_sweep([dp], build_parameters(build), refine=refine, out_dir=str(extra))
    return path


def chain_matrices(chain_mod: Any, dp: float, damping: str = "loss",
                   p: np.ndarray | None = None
                   ) -> tuple[dict[str, np.ndarray], list[str], list[str]]:
    """``M``, ``D``, ``K`` of the chain alone linearized at ``dp`` (``p``: its parameter
    vector, default its defaults with ``dp``), coordinates ``[y_c; u_n]``: its own, then the
    node translations ``nK_a`` (without their probe masses); with ``damping="loss"`` the
    loss factors as ``K + iG``, ``D − G/ω_ref``. Returns the matrices and both name lists."""
    lin = linearize(chain_mod, p=parameters_at(chain_mod, dp) if p is None else p)
    names = list(lin.coordinates)
    node = [n for n in names if n.startswith("n") and n[1:].split("_")[0].isdigit()]
    own = [n for n in names if n not in node]
    order = [names.index(n) for n in (*own, *node)]
    P, Q = lin.P, lin.Q
    if damping == "loss" and lin.has_loss:      # K + iG, D − G/ω_ref of the chain as well
        P = P - lin.G / (2 * np.pi * lin.loss_reference_frequency)
        Q = Q + 1j * lin.G
    chain = {k: a[np.ix_(order, order)] for k, a in (("M", lin.M0), ("D", P), ("K", Q))}
    k = np.arange(len(own), len(names))
    chain["M"][k, k] -= PROBE_MASS
    return chain, own, node


def linear_chain(chain_mod: Any, fe: Any, p: np.ndarray, damping: str = "loss"
                 ) -> tuple[dict[str, np.ndarray], list[str], list[int]]:
    """The chain's linear matrices for :func:`~neweul_py.middle_ear.coupled.coupled_frf`:
    ``M``, ``D``, ``K`` of :func:`chain_matrices` at the parameter vector ``p``, the names of
    its own coordinates and the FE DOF of each node translation in ``fe``."""
    chain, own, node = chain_matrices(chain_mod, 0.0, damping, p)
    dofs = [fe.inputs[f"manubrium.{n[1:].split('_')[0]}.u{n[-1]}"][0][0] for n in node]
    return chain, own, dofs


def reference_frf(chain_mod: Any, fe_path: Path, dp: float, f: np.ndarray,
                  damping: str = "loss", p: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The outputs of :func:`~neweul_py.middle_ear.study.embs_frf` from the FE model and the
    chain assembled directly (``p``: the chain's parameter vector, default its defaults with
    ``dp``)."""
    fe = frequency_form(read_fe_model(fe_path), damping)
    chain, own, dofs = linear_chain(chain_mod, fe,
                                    parameters_at(chain_mod, dp) if p is None else p, damping)
    res = coupled_frf(fe, chain, dofs, f, SOURCE,
                      ["probe_pressure", "umbo_uz"], [own.index("s_z"), own.index("m_z")])
    return {"p_probe": res["probe_pressure"], "umbo_uz": res["umbo_uz"],
            "stapes_velocity": res[f"chain{own.index('s_z')}"],
            "umbo_velocity_z": res[f"chain{own.index('m_z')}"]}


def body_coupled(chain: dict[str, np.ndarray], own: Sequence[str], node: Sequence[str],
                 body: Any, damping: str = "loss") -> dict[str, np.ndarray]:
    """The chain (:func:`chain_matrices`) with the reduced ``body`` (one working point)
    attached at its node translations: coordinates ``[y_c; q]``, ``u_n = Φ_n q`` and the
    node equations projected by ``Ψ_nᵀ`` (``Φ_n``, ``Ψ_n`` the body's right and left rows of
    the node translations ``nK_a``, ``V_kept``/``W_kept``)::

        X = [[X_cc, X_cn Φ], [Ψᵀ X_nc, Ψᵀ X_nn Φ + X_body]]      (X = M, D, K)

    ``damping`` as in :func:`chain_matrices` (the body's ``G`` likewise). Returns ``M``,
    ``D``, ``K`` and ``b`` (the canal source)."""
    rows = node_rows(body.nodes, body.dof_node, body.dof_kind)
    ids = [int(i) for i in body.nodes[:, 0]]
    pick = [int(rows[ids.index(int(n[1:].split("_")[0])), "xyz".index(n[-1])]) for n in node]
    if min(pick) < 0:
        raise DataError("a chain node translation is not a kept DOF of the body", None, "nodes")
    phi, psi = body.V_kept[pick], body.W_kept[pick]
    K, D = body.K, body.D
    if damping == "loss" and body.G is not None:
        K, D = loss_form(K, D, body.G, body.loss_reference_frequency)
    nc = len(own)
    out = {}
    for key, xb in (("M", body.M), ("D", D), ("K", K)):
        x = chain[key]
        out[key] = np.block([[x[:nc, :nc], x[:nc, nc:] @ phi],
                             [psi.T @ x[nc:, :nc], psi.T @ x[nc:, nc:] @ phi + xb]])
    b = np.zeros(out["M"].shape[0], dtype=complex)
    b[nc:] = body.B[:, list(body.input_names).index(SOURCE)]
    out["b"] = b
    return out


def body_coupled_frf(chain: dict[str, np.ndarray], own: Sequence[str], node: Sequence[str],
                     body: Any, f: np.ndarray, damping: str = "loss") -> dict[str, np.ndarray]:
    """The outputs of :func:`reference_frf` from :func:`body_coupled` (one batched solve)."""
    sys = body_coupled(chain, own, node, body, damping)
    w = 2 * np.pi * np.asarray(f, dtype=float)[:, None, None]
    A = sys["K"][None] + 1j * w * sys["D"][None] - w**2 * sys["M"][None]
    X = np.linalg.solve(A, np.broadcast_to(sys["b"], (w.shape[0], sys["b"].size))[..., None])
    X = X[..., 0]
    nc = len(own)
    out = {}
    for key, name in (("p_probe", "probe_pressure"), ("umbo_uz", "umbo_uz")):
        out[key] = X[:, nc:] @ body.C[list(body.output_names).index(name)]
    for key, name in (("stapes_velocity", "s_z"), ("umbo_velocity_z", "m_z")):
        out[key] = 1j * w[:, 0, 0] * X[:, own.index(name)]
    return out


def coupled_poles(chain: dict[str, np.ndarray], own: Sequence[str], node: Sequence[str],
                  body: Any) -> np.ndarray:
    """The right-half-plane poles
    (:func:`~neweul_py.elastic.quality.measures.right_half_plane_poles`) of the chain with
    the body in the time domain: ``chain`` from ``chain_matrices(..., damping="viscous")``,
    the body's viscous ``D``."""
    sys = body_coupled(chain, own, node, body, "viscous")
    return right_half_plane_poles(sys["M"].real, sys["D"].real, sys["K"].real)


def errors(mod: Any, chain_mod: Any, dp: float, f: np.ndarray, fe_path: Path,
           damping: str = "loss") -> dict[str, np.ndarray]:
    """Relative error per frequency of the EMBS transfer functions against the reference,
    with both (``ref_*``, ``got_*``)."""
    got = transfer(embs_frf(mod, dp, f, damping), f)
    ref = transfer(reference_frf(chain_mod, fe_path, dp, f, damping), f)
    return {k: np.abs(got[k] - ref[k]) / np.abs(ref[k]) for k in got} | {
        f"ref_{k}": v for k, v in ref.items()} | {f"got_{k}": v for k, v in got.items()}


def chain_restoring(table: bool, kc0: np.ndarray,
                    p: MiddleEarParameters | None = None) -> Callable[[np.ndarray], tuple]:
    """``y → (F_c, K_c)``: the chain at the malleus as the FE static solution has it
    (docs/equations-middle-ear.md §2), the tangent at Δp = 0 ``kc0`` in every direction plus,
    along z, the excess of the stiffening characteristic — the closed form ``F(s) − k₀ s`` of
    the data ``p`` (default: the defaults) or (``table``) the ``chain_stiffening`` table of
    ``templates/ossicles.yaml`` (natural cubic spline, as the description interpolates it;
    the defaults' chain)."""
    p = p or MiddleEarParameters()
    k0, sp, sm = p.k_chain, p.chain_limit_medial, p.chain_limit_lateral
    forces = yaml.safe_load(template("ossicles.yaml"))["forces"]
    tab = np.array(forces["chain_stiffening"]["stiffness"]["table"])
    g = CubicSpline(tab[:, 0], tab[:, 1], bc_type="natural")

    def restoring(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        F, K = kc0 @ y, kc0.copy()
        z = y[2]
        if table:
            F[2] += g(z)
            K[2, 2] += g(z, 1)
        else:
            s = sp if z >= 0 else sm
            F[2] = -np.sign(z) * k0 * s * np.log(1 - abs(z) / s)
            K[2, 2] = k0 / (1 - abs(z) / s)
        return F, K
    return restoring


def static_errors(build: Path, extra: Sequence[float] = ()) -> list[tuple]:
    """The static state of the EMBS against the FE static solution: per Δp (the body's
    samples and ``extra`` values between them, whose FE static solution is solved alone) and
    per chain characteristic (the closed form ``F(s)``, the description's table), the body at
    Δp with its static state, the malleus tied to the manubrium nodes by the TM–manubrium
    springs and held by the chain
    (:func:`~neweul_py.elastic.quality.static_equilibrium.tied_static_equilibrium`, §5):
    ``(dp, is_sample, characteristic, umbo error, volume error)`` (relative, against
    ``static.csv`` of the FE sweeps)."""
    record = build_record(build)
    params = build_parameters(build)
    defaults = MiddleEarParameters()
    tables = (False, True) if all(
        getattr(params, n) == getattr(defaults, n)
        for n in ("k_chain", "chain_limit_medial", "chain_limit_lateral")) else (False,)
    pb = load_parametric_body(build / record["body"])
    man = np.array(record["manubrium"])
    k = params.k_tm_manubrium / man.size
    kc0 = read_static(model_path(build / "fem", 0.0))["chain_tangent"]
    umbo = pb.nodes[pb.nodes[:, 0] == record["umbo"]][0, 1:4]
    out = list(pb.output_names)
    ref: dict[float, np.ndarray] = {}
    for d in sorted(build.glob("fem*")):
        if (d / "static.csv").is_file():
            for r in np.atleast_1d(np.genfromtxt(d / "static.csv", delimiter=",", names=True)):
                ref[float(r["dp_Pa"])] = r
    for dp in extra:
        path = fe_model_at(float(dp), build, int(record["refine"]))
        ref[float(dp)] = np.atleast_1d(np.genfromtxt(path.parent / "static.csv",
                                                     delimiter=",", names=True))[0]
    rows = []
    for dp in sorted(p for p in ref if p != 0.0 and (p in pb.samples or p in extra)):
        for table in tables:
            sol = tied_static_equilibrium(pb.at(dp), man, k,
                                          chain_restoring(table, kc0, params), umbo)
            e = [sol["outputs"][out.index(name)] / float(ref[dp][col]) - 1 for name, col in
                 (("umbo_uz", "umbo_uz_m"), ("tm_volume_displacement",
                                             "volume_displacement_m3"))]
            rows.append((dp, dp in pb.samples, "table" if table else "F(s)", *e))
    return rows
