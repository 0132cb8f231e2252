"""Parametric elastic bodies: samples, interpolation weights, file (``docs/equations.md`` §4).

A :class:`ParametricBody` holds ``k`` samples ``X̃_i`` of a reduced body in common coordinates
at the sample values ``p_1 < … < p_k`` of its parameter, and :meth:`ParametricBody.at`
interpolates ``X(p) = Σ_i w_i(p) X̃_i`` — every stored quantity with the same weights (§4,
step 6), which sum to one: linear, the cubic spline's cardinal functions (in an
interpolation coordinate ``ξ(p)`` if the body has one, §4.1), or the cubic or quintic
Hermite bases with the samples' slopes and curvatures (§4.2), all from
:mod:`neweul_py.ffrf.parametric` (one home, the generated module uses the same). Two
builders make the samples: :func:`~neweul_py.elastic.parametric.local_interpolation.interpolate`
(Panzer et al. 2010, the local bodies brought to common coordinates) and
:func:`~neweul_py.elastic.parametric.global_basis.global_parametric_body` (one global basis). This
module also holds what both share — the checks of the samples, their stacked loss data, the
central differences of the slopes and curvatures, the coordinate table — and the file format
(``docs/reduced-body-format.md``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import DataError
from ...ffrf.parametric import HERMITE_ORDERS, ffrf_weights, weight_polynomials
from .fields import CARRIED_INVARIANTS, BodyFields
from .parametric_format import (
    BASES,
    COMPACT_VERSION,
    COORDINATE_VERSION,
    CURVATURE_PREFIX,
    CURVATURES_VERSION,
    GROUP_ORDER,
    INTERPOLATIONS,
    KIND_GROUPS,
    MIRROR_VERSION,
    PARAMETRIC_BODY_VERSION,
    READABLE_VERSIONS,
    SLOPE_PREFIX,
    SLOPES_VERSION,
    STACKED,
    VARYING_VERSION,
    checked_slope_step,
    validate_parametric,
)
from .reduced import INVARIANT_PREFIX, ReducedBody
from .static import STATIC_KEYS, STATIC_PREFIX, StaticDeflection, residual_bound

__all__ = [
    "BASES",
    "CARRIED_INVARIANTS",
    "COMPACT_VERSION",
    "COORDINATE_VERSION",
    "CURVATURES_VERSION",
    "CURVATURE_PREFIX",
    "GROUP_ORDER",
    "INTERPOLATIONS",
    "KIND_GROUPS",
    "MIRROR_VERSION",
    "PARAMETRIC_BODY_VERSION",
    "READABLE_VERSIONS",
    "SLOPES_VERSION",
    "SLOPE_PREFIX",
    "STACKED",
    "VARYING_VERSION",
    "ParametricBody",
    "checked_slope_step",
]


@dataclass(frozen=True, eq=False, kw_only=True)
class ParametricBody(BodyFields):
    """A parametric elastic body: local reduced models at samples, in common coordinates.

    Built by :func:`interpolate` (``docs/equations.md`` §4); :meth:`at` gives the
    :class:`~neweul_py.elastic.bodies.reduced.ReducedBody` at a parameter value. ``k`` =
    number of samples, ``r`` = order, ``nk`` = kept DOFs. Plain immutable data: the fields
    of :class:`~neweul_py.elastic.bodies.fields.BodyFields`, stacked over the samples (the
    sample their first axis) where they vary, and those below, checked on construction by
    :func:`~neweul_py.elastic.bodies.parametric_format.validate_parametric` (keyword
    arguments only).

    Parameters
    ----------
    parameter
        Name of the parameter (e.g. ``"pressure"``).
    samples
        (k,) strictly increasing sample values ``p_1 < … < p_k``.
    T, L
        (k, r, r) right and left transformations ``T_i = Rᵀ S V_i``,
        ``L_i = (W_iᵀ S_W R)⁻¹``; the local coordinates map to the common ones as
        ``q̃ = T_i q_i``.
    R
        (n or nk, r) common right subspace, orthonormal in the scaled rows ``S x`` (rows of
        the FE model for ``basis="full"``, of the kept DOFs for ``"kept"``);
        ``q̃ = Rᵀ S x``.
    singular_values
        Singular values of the (weighted) stacked sample bases; ``σ_{r+1}/σ_1`` measures
        how much of the sample subspaces the ``r`` common coordinates leave out.
    svd_weights
        (k,) weights ``w_i`` of the samples in the SVD.
    basis
        ``"full"`` or ``"kept"`` (module docstring).
    two_sided
        Petrov–Galerkin (``True``) or Galerkin data.
    row_scaling, row_scale, left_row_scale, pressure_weight
        How the rows were scaled before the SVD (module docstring): ``"none"``
        (``row_scale`` is ``None``, ``S = S_W = I``), ``"kind"`` or ``"given"`` (an array
        passed to :func:`interpolate`), with ``row_scale`` = the diagonal of ``S`` and
        ``left_row_scale`` that of ``S_W`` (``None``: ``S_W = S``), one positive factor per
        row of ``R``; ``pressure_weight`` of a ``"kind"`` scaling (``None`` otherwise).
    interpolation
        Default weight function of :meth:`at`: ``"linear"``, ``"cubic"``, ``"hermite"``
        (with :attr:`slopes`, and only then) or ``"quintic-hermite"`` (with :attr:`slopes`
        and :attr:`curvatures`, and only then).
    coordinate, coordinate_name
        Optional interpolation coordinate ``ξ(σ)`` (``docs/equations.md`` §4.1): a (2, n)
        table of knots ``σ_j`` (including every sample, spanning exactly their range) and
        strictly monotone values ``ξ_j``; the cubic weights are then taken in ``ξ``
        (:func:`~neweul_py.ffrf.parametric.weight_polynomials`), and its name (e.g.
        ``tm_volume_displacement``) says what ``ξ`` is.
    sample_sources, sample_methods, sample_settings
        Per sample: the ``source``, ``method`` and ``settings`` of the local body.
    slopes
        Optional sample slopes ``dX/dσ`` at every sample (``docs/equations.md`` §4.2), the
        data of ``hermite`` weights (present exactly when :attr:`interpolation` is
        ``"hermite"``): ``key → (k, …)`` for every interpolated stack — ``M``,
        ``D``, ``K``, ``B``, ``C``, ``V_kept``, ``W_kept`` (and ``G``, ``V``, ``W`` when
        stored), ``invariants/<name>`` for the floating-point invariants and
        ``static/<key>`` for the static state (``static/residual`` zero) — each of the shape
        of its stack
        (:func:`~neweul_py.elastic.parametric.global_basis.global_parametric_body` makes
        them from FE models next to the samples).
    curvatures
        Optional sample curvatures ``d²X/dσ²`` of the same keys and shapes (the data of
        ``quintic-hermite`` weights, with :attr:`slopes`; ``static/residual`` zero): second
        differences of the same FE models next to the samples (equations.md §4.2).
    slope_step, slope_sources
        Where the slopes came from (optional, with :attr:`slopes` only): the step ``δ`` of
        the models next to the samples and their sources (``file``, ``fingerprint``),
        ``2k`` of them, every sample's ``σ_i − δ`` model, then every ``σ_i + δ`` one.
    **fields
        The :class:`~neweul_py.elastic.bodies.fields.BodyFields` of the samples in the
        common coordinates: (k, r, r) ``X̃_i = L_i X_r,i T_i⁻¹`` for ``M``, ``D``, ``K``
        and ``G`` (interpolated like ``K``, one reference frequency), (k, r, n_in)
        ``B̃_i = L_i B_r,i``, (k, n_out, r) ``C̃_i = C_r,i T_i⁻¹``, (k, nk, r)
        ``V_kept T_i⁻¹`` and ``W_kept L_iᵀ``, optional (k, n, r) ``V_i T_i⁻¹`` and
        ``W_i L_iᵀ`` (stored together); the names, kept nodes and DOFs and
        ``full_dof_kind`` (the FE rows of ``R`` for ``basis="full"``, of ``V``, ``W``) common
        to all samples; the invariants of the transformed samples stacked to (k, …), those
        that are not floating point (format tag, names, node ids, flags) and
        :data:`CARRIED_INVARIANTS` (``loss.f_ref``) equal for all samples; the static
        states stacked (``q`` in the common coordinates), mixed by :meth:`at` with the same
        weights (the residual: the largest of the samples mixed).

    Raises
    ------
    DataError
        Data that contradict the format (``docs/reduced-body-format.md``, "Checks of a
        body" and "Checks of a parametric body").
    """

    parameter: str
    samples: np.ndarray
    T: np.ndarray
    L: np.ndarray
    R: np.ndarray
    singular_values: np.ndarray
    svd_weights: np.ndarray
    basis: str = "full"
    two_sided: bool = True
    row_scaling: str = "none"
    row_scale: np.ndarray | None = None
    left_row_scale: np.ndarray | None = None
    pressure_weight: float | None = None
    interpolation: str = "linear"
    sample_sources: tuple[Mapping[str, Any], ...] = ()
    sample_methods: tuple[str, ...] = ()
    sample_settings: tuple[Mapping[str, Any], ...] = ()
    format_version: int = PARAMETRIC_BODY_VERSION
    coordinate: np.ndarray | None = None
    coordinate_name: str = ""
    slopes: Mapping[str, np.ndarray] | None = None
    curvatures: Mapping[str, np.ndarray] | None = None
    slope_step: float | None = None
    slope_sources: tuple[Mapping[str, Any], ...] = ()

    def __post_init__(self) -> None:
        validate_parametric(self)

    def slope_keys(self) -> tuple[str, ...]:
        """The keys :attr:`slopes` must hold (every interpolated stack of this body)."""
        keys = [*STACKED, *(key for key in ("G", "V", "W") if self[key] is not None)]
        keys += [INVARIANT_PREFIX + n for n, a in (self.invariants or {}).items()
                 if a.dtype.kind == "f"]
        if self.static is not None:
            keys += [STATIC_PREFIX + key for key in STATIC_KEYS]
        return tuple(keys)

    def stack(self, key: str) -> np.ndarray:
        """The sample stack (k, …) of a :meth:`slope_keys` key."""
        if key.startswith(INVARIANT_PREFIX):
            return self.invariants[key[len(INVARIANT_PREFIX):]]
        if key.startswith(STATIC_PREFIX):
            return self.static[key[len(STATIC_PREFIX):]]
        return self[key]


    # ------------------------------------------------------------------ properties
    @property
    def row_kinds(self) -> np.ndarray | None:
        """DOF kinds of the rows of ``R`` (``full_dof_kind`` or ``dof_kind``), if known."""
        return self.dof_kind if self.basis == "kept" else self.full_dof_kind

    @property
    def group_scales(self) -> dict[str, float]:
        """The factor of ``S`` per group of DOF kinds (translation, rotation, pressure).

        Empty when the kinds of the rows are not known; for ``"given"`` scalings, a group
        whose rows have different factors is reported as NaN.
        """
        return self._groups(self.row_scale)

    @property
    def left_group_scales(self) -> dict[str, float]:
        """As :attr:`group_scales`, for the left scaling ``S_W``."""
        return self._groups(self.row_scale if self.left_row_scale is None
                            else self.left_row_scale)

    def _groups(self, scale: np.ndarray | None) -> dict[str, float]:
        kinds = self.row_kinds
        if kinds is None:
            return {}
        groups = np.array([KIND_GROUPS[k] for k in kinds])
        scale = np.ones(kinds.size) if scale is None else scale
        out = {}
        for g in GROUP_ORDER:
            v = scale[groups == g]
            if v.size:
                out[g] = float(v[0]) if np.all(v == v[0]) else float("nan")
        return out

    @property
    def name(self) -> str:
        """The FE model name the samples share (``sample_sources``), ``"FIRST … LAST"``
        when they differ, ``"?"`` when none is recorded."""
        names = [str(src.get("name")) for src in self.sample_sources if src.get("name")]
        if not names:
            return "?"
        return names[0] if len(set(names)) == 1 else f"{names[0]} … {names[-1]}"

    @property
    def order(self) -> int:
        """Order ``r`` of the common coordinates."""
        return self.M.shape[1]

    @property
    def n_samples(self) -> int:
        """Number of samples ``k``."""
        return self.samples.size

    @property
    def range(self) -> tuple[float, float]:
        """The sampled parameter range ``(p_1, p_k)``; :meth:`at` refuses values outside."""
        return float(self.samples[0]), float(self.samples[-1])

    # ------------------------------------------------------------------ evaluation
    def weights(self, p: float, interpolation: str | None = None) -> np.ndarray:
        """Interpolation weights ``w_i(p)`` of the samples (they sum to one).

        ``"linear"``: the hat functions of the samples, i.e. linear between the two
        neighbouring samples, zero elsewhere. ``"cubic"``: the cardinal functions of the
        not-a-knot cubic spline through the samples (``S_i(p_j) = δ_ij``; two samples give
        the linear weights, three a parabola), in the interpolation coordinate
        :attr:`coordinate` when the body has one. ``"hermite"`` (a body with
        :attr:`slopes`): ``2k`` weights, the first ``k`` of the samples and the last ``k`` of
        their slopes — the piecewise cubic Hermite basis (equations.md §4.2);
        ``"quintic-hermite"`` (with :attr:`curvatures` too): ``3k``, the third ``k`` of the
        curvatures — the piecewise quintic Hermite basis. At a sample
        the weight vector is exactly the unit vector, so the sample's matrices are returned
        bit for bit. The weights are those of the generated module
        (:mod:`neweul_py.ffrf.parametric`, one home).

        Raises
        ------
        DataError
            ``p`` not finite or outside ``[p_1, p_k]`` (no extrapolation), or an unknown
            interpolation.
        """
        kind = self.interpolation if interpolation is None else interpolation
        if kind not in INTERPOLATIONS:
            raise DataError(f"unknown interpolation {kind!r} (one of "
                            f"{', '.join(INTERPOLATIONS)})", None, "interpolation")
        blocks = 1 + HERMITE_ORDERS.get(kind, 0)
        if blocks > 1 + (self.slopes is not None) + (self.curvatures is not None):
            raise DataError(f"parametric body {self.name!r} holds no sample "
                            f"{'slopes' if self.slopes is None else 'curvatures'}: {kind} "
                            "weights need them", None, "interpolation")
        if kind != self.interpolation and self.coordinate is not None:
            raise DataError(f"parametric body {self.name!r} has the interpolation "
                            f"coordinate {self.coordinate_name!r}: its weights are "
                            f"{self.interpolation!r}", None, "interpolation")
        try:
            p = float(p)
        except (TypeError, ValueError):
            raise DataError(f"must be a number, got {p!r}", None, self.parameter) from None
        s = self.samples
        lo, hi = self.range
        if not np.isfinite(p) or p < lo or p > hi:
            raise DataError(f"parametric body {self.name!r}: {self.parameter} = {p!r} is "
                            f"outside the sampled range [{float(lo)!r}, {float(hi)!r}]; the "
                            "parametric body does not extrapolate (add a sample)", None,
                            self.parameter)
        w = np.zeros(blocks * s.size)
        hit = np.flatnonzero(s == p)
        if hit.size:
            w[hit[0]] = 1.0
            return w
        if kind == "linear":
            j = int(np.searchsorted(s, p)) - 1      # s[j] < p < s[j + 1]
            t = (p - s[j]) / (s[j + 1] - s[j])
            w[j], w[j + 1] = 1.0 - t, t
            return w
        breaks, c = weight_polynomials(s, kind, self.coordinate)
        return np.asarray(ffrf_weights(breaks, c, p, self.name), dtype=np.float64)

    def mix(self, key: str, w: np.ndarray) -> np.ndarray:
        """``Σ_i w_i X̃_i`` of one stack (:meth:`stack`; with Hermite weights its slopes and
        curvatures too) for the weights ``w`` of :meth:`weights`: what :meth:`at` does for
        every stack, for one quantity alone (e.g. the output rows ``"C"``)."""
        idx = np.flatnonzero(w)
        k = self.n_samples
        stack = self.stack(key)
        if idx.size == 1 and idx[0] < k:
            return stack[idx[0]].copy()
        out = np.einsum("i,i...->...", w[idx[idx < k]], stack[idx[idx < k]])
        for b, data in enumerate((self.slopes, self.curvatures)[:w.size // k - 1], 1):
            j = idx[(idx >= b * k) & (idx < (b + 1) * k)] - b * k   # Hermite blocks
            out += np.einsum("i,i...->...", w[j + b * k], data[key][j])
        return out

    def at(self, p: float, interpolation: str | None = None) -> ReducedBody:
        """The reduced body at parameter value ``p``: ``X(p) = Σ_i w_i(p) X̃_i`` (§4, step 5).

        Every stored quantity — ``M``, ``D``, ``K``, ``B``, ``C``, ``V_kept``, ``W_kept``, the
        full bases, the invariants and the static state — is interpolated with the same
        weights (:meth:`weights`), so the body stays consistent (§4, step 6). What is one
        value for all samples is carried: the non-float invariants and
        :data:`CARRIED_INVARIANTS` (the loss reference frequency ``loss.f_ref``). The static
        state's relative residual is not: a ratio of norms, mixed with signed (cubic)
        weights it can turn negative; the body's ``static.residual`` is the bound
        ``max_i r_i`` over the samples with a nonzero weight
        (:func:`~neweul_py.elastic.bodies.static.residual_bound`).

        Parameters
        ----------
        p
            Parameter value in ``[p_1, p_k]``.
        interpolation
            One of :data:`INTERPOLATIONS` the body has the data of (default:
            :attr:`interpolation`).

        Returns
        -------
        ReducedBody
            ``method="interpolated"``, ``parameters={name: p}``; ``settings`` name the
            parameter, the samples and the weights. ``source`` holds what all samples share
            (model name, kind, ``n_dofs``, density) and the samples' fingerprints; at a sample
            it is that sample's source, fingerprint included (the body there is a
            state-space equivalent of the local model, so ``compare_frf`` against the FE
            model of that sample is meaningful).

        Examples
        --------
        >>> pb = interpolate(bodies, [0.0, 0.5, 1.0], parameter="pressure")  # doctest: +SKIP
        >>> body = pb.at(0.3)                                                # doctest: +SKIP
        """
        kind = self.interpolation if interpolation is None else interpolation
        w = self.weights(p, kind)

        def mix(key: str) -> np.ndarray:
            return self.mix(key, w)

        arrays = {key: mix(key) for key in STACKED}
        if self.G is not None:
            arrays.update(G=mix("G"), loss_reference_frequency=self.loss_reference_frequency)
        V = None if self.V is None else mix("V")
        W = None if self.W is None else mix("W")
        inv = None
        if self.invariants is not None:
            inv = {}
            for name, a in self.invariants.items():
                mixed = a.dtype.kind == "f" and name not in CARRIED_INVARIANTS
                inv[name] = mix(INVARIANT_PREFIX + name) if mixed else a[0].copy()
        hit = np.flatnonzero(self.samples == float(p))
        if hit.size:
            source = dict(self.sample_sources[hit[0]])
        else:
            first, rest = self.sample_sources[0], self.sample_sources[1:]
            source = {key: v for key, v in first.items() if key != "fingerprint"
                      and all(s.get(key) == v for s in rest)}
            prints = [s.get("fingerprint") for s in self.sample_sources]
            if any(f is not None for f in prints):
                source["sample_fingerprints"] = prints
        settings = {
            "two_sided": self.two_sided, "parameter": self.parameter, "value": float(p),
            "interpolation": kind, "samples": self.samples.tolist(), "weights": w.tolist(),
            **({"coordinate": self.coordinate_name} if self.coordinate is not None else {}),
            "basis": self.basis, "row_scaling": self.row_scaling,
            "pressure_weight": self.pressure_weight,
            "sample_methods": list(self.sample_methods),
        }
        return ReducedBody(
            **arrays, input_names=self.input_names, output_names=self.output_names,
            nodes=self.nodes.copy(), kept_dofs=self.kept_dofs.copy(),
            dof_node=self.dof_node.copy(), dof_kind=self.dof_kind.copy(), V=V, W=W,
            full_dof_kind=None if V is None else self.full_dof_kind,
            method="interpolated", settings=settings, source=source, invariants=inv,
            parameters={self.parameter: float(p)},
            static=None if self.static is None else StaticDeflection(
                **{key: mix(STATIC_PREFIX + key) for key in STATIC_KEYS if key != "residual"},
                residual=residual_bound(self.static.residual, w)),
        )
