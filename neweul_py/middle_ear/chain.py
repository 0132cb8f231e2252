"""The ossicular chain as the static support of the manubrium: a rigid malleus on springs.

Model (``docs/equations-middle-ear.md`` §2): a rigid malleus with the six coordinates
``q = (q_t, θ)`` (translation of the umbo point and small rotation about it) is attached to
the ``m`` manubrium nodes by isotropic springs of total stiffness ``k_attach`` and held by the
rest of the chain (incus, stapes, ligaments, annular ligament) with the restoring force
``F_c(q)``::

    E(u_m, q) = ½ k Σ_i |u_i − (T q)_i|² + Π_c(q),   (T q)_i = q_t + θ × (x_i − x_umbo),

``k = k_attach / m``. ``Π_c`` is linear (``½ qᵀ K₀ q``, ``K₀ = diag(k₀ I₃, k₀ a² I₃)``) in five
of the six coordinates; along the TM axis (``q_z``, medial positive) the chain stiffens with
displacement (Lauxmann et al. 2014: progressive stiffening of the annular ligament; Gan et al.
2011: its shear modulus grows ×60 with the stress; Hüttenbrink: the joints glide for large
static malleus motion). The characteristic has a limit displacement ``s±`` on each side and a
tangent stiffness that grows exponentially with the load — so that the low-frequency loss in
dB grows about linearly with the static pressure, as measured (Gyo & Goode 1987)::

    F(s) = −sign(s) k₀ s± ln(1 − |s|/s±),   dF/ds = k₀/(1 − |s|/s±) = k₀ exp(|F|/(k₀ s±)),

``s± = s₊`` (medial, ``s ≥ 0``) or ``s₋`` (lateral); ``F`` and ``dF/ds`` are continuous at
``s = 0`` (both branches start with ``k₀``).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "chain_force",
    "chain_tangent_matrix",
    "condensed_support",
    "malleus_map",
]


def chain_force(s: float, k0: float, s_medial: float, s_lateral: float) -> tuple[float, float]:
    """The stiffening chain characteristic along the TM axis: force and tangent stiffness.

    Parameters
    ----------
    s
        Umbo (malleus) displacement along the TM axis [m], medial positive.
    k0
        Small-displacement stiffness [N/m].
    s_medial, s_lateral
        Limit displacements of the medial and lateral branches [m].

    Returns
    -------
    force, tangent
        ``−sign(s) k₀ s± ln(1 − |s|/s±)`` [N] and ``k₀ / (1 − |s|/s±)`` [N/m]; ``nan``
        beyond the limit (Newton then halves the load step).

    Examples
    --------
    >>> f, k = chain_force(0.0, 1000.0, 1e-4, 2e-4)
    >>> (f, k)
    (0.0, 1000.0)
    >>> f, k = chain_force(5e-5, 1000.0, 1e-4, 2e-4)  # half the medial limit
    >>> round(k / 1000.0, 6), round(float(np.exp(f / (1000.0 * 1e-4))), 6)  # k₀ e^{F/(k₀s₊)}
    (2.0, 2.0)
    """
    lim = s_medial if s >= 0 else s_lateral
    x = abs(s) / lim
    if not x < 1.0:
        return float("nan"), float("nan")
    return float(-np.sign(s) * k0 * lim * np.log1p(-x)), float(k0 / (1.0 - x))


def malleus_map(points: np.ndarray, manubrium: np.ndarray, umbo_point: np.ndarray) -> np.ndarray:
    """``T`` (3m × 6): displacements of the manubrium nodes for a rigid malleus motion ``q``.

    ``u_i = q_t + θ × r_i``, ``r_i = x_i − x_umbo``, i.e. ``u_i = q_t − [r_i]× θ``.
    """
    m = manubrium.size
    rel = points[manubrium] - umbo_point
    t = np.zeros((3 * m, 6))
    for i in range(3):
        t[i::3, i] = 1.0
    skew = np.zeros((m, 3, 3))  # θ × r = −[r]× θ
    skew[:, 0, 1], skew[:, 0, 2] = rel[:, 2], -rel[:, 1]
    skew[:, 1, 0], skew[:, 1, 2] = -rel[:, 2], rel[:, 0]
    skew[:, 2, 0], skew[:, 2, 1] = rel[:, 1], -rel[:, 0]
    t[:, 3:] = skew.reshape(3 * m, 3)
    return t


def chain_tangent_matrix(
    q: np.ndarray, k0: float, lever: float, s_medial: float, s_lateral: float
) -> tuple[np.ndarray, np.ndarray]:
    """Restoring force ``F_c(q)`` (6,) and tangent ``∂F_c/∂q`` (6×6) of the chain on the malleus.

    Linear ``k₀`` in the two in-plane translations, ``k₀ a²`` (``a = lever``) in the three
    rotations, the stiffening characteristic :func:`chain_force` along ``z``.
    """
    kd = np.array([k0, k0, k0, k0 * lever**2, k0 * lever**2, k0 * lever**2])
    f = kd * q
    fz, kz = chain_force(float(q[2]), k0, s_medial, s_lateral)
    f[2] = fz
    kd = kd.copy()
    kd[2] = kz
    return f, np.diag(kd)


def condensed_support(t: np.ndarray, k_attach: float, k_chain: np.ndarray) -> np.ndarray:
    """The support stiffness seen by the manubrium nodes (dense 3m × 3m), malleus condensed.

    ``K_sup = k I − k² T (k TᵀT + K_c)⁻¹ Tᵀ`` with ``k = k_attach / m`` and the chain tangent
    ``K_c`` (6×6) at the working point: rigid motions of the manubrium see the chain
    stiffness, relative deformations along the manubrium the (stiff) attachment springs.
    """
    k = k_attach / (t.shape[0] // 3)
    return k * np.eye(t.shape[0]) - k**2 * t @ np.linalg.solve(k * t.T @ t + k_chain, t.T)
