"""The unreduced FE model coupled with a linear multibody chain at its nodes (validation).

The reference of the middle-ear EMBS: the *same* ossicular chain as the
EMBS — its linear matrices, taken from the linearized chain model with the TM's node frames
replaced by free translations — attached directly to the full FE model of a working point,
as ``examples/elastic_up_body`` does for its piston. With the chain's coordinates
``z = [y_c; u_n]`` (its own coordinates ``y_c`` and the translations ``u_n`` of the FE nodes it
is attached to) and ``u_n = E x`` (rows of the FE DOFs):

    [M_fe + Eᵀ M_nn E   Eᵀ M_nc] [ẍ ]                          [B]
    [M_cn E             M_cc   ] [ÿ_c] + (same for D, K) = [0] u

solved in the frequency domain, ``(K + iωD − ω²M) X = B`` (viscous FE damping ``D`` as in the
time domain, so that the EMBS and the reference have the same losses), one
:class:`~neweul_py.elastic.reductors.eigen.SparseLU` per frequency (the symmetric ordering of the
u–p pattern: a refine-1 calibration evaluation, 208 solves, takes 55 s instead of 115 s).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import scipy.sparse as sps

from ..elastic.fe_model import FEModel
from ..elastic.reductors.eigen import SparseLU
from ..errors import ModelError

__all__ = ["coupled_frf"]


def coupled_frf(fe: FEModel, chain: Mapping[str, np.ndarray], node_dofs: Sequence[int],
                freqs_hz: Sequence[float], input_name: str, fe_outputs: Sequence[str],
                chain_outputs: Sequence[int]) -> dict[str, np.ndarray]:
    """Frequency response of the FE model + chain (module docstring).

    Parameters
    ----------
    fe
        The working-point FE model.
    chain
        ``M``, ``D``, ``K`` (m × m) of the linear chain, coordinates ``[y_c; u_n]`` with the
        node translations last.
    node_dofs
        FE DOF index of every node translation ``u_n`` (in the chain's order).
    freqs_hz
        Frequencies [Hz].
    input_name
        The FE input driving the model.
    fe_outputs
        FE output names (displacements / pressures).
    chain_outputs
        Indices of chain coordinates ``y_c`` whose *velocity* is returned.

    Returns
    -------
    dict
        ``name → complex (nf,)`` per unit input: every FE output, and ``chain<i>`` the
        velocity ``jω y_c[i]``.
    """
    n = fe.n_dofs
    nodes = np.asarray(node_dofs, dtype=np.int64)
    m = chain["K"].shape[0]
    nc = m - nodes.size
    if nc < 0 or any(chain[k].shape != (m, m) for k in ("M", "D", "K")):
        raise ModelError("chain matrices do not match the node DOFs", "coupled_frf")
    P = sps.csr_matrix((np.ones(m), (np.r_[n + np.arange(nc), nodes], np.arange(m))),
                       shape=(n + nc, m))

    def total(fe_mat, key):
        base = sps.block_diag([fe_mat if fe_mat is not None else sps.csr_matrix((n, n)),
                               sps.csr_matrix((nc, nc))], format="csr")
        return (base + P @ sps.csr_matrix(chain[key]) @ P.T).tocsc()

    M, D, K = total(fe.M, "M"), total(fe.D, "D"), total(fe.K, "K")
    b = np.zeros(n + nc, dtype=complex)
    b[:n] = fe.B(input_name)[:, 0]
    rows = {}
    for name in fe_outputs:
        c = np.zeros(n + nc)
        for i, w in fe.outputs[name]:
            c[i] += w
        rows[name] = c
    out = {name: [] for name in (*fe_outputs, *(f"chain{i}" for i in chain_outputs))}
    for f in np.asarray(freqs_hz, dtype=float):
        w = 2 * np.pi * f
        x = SparseLU(K + 1j * w * D - w * w * M).solve(b)
        for name, c in rows.items():
            out[name].append(c @ x)
        for i in chain_outputs:
            out[f"chain{i}"].append(1j * w * x[n + i])
    return {k: np.array(v) for k, v in out.items()}
