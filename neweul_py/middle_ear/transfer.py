"""Frequency responses of a working-point model with the ossicular chain (lumped checks).

Two checks of the FE data that need no multibody model (``docs/equations-middle-ear.md`` §5):

* :func:`umbo_transfer` — the FE model with the chain *support* (the malleus condensed, the chain
  tangent at the working point) added at the manubrium: umbo velocity per probe pressure;
* :func:`chain_transfer` — the FE model with an LVATB1-like lumped chain assembled directly
  (as ``examples/elastic_up_body`` does): a rigid malleus (6 DOFs, mass and inertia) on the
  manubrium nodes, incus and stapes as masses along the TM axis, the ligaments and joints as
  springs with a loss factor, the cochlea as a dashpot at the stapes; the ligaments to ground
  stiffen with Δp so that the chain's static stiffness at the malleus equals the tangent of
  the static characteristic at the working point. Umbo and stapes velocity per probe
  pressure; the reference the flagship EMBS can be checked against.

Frequency domain with loss factors: ``(K + iG − ω² M) x = B``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.optimize as spo
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from ..elastic.fe_model import FEModel
from ..errors import ModelError

__all__ = ["LumpedChain", "chain_transfer", "manubrium_input_order", "umbo_transfer"]


@dataclass(frozen=True)
class LumpedChain:
    """An LVATB1-like ossicular chain along the TM axis (SI units).

    Masses and stiffnesses: LVATB1 (Lobato et al.; ``docs/middle-ear-measurements.md``):
    malleus 34.8 mg, incus 33.7 mg, stapes 2.12 mg; malleus ligaments 893 N/m,
    incudomalleolar joint 11 410 N/m, incus ligament 129 N/m, incudostapedial joint
    12 581 N/m, annular ligament 764 N/m. Malleus inertia about the umbo 130 mg mm²
    (the malleus–incus complex about its axis; micro-CT, reference data sheet). Cochlear load
    ``Z_c A_fp²`` with the measured cochlear input impedance 21 GΩ (Aibara et al. 2001) and the
    footplate area 3.2 mm². Ligament/joint loss factor 0.32 (LVATB1's modal loss factor of the
    chain modes).
    """

    m_malleus: float = 34.8e-6
    i_malleus: float = 130e-12
    m_incus: float = 33.7e-6
    m_stapes: float = 2.12e-6
    k_malleus_lig: float = 893.0
    k_im_joint: float = 11410.0
    k_incus_lig: float = 129.0
    k_is_joint: float = 12581.0
    k_annular: float = 764.0
    c_cochlea: float = 21e9 * (3.2e-6) ** 2
    loss: float = 0.32

    def static_stiffness(self, factor: float = 1.0) -> float:
        """Static stiffness of the chain at the malleus [N/m] with the ligaments to ground
        scaled by ``factor``: ``k_ml φ + 1/(1/k_imj + 1/(k_il φ + 1/(1/k_isj + 1/(k_al φ))))``."""
        inner = 1.0 / (1.0 / self.k_is_joint + 1.0 / (self.k_annular * factor))
        incus = self.k_incus_lig * factor + inner
        return self.k_malleus_lig * factor + 1.0 / (1.0 / self.k_im_joint + 1.0 / incus)

    def ligament_factor(self, k_target: float) -> float:
        """The factor ``φ`` of the ligaments to ground for a static stiffness ``k_target``."""
        if not k_target > 0:
            raise ModelError(f"chain stiffness must be positive, got {k_target}", "chain")
        return float(spo.brentq(lambda f: self.static_stiffness(f) - k_target, 1e-3, 1e4))


def _solve(k: sps.spmatrix, g: sps.spmatrix, m: sps.spmatrix, b: np.ndarray, freqs) -> np.ndarray:
    out = []
    for f in np.asarray(freqs, dtype=float):
        w = 2 * np.pi * f
        a = (k + 1j * g - w**2 * m).tocsc()
        out.append(spla.spsolve(a, b.astype(complex)))
    return np.array(out)


def _row(fe: FEModel, name: str, n: int) -> np.ndarray:
    c = np.zeros(n)
    for i, w in fe.outputs[name]:
        c[i] += w
    return c


def umbo_transfer(
    fe: FEModel, g: sps.spmatrix, support: sps.spmatrix | None, freqs: Sequence[float],
    support_loss: float = 0.0,
) -> np.ndarray:
    """Umbo velocity per probe pressure ``jω u_z / p_probe`` [m/s/Pa] of ``K + iG − ω²M``.

    ``support`` (n_u × n_u on the model's displacement DOFs, e.g. the free-DOF block of
    :func:`~neweul_py.middle_ear.static.support_at`) is added to the stiffness, with
    ``support_loss`` as its loss factor.
    """
    n = fe.n_dofs
    k, gg = fe.K, sps.csr_matrix(g)
    if support is not None:
        nu = support.shape[0]
        pad = sps.block_diag([support, sps.csr_matrix((n - nu, n - nu))], format="csr")
        k, gg = k + pad, gg + support_loss * pad
    b = fe.B("canal_volume_acceleration")[:, 0]
    x = _solve(k, gg, fe.M, b, freqs)
    cu, cp = _row(fe, "umbo_uz", n), _row(fe, "probe_pressure", n)
    w = 2 * np.pi * np.asarray(freqs, dtype=float)
    return 1j * w * (x @ cu) / (x @ cp)


def manubrium_input_order(name: str) -> tuple[int, str]:
    """Sort key of an FE input ``manubrium.<node>.u<x|y|z>``: node id as a number, then the
    component (the row order of ``MiddleEar.malleus_T``; string order would put node 20
    before node 8)."""
    _, node, comp = name.split(".")
    return int(node), comp


def chain_transfer(
    fe: FEModel,
    g: sps.spmatrix,
    static: Mapping[str, np.ndarray],
    malleus_T: np.ndarray,
    k_attach: float,
    freqs: Sequence[float],
    chain: LumpedChain | None = None,
) -> dict[str, np.ndarray]:
    """Umbo and stapes velocity per probe pressure of the FE model + a lumped chain.

    Parameters
    ----------
    fe, g
        A working-point model (without support) and its hysteretic damping.
    static
        Its static group (:func:`~neweul_py.middle_ear.working_point.static_data`): the chain
        tangent ``chain_tangent`` sets the Δp-dependent ligament stiffness.
    malleus_T
        (3m, 6) rigid malleus → manubrium map (``MiddleEar.malleus_T``), node order of the
        ``manubrium.<id>.u?`` inputs.
    k_attach
        Total TM–manubrium attachment stiffness [N/m].
    freqs
        Frequencies [Hz].
    chain
        The lumped chain (default :class:`LumpedChain`); the malleus's other five coordinates
        are held by the chain tangent ``static["chain_tangent"]`` (``k₀``, ``k₀ a²``).

    Returns
    -------
    dict
        ``umbo``, ``stapes``: complex velocities per probe pressure [m/s/Pa]; ``factor``:
        the ligament factor φ.
    """
    ch = chain or LumpedChain()
    n = fe.n_dofs
    kc = np.asarray(static["chain_tangent"])
    k_target = float(kc[2, 2])
    phi = ch.ligament_factor(k_target)
    man = sorted((name for name in fe.inputs if name.startswith("manubrium.")),
                 key=manubrium_input_order)           # the node order of malleus_T's rows
    dofs = np.array([fe.inputs[name][0][0] for name in man])
    if dofs.size != malleus_T.shape[0]:
        raise ModelError("manubrium DOFs do not match the malleus map", "chain_transfer")
    # DOFs: FE (n), malleus q (6), incus, stapes
    nq = n + 6
    ni, ns = nq, nq + 1
    ntot = nq + 2
    k_att = k_attach / (dofs.size // 3)
    rows, cols, vals = [], [], []

    def add(r, c, v):
        rows.append(np.atleast_1d(r))
        cols.append(np.atleast_1d(c))
        vals.append(np.atleast_1d(np.asarray(v, dtype=float)))

    # attachment springs: ½ k |u_m − T q|²
    q_idx = n + np.arange(6)
    add(dofs, dofs, np.full(dofs.size, k_att))
    rr, cc = np.meshgrid(dofs, q_idx, indexing="ij")
    add(rr.ravel(), cc.ravel(), (-k_att * malleus_T).ravel())
    add(cc.T.ravel(), rr.T.ravel(), (-k_att * malleus_T.T).ravel())
    ttt = k_att * malleus_T.T @ malleus_T
    rq, cq = np.meshgrid(q_idx, q_idx, indexing="ij")
    add(rq.ravel(), cq.ravel(), ttt.ravel())
    # the malleus's other coordinates: the chain tangent (linear part), z handled by the chain
    kq = kc.copy()
    kq[2, 2] = 0.0
    add(rq.ravel(), cq.ravel(), kq.ravel())
    z = n + 2

    def spring(i, j, k):
        if j is None:
            add(i, i, k)
            return
        add([i, j, i, j], [i, j, j, i], [k, k, -k, -k])

    spring(z, None, ch.k_malleus_lig * phi)
    spring(z, ni, ch.k_im_joint)
    spring(ni, None, ch.k_incus_lig * phi)
    spring(ni, ns, ch.k_is_joint)
    spring(ns, None, ch.k_annular * phi)
    kadd = sps.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(ntot, ntot)
    )
    m_add = np.zeros(ntot)
    m_add[n : n + 3] = ch.m_malleus
    m_add[n + 3 : n + 6] = ch.i_malleus
    m_add[ni], m_add[ns] = ch.m_incus, ch.m_stapes
    pad = sps.csr_matrix((ntot - n, ntot - n))
    k = sps.block_diag([fe.K, pad], format="csr") + kadd
    gg = sps.block_diag([g, pad], format="csr") + ch.loss * kadd
    m = sps.block_diag([fe.M, pad], format="csr") + sps.diags(m_add)
    d = sps.csr_matrix(([ch.c_cochlea], ([ns], [ns])), shape=(ntot, ntot))
    b = np.zeros(ntot)
    b[:n] = fe.B("canal_volume_acceleration")[:, 0]
    freqs = np.asarray(freqs, dtype=float)
    out_x = []
    for f in freqs:
        w = 2 * np.pi * f
        a = (k + 1j * gg + 1j * w * d - w**2 * m).tocsc()
        out_x.append(spla.spsolve(a, b.astype(complex)))
    x = np.array(out_x)
    cp = np.zeros(ntot)
    cp[:n] = _row(fe, "probe_pressure", n)
    cu = np.zeros(ntot)
    cu[:n] = _row(fe, "umbo_uz", n)
    w = 2 * np.pi * freqs
    p = x @ cp
    return {"umbo": 1j * w * (x @ cu) / p, "stapes": 1j * w * x[:, ns] / p, "factor": phi}
