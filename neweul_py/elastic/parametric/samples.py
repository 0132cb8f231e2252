"""The samples of a parametric body: checks, stacks, derivatives (``docs/equations.md`` §4).

What both builders of a parametric body share (the local bodies in common coordinates,
:mod:`~neweul_py.elastic.parametric.local_interpolation`, and the global basis,
:mod:`~neweul_py.elastic.parametric.global_basis`): the checks that bodies are samples of one
family, the sample values, their stacked loss data, the central differences of the slopes and
curvatures (§4.2) and the interpolation-coordinate table (§4.1).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from ...errors import DataError
from ...ffrf.parametric import HERMITE_ORDERS, coordinate_problem
from ...ffrf.varying import VARYING_TOLERANCE, entry_scale
from ..bodies.parametric import checked_slope_step
from ..bodies.reduced import INVARIANT_PREFIX, ReducedBody
from ..bodies.static import STATIC_PREFIX

__all__ = [
    "bodies_stack",
    "body_label",
    "central_curvatures",
    "central_slopes",
    "check_samples",
    "coordinate_table",
    "hermite_kind",
    "model_sources",
    "sample_values",
    "stacked_loss",
    "structured_derivatives",
]


    # ------------------------------------------------------------------ file I/O


def bodies_stack(bodies: Sequence[ReducedBody], key: str) -> np.ndarray:
    """The (k, …) stack over reduced bodies of a :meth:`ParametricBody.slope_keys` key
    (``M`` …, ``invariants/<name>``, ``static/<key>``)."""
    if key.startswith(INVARIANT_PREFIX):
        return np.stack([np.asarray(b.invariants[key[len(INVARIANT_PREFIX):]]) for b in bodies])
    if key.startswith(STATIC_PREFIX):
        return np.stack([b.static[key[len(STATIC_PREFIX):]] for b in bodies])
    return np.stack([b[key] for b in bodies])


def model_sources(fes: Iterable[Any]) -> tuple[dict[str, Any], ...]:
    """``{"file", "fingerprint"}`` of each FE model (the :attr:`ParametricBody.slope_sources`
    of its slope models)."""
    return tuple({"file": fe.source, "fingerprint": fe.fingerprint} for fe in fes)


def hermite_kind(interpolation: str | None, slopes: bool) -> str:
    """The weights of a parametric body built with (``slopes``) or without models next to
    its samples: by default ``"quintic-hermite"`` (the models give the slopes and the
    curvatures, equations.md §4.2) or ``"cubic"``; with the models only Hermite weights.

    Raises
    ------
    DataError
        Weights without derivatives asked for with the models (naming ``interpolation``).
    """
    if interpolation is None:
        return "quintic-hermite" if slopes else "cubic"
    if slopes and interpolation not in HERMITE_ORDERS:
        raise DataError(f"the models next to the samples give Hermite weights "
                        f"({', '.join(HERMITE_ORDERS)}), not {interpolation!r}", None,
                        "interpolation")
    return interpolation


def central_slopes(minus: Any, plus: Any, step: float, keys: Sequence[str]
                   ) -> dict[str, np.ndarray]:
    """Sample slopes by central differences (``docs/equations.md`` §4.2): per key
    ``(plus(key) − minus(key)) / (2 step)``, ``minus``/``plus`` giving the (k, …) stacks at
    the samples ∓ ``step`` (:meth:`ParametricBody.stack`, or :func:`bodies_stack` of
    their bodies); the residual of a static state gets no slope (zero).

    Raises
    ------
    DataError
        A step that is not a positive finite number.
    """
    step = checked_slope_step(step)
    return _shared({key: (minus(key), plus(key)) for key in keys},
                   lambda key, m, p: (p - m) / (2.0 * step)
                   * (0.0 if key == STATIC_PREFIX + "residual" else 1.0))


def _shared(arguments: Mapping[str, tuple[np.ndarray, ...]],
            derivative: Callable[..., np.ndarray]) -> dict[str, np.ndarray]:
    """``key → derivative(key, *arguments[key])``, computed once for keys whose arguments
    are the same arrays (an invariant that is the body's own ``M``, ``K``, ``D``, ``G``)."""
    out, done = {}, {}
    for key, args in arguments.items():
        ident = (key == STATIC_PREFIX + "residual", *(id(a) for a in args))
        if ident not in done:
            done[ident] = derivative(key, *args)
        out[key] = done[ident]
    return out


def central_curvatures(minus: Any, centre: Any, plus: Any, step: float,
                       keys: Sequence[str]) -> dict[str, np.ndarray]:
    """Sample curvatures by central second differences (``docs/equations.md`` §4.2): per
    key ``(plus(key) − 2 centre(key) + minus(key)) / step²`` (O(step²)), the stacks as in
    :func:`central_slopes` and ``centre`` those of the samples themselves, defined alike
    (the same projection); the residual of a static state gets none (zero).

    Raises
    ------
    DataError
        A step that is not a positive finite number.
    """
    step = checked_slope_step(step)
    return _shared({key: (minus(key), centre(key), plus(key)) for key in keys},
                   lambda key, m, c, p: (p - 2.0 * c + m) / step**2
                   * (0.0 if key == STATIC_PREFIX + "residual" else 1.0))


def structured_derivatives(values: Callable[[str], np.ndarray],
                           derivatives: Sequence[Mapping[str, np.ndarray]],
                           proportional: Mapping[str, tuple[str, float]] | None = None,
                           tol: float = VARYING_TOLERANCE) -> list[dict[str, np.ndarray]]:
    """Slopes and curvatures (:func:`central_slopes`, :func:`central_curvatures`; one dict
    per set) with the structure of the samples they belong to (``docs/equations.md`` §4.2):

    * where a square stack's samples are symmetric (``|X_ij − X_ji| ≤ tol · scale`` at every
      sample, :func:`~neweul_py.ffrf.varying.entry_scale`), its derivative is made symmetric,
      ``(Y_ij + Y_ji)/2``;
    * ``proportional`` ``key → (other, c)``: where ``X_key = c X_other`` at every sample
      within the same bound, the derivative of ``key`` is ``c`` times the other's.

    The central differences of nearby FE models cancel the samples' leading digits: their
    round-off is the samples' magnified by ``span/step`` (slopes) or ``(span/step)²``
    (curvatures) — in the middle ear ~2·10⁻¹⁴ and ~3·10⁻¹¹ of the entries' scale — and it
    breaks the symmetry of the membrane's blocks and ``D = G/ω_ref``, which the exact
    derivatives keep. ``values(key)``: the (k, …) stack of the samples; the structure of
    the samples is found once for all sets, and a derivative shared by keys is fixed once.
    """
    symmetric, seen, scaled = {}, {}, {}
    for key, d in derivatives[0].items() if derivatives else ():
        if d.ndim == 3 and d.shape[1] == d.shape[2]:
            x = values(key)
            if id(x) not in seen:           # the samples of two keys may be one array
                seen[id(x)] = (x, np.all(np.abs(x - x.transpose(0, 2, 1))
                                         <= tol * entry_scale(x), axis=0))
            symmetric[key] = seen[id(x)][1]
    for key, (other, c) in (proportional or {}).items():
        if key in derivatives[0] and other in derivatives[0]:
            x = values(key)
            if x.shape == values(other).shape and np.all(
                    np.abs(x - c * values(other)) <= tol * entry_scale(x)):
                scaled[key] = (other, c)
    out = []
    for given in derivatives:
        fixed, done = dict(given), {}
        for key, d in given.items():
            sym = symmetric.get(key)
            if sym is None or not sym.any():
                continue
            if id(d) not in done:                       # a derivative shared by two keys
                done[id(d)] = np.where(sym, 0.5 * (d + d.transpose(0, 2, 1)), d)
            fixed[key] = done[id(d)]
        for key, (other, c) in scaled.items():
            ident = (id(fixed[other]), c)
            if ident not in done:
                done[ident] = c * fixed[other]
            fixed[key] = done[ident]
        out.append(fixed)
    return out


def stacked_loss(bodies: Sequence[ReducedBody]) -> dict[str, Any]:
    """``{"G": (k, r, r), "loss_reference_frequency": f}`` of sample bodies that all carry
    a hysteretic matrix, ``{}`` when none does; a :class:`DataError` naming the sample when
    only some do or their reference frequencies differ."""
    has = [b.G is not None for b in bodies]
    if not any(has):
        return {}
    if not all(has):
        i = has.index(False)
        raise DataError(f"sample {i + 1} has no hysteretic matrix G, sample "
                        f"{has.index(True) + 1} has one (loss factors in some samples only)",
                        None, "G")
    f = {b.loss_reference_frequency for b in bodies}
    if len(f) != 1:
        raise DataError(f"the samples' loss reference frequencies differ: {sorted(f)} Hz",
                        None, "loss_reference_frequency")
    return {"G": np.stack([b.G for b in bodies]), "loss_reference_frequency": f.pop()}


# ---------------------------------------------------------------------- interpolate
def body_label(labels: Sequence[str] | None, i: int) -> str:
    """``body i`` (1-based) and its label, for errors about the samples."""
    return f"body {i + 1}" + (f" ({labels[i]})" if labels is not None else "")


def check_samples(bodies: Sequence[ReducedBody], labels: Sequence[str] | None = None) -> None:
    """Refuse bodies that are not samples of one family (same FE discretization, DOFs, I/O);
    ``labels`` (e.g. the file names) name the bodies in the error."""
    ref = bodies[0]

    def fail(i: int, what: str) -> None:
        raise DataError(f"{body_label(labels, i)} does not match {body_label(labels, 0)}: {what}; "
                        "the samples of a "
                        "parametric body must be reductions of one FE discretization with "
                        "the same order, kept nodes, inputs and outputs", None,
                        f"bodies[{i}]")

    for i, b in enumerate(bodies[1:], start=1):
        if b.order != ref.order:
            fail(i, f"order {b.order} vs {ref.order} (T_i = Rᵀ V_i must be square)")
        if b.two_sided != ref.two_sided:
            fail(i, "one-sided vs two-sided data")
        for key in ("n_dofs", "kind", "density"):
            a, c = b.source.get(key), ref.source.get(key)
            if a is not None and c is not None and a != c:
                fail(i, f"source {key} {a!r} vs {c!r}")
        if b.input_names != ref.input_names or b.output_names != ref.output_names:
            fail(i, f"inputs/outputs {list(b.input_names)}/{list(b.output_names)} vs "
                    f"{list(ref.input_names)}/{list(ref.output_names)}")
        if not (np.array_equal(b.kept_dofs, ref.kept_dofs)
                and np.array_equal(b.dof_node, ref.dof_node)
                and np.array_equal(b.dof_kind, ref.dof_kind)):
            fail(i, "kept DOFs (index, node, kind) differ")
        if not np.array_equal(b.nodes, ref.nodes):
            fail(i, "kept node table (ids, coordinates) differs")
        if (b.invariants is None) != (ref.invariants is None):
            fail(i, "invariants present in one and not the other")
        if b.invariants is not None and list(b.invariants) != list(ref.invariants):
            fail(i, "different invariant arrays")
        if (b.full_dof_kind is not None and ref.full_dof_kind is not None
                and not np.array_equal(b.full_dof_kind, ref.full_dof_kind)):
            fail(i, "DOF kinds of the full bases (full_dof_kind) differ")
    prints = [b.source.get("fingerprint") for b in bodies]
    for i, fp in enumerate(prints):
        if fp is not None and fp in prints[:i]:
            j = prints.index(fp)
            raise DataError(f"{body_label(labels, j)} and {body_label(labels, i)} were "
                            "reduced from the same FE model "
                            f"(fingerprint {str(fp)[:12]}…): two samples of one model (the "
                            "same file given twice?)", None, f"bodies[{i}]")


def sample_values(bodies: Sequence[ReducedBody], samples: Sequence[float] | None,
                  parameter: str) -> np.ndarray:
    """The checked sample values: given, or recorded in the bodies' ``parameters``."""
    if samples is None:
        missing = [i + 1 for i, b in enumerate(bodies)
                   if not b.parameters or parameter not in b.parameters]
        if missing:
            raise DataError(f"no sample values given and bodies {missing} record no value "
                            f"of {parameter!r} in their parameters", None, "samples")
        samples = [b.parameters[parameter] for b in bodies]
    try:
        s = np.asarray(samples, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise DataError(f"must be numbers, got {samples!r}", None, "samples") from None
    if s.size != len(bodies):
        raise DataError(f"{s.size} sample values for {len(bodies)} bodies", None, "samples")
    if not np.all(np.isfinite(s)):
        raise DataError(f"must be finite, got {s.tolist()}", None, "samples")
    if np.any(np.diff(s) <= 0):
        raise DataError(f"must be strictly increasing (give the bodies in the order of the "
                        f"parameter), got {s.tolist()}", None, "samples")
    for i, b in enumerate(bodies):
        v = (b.parameters or {}).get(parameter)
        if v is not None and v != s[i]:
            raise DataError(f"body {i + 1} records {parameter} = {v:g}, but is given as the "
                            f"sample {s[i]:g}", None, "samples")
    return s


def coordinate_table(samples: Sequence[float], sigma: Sequence[float], xi: Sequence[float],
                     source: str | None = None) -> np.ndarray:
    """The (2, n) interpolation-coordinate table of :class:`ParametricBody` from a curve
    ``(σ_j, ξ_j)`` (e.g. ``static_curve.csv`` of ``neweul fem middle-ear --static-curve``):
    sorted, cut to the samples' range, the knots that match a sample within 1e-9 of the range
    set to it exactly.

    Raises
    ------
    DataError
        Curve and values of different lengths, a value that is not finite, a repeated
        ``σ``, a sample that is not on the curve (naming ``source``), or a table that
        :func:`~neweul_py.ffrf.parametric.coordinate_problem` refuses.
    """
    s = np.asarray(samples, dtype=np.float64)
    sig, val = np.asarray(sigma, dtype=np.float64), np.asarray(xi, dtype=np.float64)
    if sig.shape != val.shape or sig.ndim != 1:
        raise DataError(f"{sig.size} knots for {val.size} coordinate values", source,
                        "coordinate")
    if not (np.all(np.isfinite(sig)) and np.all(np.isfinite(val))):
        raise DataError("the curve holds a value that is not a finite number", source,
                        "coordinate")
    order = np.argsort(sig, kind="stable")
    sig, val = sig[order], val[order]
    if np.any(np.diff(sig) == 0):
        raise DataError("the curve repeats a parameter value", source, "coordinate")
    tol = 1e-9 * max(float(s[-1] - s[0]), 1e-300)
    keep = np.ones(sig.size, dtype=bool)
    for v in s:
        near = np.flatnonzero(np.abs(sig - v) <= tol)
        if not near.size:
            raise DataError(f"the sample {v:g} is not on the curve (it must hold every "
                            "sample value)", source, "coordinate")
        best = near[np.argmin(np.abs(sig[near] - v))]
        sig[best] = v                      # the sample exactly; its near-duplicates go
        keep[near[near != best]] = False
    keep &= (sig >= s[0]) & (sig <= s[-1])
    table = np.vstack([sig[keep], val[keep]])
    why = coordinate_problem(s, table)
    if why is not None:
        raise DataError(why, source, "coordinate")
    return table
