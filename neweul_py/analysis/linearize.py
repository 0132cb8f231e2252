"""Linearization of a generated module about an operating point (equations.md §1).

About a reference ``(y0, ẏ0, u0)`` the equations of motion ``M(y) ÿ = F(y, ẏ, u)`` with
``F = q − k`` become

    M0 δÿ + P δẏ + Q δy = B δu,    δy_out = C δx + D δu,

with ``M0 = M(y0)``, ``P = −∂F/∂ẏ``, ``Q = −∂F/∂y + ∂(M ÿ0)/∂y``, ``B = ∂F/∂u`` and the output
Jacobians ``C = ∂y_out/∂x``, ``D = ∂y_out/∂u``. All derivatives come from the module's symbolically
generated Jacobians (``force_jacobians``, ``mass_matrix_times_derivative``, ``output_jacobians``).

Constrained systems (``CONSTRAINTS`` non-empty) are linearized *on the constraint manifold* in
minimal coordinates: the coordinates are partitioned into independent ``z`` and dependent ones
(:func:`~neweul_py.analysis.protocol.partition`), the admissible motions are ``δy = N δz`` with
``G(y0) N = 0`` and ``N[indep] = I``, and the multipliers are eliminated by projecting with
``N_Rᵀ``, ``G_R(y0) N_R = 0``:

    N_Rᵀ M0 N δz̈ + N_Rᵀ P N δż + N_Rᵀ (Q − ∂(G_Rᵀλ0)/∂y) N δz = N_Rᵀ B δu.

``G_R`` is the Jacobian of the reactions ``G_Rᵀ λ`` (the module's ``constraint_reaction_jacobian``;
it differs from ``G`` only for constraints on node frames of two-sided elastic bodies, whose
reactions enter the elastic rows through the left basis, equations.md §2). Where ``G_R = G``,
``N_R = N`` (:func:`~neweul_py.analysis.protocol.reaction_free_basis`); otherwise the model's
matrices are unsymmetric anyway. The term ``∂(G_Rᵀλ0)/∂y`` carries the stiffness that the
constraint forces produce through the curvature of the manifold (for a pendulum in Cartesian
coordinates it is *all* of the stiffness); it is obtained by central differences of the analytic
``G_R``. Constrained linearization is about rest points (``ẏ0 = 0``); away from an equilibrium
(``ÿ0 ≠ 0``) the curvature of the manifold acting on ``ÿ0`` is not included.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic import atomic_savez
from ..errors import DataError, NeweulError
from ..ffrf.loss_form import DAMPING_FORMS, loss_form
from ..files import load_npz
from . import protocol as proto
from .equilibrium import EquilibriumResult
from .module import GeneratedModel, ModelLike, as_model
from .results import check_output_path

__all__ = ["DAMPING_FORMS", "LinearModel", "linearize"]


@dataclass(frozen=True, repr=False)
class LinearModel:
    """A linear second-order model ``M0 δÿ + P δẏ + Q δy = B δu``, ``δy_out = C δx + D δu``.

    Attributes
    ----------
    M0, P, Q : ndarray (m, m)
        Mass, damping (incl. gyroscopic) and stiffness (incl. circulatory) matrices.
    B : ndarray (m, nu)
        Input matrix.
    C : ndarray (ny, 2m)
        Output matrix with respect to the first-order state ``[δz, δż]``.
    D : ndarray (ny, nu)
        Feed-through.
    coordinates : tuple of str
        Names of the (minimal) coordinates ``z`` of this model.
    inputs, outputs : tuple of str
        Names of ``u`` and of the module outputs (rows of ``C``).
    basis : ndarray (n, m)
        ``δy = basis · δz`` in the module's full coordinates (identity without constraints).
        The equations are projected with the same basis, but for constraints whose reactions
        differ from their Jacobian (node frames of two-sided elastic bodies: ``N_R``, see the
        module docstring).
    all_coordinates : tuple of str
        The module's coordinate names (rows of ``basis``).
    y0, yd0, u0, p : ndarray
        The operating point and the parameters.
    t : float
        Time of the operating point.
    lambda0 : ndarray
        Constraint multipliers at the operating point (empty without constraints).
    constraints : tuple of str
        Constraint names.
    input_rates : tuple of (str, tuple of str)
        For inputs that move frames (kinematic excitation), the names of the entries of
        ``inputs`` that hold their first and second time derivatives (``INPUT_RATES`` of the
        module); a harmonic input then acts through ``B_u + jω B_du − ω² B_ddu``.
    G : ndarray (m, m) or None
        The hysteretic matrix of the loss factors (``K + iG`` in the frequency domain,
        equations.md §1.1), projected like ``Q``; ``P`` holds its time-domain equivalent
        ``G/ω_ref``. ``None``: the module has no loss factors (``loss_matrix``).
    loss_reference_frequency : float or None
        ``f_ref`` [Hz] of ``G`` (``ω_ref = 2π f_ref``).
    """

    M0: np.ndarray
    P: np.ndarray
    Q: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    coordinates: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    basis: np.ndarray
    all_coordinates: tuple[str, ...]
    y0: np.ndarray
    yd0: np.ndarray
    u0: np.ndarray
    p: np.ndarray
    t: float = 0.0
    lambda0: np.ndarray = field(default_factory=lambda: np.zeros(0))
    constraints: tuple[str, ...] = ()
    input_rates: tuple[tuple[str, tuple[str, ...]], ...] = ()
    G: np.ndarray | None = None
    loss_reference_frequency: float | None = None

    def __repr__(self) -> str:
        return (f"LinearModel({self.n} coordinates ({', '.join(self.coordinates[:6])}"
                f"{', …' if self.n > 6 else ''}), {len(self.inputs)} inputs, "
                f"{len(self.outputs)} outputs, t = {self.t:g})")

    @property
    def n(self) -> int:
        """Number of (minimal) coordinates ``m``."""
        return self.M0.shape[0]

    @property
    def state_names(self) -> list[str]:
        """Names of the first-order state ``[z, ż]``."""
        return [*self.coordinates, *(f"d_{c}" for c in self.coordinates)]

    @property
    def has_loss(self) -> bool:
        """Whether the model carries a nonzero hysteretic matrix ``G``."""
        return self.G is not None and bool(np.any(self.G))

    def dynamic_stiffness(self, w: np.ndarray, damping: str = "loss") -> np.ndarray:
        """``Z(ω)`` (nf, m, m) for the angular frequencies ``w`` (equations.md §1.1).

        ``"loss"``: ``−ω² M0 + jω (P − G/ω_ref) + Q + jG`` — the loss factors as hysteretic
        damping, the rest of ``P`` viscous; ``"viscous"`` (and models without ``G``):
        ``−ω² M0 + jω P + Q``, the time-domain equivalent. The two agree at ``ω = ω_ref``.
        """
        if damping not in DAMPING_FORMS:
            raise NeweulError(f"unknown damping form {damping!r}; valid: "
                              f"{', '.join(DAMPING_FORMS)}")
        Q, P = self.Q, self.P
        if damping == "loss" and self.has_loss:
            Q, P = loss_form(Q, P, self.G, self.loss_reference_frequency)
        ww = np.asarray(w, dtype=float)[:, None, None]
        return -(ww**2) * self.M0 + 1j * ww * P + Q

    def first_order_pencil(self) -> tuple[np.ndarray, np.ndarray]:
        """``(Ã, E)`` with ``E ẋ = Ã x``: ``E = diag(I, M0)``, ``Ã = [[0, I], [−Q, −P]]``."""
        m = self.n
        eye = np.eye(m)
        e = np.zeros((2 * m, 2 * m))
        e[:m, :m] = eye
        e[m:, m:] = self.M0
        a = np.zeros((2 * m, 2 * m))
        a[:m, m:] = eye
        a[m:, :m] = -self.Q
        a[m:, m:] = -self.P
        return a, e

    def to_first_order(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """State-space matrices ``(A, B, C, D)`` of ``ẋ = A x + B u``, ``y = C x + D u``.

        ``A = [[0, I], [−M0⁻¹Q, −M0⁻¹P]]``, ``B = [[0], [M0⁻¹B]]`` (equations.md §1).
        """
        m = self.n
        rhs = np.linalg.solve(self.M0, np.hstack([self.Q, self.P, self.B]))
        a = np.zeros((2 * m, 2 * m))
        a[:m, m:] = np.eye(m)
        a[m:, :m] = -rhs[:, :m]
        a[m:, m:] = -rhs[:, m : 2 * m]
        b = np.zeros((2 * m, self.B.shape[1]))
        b[m:] = rhs[:, 2 * m :]
        return a, b, self.C.copy(), self.D.copy()

    def to_statespace(self) -> Any:
        """The first-order model as a :class:`scipy.signal.StateSpace`."""
        from scipy import signal

        return signal.StateSpace(*self.to_first_order())

    def to_control(self) -> Any:
        """The first-order model as a python-control ``StateSpace`` (named signals).

        Raises
        ------
        NeweulError
            When python-control is not installed.
        """
        try:
            import control
        except ImportError:
            raise NeweulError(
                "python-control is not installed (pip install control); "
                "use to_statespace() for a scipy.signal.StateSpace"
            ) from None
        a, b, c, d = self.to_first_order()
        return control.ss(
            a,
            b,
            c,
            d,
            inputs=list(self.inputs),
            outputs=list(self.outputs),
            states=self.state_names,
        )

    def output_rows(
        self, names: Sequence[str]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Rows that pick outputs by name, split by derivative order.

        ``δy_sel = Cy δz + Cyd δż + Cydd δz̈ + D δu``. A name is a module output, a coordinate
        (also a dependent one of a constrained model), ``d_<coordinate>`` (its velocity) or
        ``dd_<coordinate>`` (its acceleration).

        Returns
        -------
        Cy, Cyd, Cydd : ndarray (k, m)
        D : ndarray (k, nu)
        """
        m = self.n
        k = len(names)
        cy = np.zeros((k, m))
        cyd = np.zeros((k, m))
        cydd = np.zeros((k, m))
        d = np.zeros((k, self.B.shape[1]))
        for i, name in enumerate(names):
            if name in self.outputs:
                j = self.outputs.index(name)
                cy[i] = self.C[j, :m]
                cyd[i] = self.C[j, m:]
                d[i] = self.D[j]
                continue
            order, base = 0, name
            if base not in self.all_coordinates and base.startswith("dd_"):
                order, base = 2, base[3:]
            elif base not in self.all_coordinates and base.startswith("d_"):
                order, base = 1, base[2:]
            if base not in self.all_coordinates:
                valid = [
                    *self.outputs,
                    *self.all_coordinates,
                    *(f"d_{c}" for c in self.all_coordinates),
                    *(f"dd_{c}" for c in self.all_coordinates),
                ]
                proto.name_index(valid, name, "output")
            (cy, cyd, cydd)[order][i] = self.basis[self.all_coordinates.index(base)]
        return cy, cyd, cydd, d

    def input_columns(self, names: Sequence[str]) -> np.ndarray:
        """Column indices of the inputs ``names`` (error listing the valid inputs otherwise)."""
        return np.array([proto.name_index(self.inputs, nm, "input") for nm in names], dtype=int)

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the model to a ``.npz`` file (no pickles), atomically: matrices, names and
        operating point. Other suffixes are an error (the name is not changed silently)."""
        path = check_output_path(path, (".npz",), "linear models")
        return atomic_savez(
            path,
            M0=self.M0,
            P=self.P,
            Q=self.Q,
            B=self.B,
            C=self.C,
            D=self.D,
            basis=self.basis,
            y0=self.y0,
            yd0=self.yd0,
            u0=self.u0,
            p=self.p,
            t=np.array(self.t),
            lambda0=self.lambda0,
            coordinates=np.array(self.coordinates, dtype=str),
            all_coordinates=np.array(self.all_coordinates, dtype=str),
            inputs=np.array(self.inputs, dtype=str),
            outputs=np.array(self.outputs, dtype=str),
            constraints=np.array(self.constraints, dtype=str),
            input_rates=np.array(
                [[name, *rates, "", ""][:3] for name, rates in self.input_rates], dtype=str
            ).reshape(-1, 3),
            **({} if self.G is None else {
                "G": self.G, "loss_reference_frequency": np.array(
                    float(self.loss_reference_frequency))}),
        )

    @classmethod
    def load(cls, path: str | Path) -> LinearModel:
        """Read a model written by :meth:`save`.

        Raises
        ------
        DataError
            The file is not a regular file, not a valid ``.npz`` (:func:`neweul_py.files.load_npz`)
            or lacks an array of the model.
        """
        f = load_npz(path, "linear model file")
        try:
            names = ("coordinates", "all_coordinates", "inputs", "outputs", "constraints")
            kw: dict[str, Any] = {k: tuple(str(s) for s in f[k]) for k in names}
            for k in ("M0", "P", "Q", "B", "C", "D", "basis", "y0", "yd0", "u0", "p", "lambda0"):
                kw[k] = f[k]
            kw["t"] = float(f["t"])
            if "G" in f:
                kw["G"] = f["G"]
                kw["loss_reference_frequency"] = float(f["loss_reference_frequency"])
            if "input_rates" in f:
                kw["input_rates"] = tuple(
                    (str(row[0]), tuple(str(r) for r in row[1:] if r)) for row in f["input_rates"]
                )
        except (ValueError, TypeError, KeyError, IndexError) as exc:
            raise DataError(f"cannot read a linear model: {exc}", file=str(path)) from None
        return cls(**kw)


def linearize(
    module: ModelLike,
    y0: Any = None,
    yd0: Any = None,
    u0: Any = None,
    p: proto.ParameterLike = None,
    t: float = 0.0,
    *,
    independent: Sequence[str] | None = None,
) -> LinearModel:
    """Linearize a generated module about ``(y0, ẏ0, u0)`` (equations.md §1).

    Parameters
    ----------
    module
        A generated module (or its path).
    y0
        Coordinates of the operating point: array, mapping name → value (over the initial
        state), an
        :class:`~neweul_py.analysis.equilibrium.EquilibriumResult` (its ``y``, ``p`` and ``u`` are
        used), or ``None`` for the initial state of the module.
    yd0
        Velocities: array or mapping (default zero; must be zero for constrained modules).
    u0
        Inputs (default: ``default_inputs(t, p)``).
    p
        Parameters (``None``: defaults; mapping: overrides by name; array).
    t
        Time of the operating point.
    independent
        Constrained modules only: coordinates to use as minimal coordinates (default: the first
        ones in ``COORDINATES`` order that the constraints leave independent).

    Returns
    -------
    LinearModel
        ``M0, P, Q, B, C, D`` with ``Q`` including ``∂(M ÿ0)/∂y`` (and, with constraints, the
        projection on the constraint manifold described in the module docstring), and the
        hysteretic matrix ``G`` of the loss factors when the module has ``loss_matrix``.

    Examples
    --------
    >>> lin = linearize(mod, equilibrium(mod))                       # doctest: +SKIP
    >>> a, b, c, d = lin.to_first_order()                            # doctest: +SKIP
    """
    module = as_model(module)
    names = list(module.COORDINATES)
    n = len(names)
    if not module.first_order_state:
        raise NeweulError(
            f"linearize: state size {module.STATE_SIZE} != 2 × {n} coordinates; first-order "
            "states beyond [y, ẏ] are not supported yet"
        )
    if isinstance(y0, EquilibriumResult):
        eq = y0
        y0 = eq.y
        p = eq.p if p is None else p
        u0 = eq.u if u0 is None else u0
        t = eq.t
    pv = proto.resolve_parameters(module, p)
    y_init = np.asarray(module.INITIAL_STATE, dtype=float)[:n].copy()
    y = proto.override_vector(y_init, names, y0, "coordinate")
    yd = proto.override_vector(np.zeros(n), names, yd0, "coordinate")
    u = proto.resolve_inputs(module, t, pv, u0)
    inputs = tuple(module.INPUTS)
    outputs = tuple(module.OUTPUTS)
    cnames = tuple(module.CONSTRAINTS)

    m0 = np.asarray(module.mass_matrix(t, y, pv), dtype=float)
    force = np.asarray(module.force_vector(t, y, yd, pv, u), dtype=float)
    f_y, f_yd, f_u = (np.asarray(a, dtype=float) for a in module.force_jacobians(t, y, yd, pv, u))
    f_u = f_u.reshape(n, len(inputs))
    x0 = np.concatenate([y, yd])
    if outputs:
        c_full, d_out = (np.asarray(a, dtype=float) for a in module.output_jacobians(t, x0, pv, u))
        c_full = c_full.reshape(len(outputs), 2 * n)
        d_out = d_out.reshape(len(outputs), len(inputs))
    else:
        c_full, d_out = np.zeros((0, 2 * n)), np.zeros((0, len(inputs)))

    if cnames:
        indep, basis, left, ydd0, lam0, q_lam = _manifold(module, t, y, yd, pv, m0, force,
                                                          independent)
    else:
        proto.check_mass_matrix(m0, names)
        indep, basis = np.arange(n), np.eye(n)
        left = basis
        ydd0, lam0, q_lam = np.linalg.solve(m0, force), np.zeros(0), 0.0
    q_mat = -f_y - q_lam
    if np.any(ydd0):
        q_mat = q_mat + np.asarray(module.mass_matrix_times_derivative(t, y, pv, ydd0))
    nt = left.T
    g_loss, f_ref = None, None
    if module.loss_matrix is not None:
        g_loss = nt @ np.asarray(module.loss_matrix(t, x0, pv, u), dtype=float) @ basis
        f_ref = float(module.LOSS_REFERENCE_FREQUENCY)
    two = np.zeros((2 * n, 2 * indep.size))
    two[:n, : indep.size] = basis
    two[n:, indep.size :] = basis
    return LinearModel(
        M0=nt @ m0 @ basis,
        P=nt @ (-f_yd) @ basis,
        Q=nt @ q_mat @ basis,
        B=nt @ f_u,
        C=c_full @ two,
        D=d_out,
        coordinates=tuple(names[i] for i in indep),
        inputs=inputs,
        outputs=outputs,
        basis=basis,
        all_coordinates=tuple(names),
        y0=y,
        yd0=yd,
        u0=u,
        p=pv,
        t=float(t),
        lambda0=lam0,
        constraints=cnames,
        input_rates=tuple(
            (name, tuple(rates))
            for name, rates in sorted(module.INPUT_RATES.items())
        ),
        G=g_loss,
        loss_reference_frequency=f_ref,
    )


def _manifold(
    module: GeneratedModel,
    t: float,
    y: np.ndarray,
    yd: np.ndarray,
    pv: np.ndarray,
    m0: np.ndarray,
    force: np.ndarray,
    independent: Sequence[str] | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Minimal coordinates of a constrained module at a rest point (see the module docstring).

    Returns
    -------
    indep, basis, left, ydd0, lam0, dgl
        Independent coordinate indices, ``N``, ``N_R``, ``ÿ0`` and ``λ0`` of the augmented
        system, and ``∂(G_Rᵀλ0)/∂y``.
    """
    names = list(module.COORDINATES)
    cnames = list(module.CONSTRAINTS)
    if np.any(yd):
        raise NeweulError(
            "linearize: constrained modules are linearized about rest points (ẏ0 = 0)"
        )
    g = np.asarray(module.constraints(t, y, pv), dtype=float)
    g_jac = np.asarray(module.constraint_jacobian(t, y, pv), dtype=float).reshape(
        len(cnames), len(names)
    )
    tol = 1e-8 * max(1.0, np.abs(g_jac).max() * max(1.0, np.abs(y).max()))
    if np.abs(g).max() > tol:
        worst = cnames[int(np.argmax(np.abs(g)))]
        raise NeweulError(
            f"linearize: the operating point violates the constraints (|g| = {np.abs(g).max():.3g}"
            f", worst {worst}); use equilibrium() or a consistent initial state"
        )
    redundant = proto.redundant_constraints(g_jac, cnames)
    if redundant:
        raise NeweulError("redundant constraints at the operating point: " + "; ".join(redundant))
    indep, dep = proto.partition(g_jac, names, independent)
    basis = proto.partition_basis(g_jac, indep, dep)
    g_r = g_jac
    if module.separate_reactions:
        g_r = proto.constraint_reaction_jacobian(module, t, y, pv)
    left = proto.reaction_free_basis(g_r, g_jac, indep, dep, basis)
    proto.check_mass_matrix(m0, names, basis, left)
    gamma = np.asarray(module.constraint_gamma(t, y, yd, pv), dtype=float)
    ydd0, lam0 = proto.augmented_solve(m0, g_jac, force, -gamma, g_r)
    return (indep, basis, left, ydd0, lam0,
            proto.constraint_force_jacobian(module, t, y, pv, lam0))
