"""A spring–mass chain as a protocol-conforming object (docs/generated-module-protocol.md).

ground —k1— m —k2— m — … —kn— m; spring i has stiffness k_i (alternately ``k_stiff`` and
``k_soft``) plus a cubic term ``k3 e³`` of its elongation e, dampers ``d_i`` (``d_stiff`` on the
stiff springs, ``d`` on the others) parallel to every spring, a constant load ``m g`` on every
mass and an input force ``F`` on the last one. With the difference matrix ``D`` (e = D x):
``F(x, ẋ) = −Dᵀ(k e + k3 e³ + d ė) + m g + F e_n``, ``∂F/∂x = −Dᵀ diag(k + 3 k3 e²) D``,
``∂F/∂ẋ = −Dᵀ diag(d_i) D``. Written by hand so that the benchmarks need no code generation.
"""

from __future__ import annotations

import types

import numpy as np


def make_chain(n: int, k_soft: float = 1.0e3, k_stiff: float = 1.0e3, k3: float = 1.0e5,
               d: float = 0.05, m: float = 0.1, g: float = 9.81,
               d_stiff: float | None = None) -> types.SimpleNamespace:
    """A chain of ``n`` masses implementing the generated-module protocol.

    ``d_stiff`` (default ``d``) is the damping of the stiff springs: a large value makes their
    modes decay fast (a stiff problem in the ODE sense).
    """
    k = np.where(np.arange(n) % 2 == 0, k_stiff, k_soft)
    dscale = np.where(np.arange(n) % 2 == 0, (d if d_stiff is None else d_stiff) / d, 1.0)
    dmat = np.eye(n) - np.eye(n, k=-1)
    eye = np.eye(n)
    e_last = np.zeros(n)
    e_last[-1] = 1.0
    coords = [f"x{i + 1}" for i in range(n)]

    def default_parameters():
        return np.array([m, d, k3, g])

    def default_inputs(t, p):
        return np.zeros(1)

    def mass_matrix(t, y, p):
        return p[0] * eye

    def force_vector(t, y, yd, p, u=None):
        u = default_inputs(t, p) if u is None else u
        e, ed = dmat @ y, dmat @ yd
        return -dmat.T @ (k * e + p[2] * e**3 + p[1] * dscale * ed) + p[0] * p[3] + u[0] * e_last

    def force_jacobians(t, y, yd, p, u=None):
        e = dmat @ y
        fy = -dmat.T @ ((k + 3 * p[2] * e**2)[:, None] * dmat)
        return fy, -p[1] * dmat.T @ (dscale[:, None] * dmat), e_last[:, None].copy()

    def mass_matrix_times_derivative(t, y, p, a):
        return np.zeros((n, n))

    def rhs(t, x, p, u=None):
        return np.concatenate([x[n:], force_vector(t, x[:n], x[n:], p, u) / p[0]])

    def rhs_jacobian(t, x, p, u=None):
        fy, fyd, _ = force_jacobians(t, x[:n], x[n:], p, u)
        out = np.zeros((2 * n, 2 * n))
        out[:n, n:] = eye
        out[n:, :n] = fy / p[0]
        out[n:, n:] = fyd / p[0]
        return out

    def outputs(t, x, p, u=None):
        return np.array([x[n - 1], x[2 * n - 1]])

    def output_jacobians(t, x, p, u=None):
        c = np.zeros((2, 2 * n))
        c[0, n - 1] = 1.0
        c[1, 2 * n - 1] = 1.0
        return c, np.zeros((2, 1))

    return types.SimpleNamespace(
        PROTOCOL_VERSION=1,
        MODEL_NAME=f"spring_chain{n}",
        COORDINATES=coords,
        INITIAL_STATE=[0.0] * (2 * n),
        PARAMETERS={"m": m, "d": d, "k3": k3, "g": g},
        INPUTS=["F"],
        OUTPUTS=["x_last", "v_last"],
        CONSTRAINTS=[],
        STATE_SIZE=2 * n,
        SOURCE_HASH="hand-written",
        MASS_MATRIX_SYMMETRIC=True,
        default_parameters=default_parameters,
        default_inputs=default_inputs,
        mass_matrix=mass_matrix,
        force_vector=force_vector,
        force_jacobians=force_jacobians,
        mass_matrix_times_derivative=mass_matrix_times_derivative,
        rhs=rhs,
        rhs_jacobian=rhs_jacobian,
        outputs=outputs,
        output_jacobians=output_jacobians,
        constraints=lambda t, y, p: np.zeros(0),
        constraint_jacobian=lambda t, y, p: np.zeros((0, n)),
        constraint_gamma=lambda t, y, yd, p: np.zeros(0),
    )
