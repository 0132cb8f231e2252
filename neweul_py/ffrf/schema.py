"""The schema of the floating-frame invariants: one place for names, shapes and orders.

Every layer that stores, validates or evaluates elastic-body data reads it from here:
``elastic/`` writes the flat arrays
(:meth:`neweul_py.elastic.bodies.invariants.Invariants.to_flat`),
``model/`` validates them (:func:`check_flat`), ``codegen/`` embeds the arrays the kernel
needs (:data:`KERNEL_ARRAYS`) and the kernel (:mod:`neweul_py.ffrf.body`) evaluates them.
The conventions are those of ``docs/equations.md`` §2 (SID conventions, Wallrapp 1994);
``J.m2`` is this project's second-order inertia term (§2.1, energy-consistent bodies).

Flat keys are ``X.m0`` (order 0), ``X.m1`` (order 1: ``(rows, nq, cols)``, the SID index
order) and ``J.m2`` (order 2: ``(nq, nq, 3, 3)``), plus node arrays stacked over the nk node
frames. Shapes are written with the symbols ``nq`` (modes) and ``nk`` (node frames).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

__all__ = [
    "FIXED_ARRAYS",
    "FLAT_FORMAT",
    "INERTIA_FORMS",
    "KERNEL_ARRAYS",
    "SCHEMA",
    "SCHEMA_VERSION",
    "TAYLOR_NAMES",
    "ArraySpec",
    "check_flat",
    "frame_stiffening",
    "loss_reference_frequency",
    "mode_count",
]

#: Format tag stored in every flat invariants set (``format`` array).
FLAT_FORMAT = "neweul-invariants-1"
#: Version of this schema (2: optional second-order inertia ``J.m2``).
SCHEMA_VERSION = 2

#: ``consistent``: the full second-order inertia terms (default; energy-consistent);
#: ``sid``: the SID truncation (``J`` linear in q, ``Gr`` constant), for comparison with
#: commercial SID workflows.
INERTIA_FORMS = ("consistent", "sid")

#: The Taylor objects of a body (each has ``.m0``, optionally ``.m1``).
TAYLOR_NAMES = ("md", "J", "Ct", "Cr", "Crv", "Me", "Gr", "Ge", "Oe", "ksigma", "Ke", "De")


@dataclass(frozen=True)
class ArraySpec:
    """One flat array: its shape (in ``nq``, ``nk``), whether it is required, its meaning
    and the basis it is built with (``V``: displacement, ``W``: elastic-equation rows)."""

    shape: tuple[str | int, ...]
    required: bool
    meaning: str
    side: str = ""


#: Every array of the flat form, by key.
SCHEMA: dict[str, ArraySpec] = {
    "format": ArraySpec((), True, "format tag, FLAT_FORMAT"),
    "m": ArraySpec((), True, "mass"),
    "names": ArraySpec(("nq",), False, "names of the elastic coordinates"),
    "two_sided": ArraySpec((), True, "whether W differs from V"),
    "md.m0": ArraySpec((3, 1), True, "first mass moment about the frame origin"),
    "md.m1": ArraySpec((3, "nq", 1), False, "∫ Φ dm", "V"),
    "J.m0": ArraySpec((3, 3), True, "inertia about the frame origin"),
    "J.m1": ArraySpec((3, "nq", 3), False, "J¹_k = sym Gr_k", "V"),
    "J.m2": ArraySpec(("nq", "nq", 3, 3), False,
                      "C2[k, l, a, b] = ∫ (e_a × Φ_k)·(e_b × Φ_l) dm: J(q) += qᵀ C2 q, "
                      "Gr_k(q) += 2 Σ_l q_l C2[l, k]", "V"),
    "Ct.m0": ArraySpec(("nq", 3), True, "elastic-row coupling with a", "W"),
    "Ct.m1": ArraySpec(("nq", "nq", 3), False, "geometric stiffening of a", "W"),
    "Cr.m0": ArraySpec(("nq", 3), True, "elastic-row coupling with α", "W"),
    "Cr.m1": ArraySpec(("nq", "nq", 3), False, "kinematic part + stiffening of α", "W"),
    "Crv.m0": ArraySpec(("nq", 3), True, "rotational-row coupling (Crvᵀ in M)", "V"),
    "Crv.m1": ArraySpec(("nq", "nq", 3), False, "its first-order part", "V"),
    "Me.m0": ArraySpec(("nq", "nq"), True, "modal mass Wᵀ M V", "W"),
    "Gr.m0": ArraySpec((3, "3nq"), True, "Gr_k = −2 ∫ x̃ Φ̃_k dm, per-mode layout", "V"),
    "Ge.m0": ArraySpec(("nq", "3nq"), True, "Ge_k = 2 ∫ Φᵀ Φ̃_kᵀ dm, per-mode layout", "W"),
    "Oe.m0": ArraySpec(("nq", 6), True, "centrifugal terms, columns ω_q", "W"),
    "Oe.m1": ArraySpec(("nq", "nq", 6), False, "their first-order part + stiffening", "W"),
    "ksigma.m0": ArraySpec(("nq", 1), True, "modal forces of reference stresses", "W"),
    "Ke.m0": ArraySpec(("nq", "nq"), True, "modal stiffness Wᵀ K V", "W"),
    "De.m0": ArraySpec(("nq", "nq"), True, "modal damping Wᵀ D V", "W"),
    "Le.m0": ArraySpec(("nq", "nq"), False,
                       "modal hysteretic (loss) stiffness Wᵀ G V: K + iG in the frequency "
                       "domain; De holds its time-domain equivalent Le/ω_ref", "W"),
    "loss.f_ref": ArraySpec((), False, "reference frequency f_ref [Hz] of Le (ω_ref = 2π f_ref)"),
    "nodes.id": ArraySpec(("nk",), True, "node ids"),
    "nodes.origin.m0": ArraySpec(("nk", 3, 1), True, "node positions"),
    "nodes.origin.m1": ArraySpec(("nk", 3, "nq", 1), False, "Φ of the node origins", "V"),
    "nodes.phi": ArraySpec(("nk", 3, "nq"), True, "node translations Φ_P", "V"),
    "nodes.psi": ArraySpec(("nk", 3, "nq"), True, "node rotations Ψ_P", "V"),
    "nodes.phi_w": ArraySpec(("nk", 3, "nq"), True, "node load matrices Φ_W", "W"),
    "nodes.psi_w": ArraySpec(("nk", 3, "nq"), True, "node load matrices Ψ_W", "W"),
    "nodes.AP.m0": ArraySpec(("nk", 3, 3), True, "node orientations"),
    "nodes.AP.m1": ArraySpec(("nk", 3, "nq", 3), False, "their first-order part", "V"),
}

#: The arrays the generated module embeds for the kernel (order-1 parts, ``J.m2`` and the
#: hysteretic matrix ``Le.m0`` are optional; absent means zero; its reference frequency is
#: the model's ``loss_reference_frequency``, checked equal to ``loss.f_ref``).
KERNEL_ARRAYS = ("md.m0", "md.m1", "J.m0", "J.m1", "J.m2", "Ct.m0", "Ct.m1", "Cr.m0",
                 "Cr.m1", "Crv.m0", "Crv.m1", "Me.m0", "Gr.m0", "Ge.m0", "Oe.m0", "Oe.m1",
                 "ksigma.m0", "Ke.m0", "De.m0", "Le.m0")

#: The arrays of a second-order displacement field (equations.md §2.3): the extended body
#: ``quad.<key>`` (``nz = nq + ny`` coordinates ``z = [q; y]``, one-sided, no stiffening)
#: and ``quad.A`` (ny, nq, nq) with ``y_j = ½ qᵀ A_j q``. Optional; the kernel uses them
#: instead of the first-order stiffening terms when present (``inertia: consistent``).
QUAD_ARRAYS = (*(f"quad.{k}" for k in KERNEL_ARRAYS
                 if k not in ("Ct.m1", "ksigma.m0", "Ke.m0", "De.m0", "Le.m0")),
                "quad.A")
KERNEL_ARRAYS = KERNEL_ARRAYS + QUAD_ARRAYS

#: The arrays of a body on a fixed frame without stiffening (equations.md §2.2): its
#: equations are ``Me q̈ + De q̇ + Ke q + kσ = Ct⁰ g + node loads``, the rest is not embedded.
FIXED_ARRAYS = ("md.m0", "md.m1", "Ct.m0", "Me.m0", "ksigma.m0", "Ke.m0", "De.m0", "Le.m0")


def frame_stiffening(flat: Mapping[str, np.ndarray]) -> bool:
    """Whether the data hold stiffening that the frame's acceleration (gravity on a fixed
    frame) acts through: ``Ct.m1`` or a second-order field (``quad.A``)."""
    return "quad.A" in flat or ("Ct.m1" in flat and bool(np.any(flat["Ct.m1"])))


def mode_count(flat: Mapping[str, np.ndarray]) -> int:
    """Number of elastic coordinates: the rows of ``Me.m0`` (0 if missing or malformed)."""
    me = flat.get("Me.m0")
    if me is None or np.ndim(me) != 2:
        return 0
    return int(np.shape(me)[0])


def _expected(shape: tuple[str | int, ...], nq: int, nk: int) -> tuple[int, ...]:
    sizes = {"nq": nq, "nk": nk, "3nq": 3 * nq}
    return tuple(sizes[s] if isinstance(s, str) else s for s in shape)


def check_flat(flat: Mapping[str, np.ndarray]) -> list[str]:
    """The problems of a flat invariants set against :data:`SCHEMA` (empty if none).

    Checks presence of the required arrays, every known array's shape (with ``nq`` from
    ``Me.m0`` and ``nk`` from ``nodes.id``) and that float arrays are finite.

    Returns
    -------
    list of str
        One message per problem, each naming the key.
    """
    missing = [k for k, s in SCHEMA.items() if s.required and k not in flat]
    if missing:
        return [f"the elastic data lack {', '.join(missing)}"]
    nq = mode_count(flat)
    if nq == 0:
        return ["the elastic data hold no modes (Me.m0 is empty)"]
    nk = int(np.size(flat["nodes.id"]))
    problems = []
    if "quad.A" in flat:
        problems += _check_quadratic(flat, nq)
    for key, spec in SCHEMA.items():
        if key not in flat or key == "names":
            continue
        arr = np.asarray(flat[key])
        want = _expected(spec.shape, nq, nk)
        if arr.shape != want:
            problems.append(f"{key} has shape {arr.shape}, expected {want} (nq = {nq} from "
                            f"Me.m0, {nk} node frames)")
        elif arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
            problems.append(f"array {key} holds NaN or Inf")
    problems += _check_loss(flat)
    return problems


def loss_reference_frequency(flat: Mapping[str, np.ndarray]) -> float | None:
    """The reference frequency ``f_ref`` [Hz] of a body's hysteretic matrix ``Le.m0``
    (``loss.f_ref``), or ``None`` for a body without one (equations.md §1.1)."""
    if "Le.m0" not in flat or "loss.f_ref" not in flat:
        return None
    return float(np.asarray(flat["loss.f_ref"]))


def _check_loss(flat: Mapping[str, np.ndarray]) -> list[str]:
    """``Le.m0`` and ``loss.f_ref`` come together; ``f_ref`` is a positive finite number."""
    has_le, has_f = "Le.m0" in flat, "loss.f_ref" in flat
    if has_le != has_f:
        return ["Le.m0 and loss.f_ref come together (the hysteretic matrix and its reference "
                "frequency)"]
    if has_f:
        f = np.asarray(flat["loss.f_ref"])
        if f.dtype.kind not in "fiu" or not np.isfinite(f) or float(f) <= 0:
            return [f"loss.f_ref must be a positive frequency in Hz, got {f!r}"]
    return []


def _check_quadratic(flat: Mapping[str, np.ndarray], nq: int) -> list[str]:
    """The problems of the second-order field arrays (``quad.*``), each naming the key."""
    inner = {k[5:]: v for k, v in flat.items() if k.startswith("quad.") and k != "quad.A"}
    if "Me.m0" not in inner:
        return ["the second-order field lacks quad.Me.m0"]
    nz = mode_count(inner)
    # the extended body has no node frames and no elastic forces of its own
    defaults = {"format": flat.get("format"), "m": flat.get("m"), "two_sided": False,
                "ksigma.m0": np.zeros((nz, 1)), "Ke.m0": np.zeros((nz, nz)),
                "De.m0": np.zeros((nz, nz)), "nodes.id": np.zeros(0),
                **{k: np.zeros((0, *SCHEMA[k].shape[1:2])) for k in SCHEMA
                   if k.startswith("nodes.") and k != "nodes.id"}}
    checked = {**defaults, **{k: v for k, v in inner.items() if not k.startswith("nodes.")}}
    problems = []
    for p in check_flat(checked):
        if "nodes." in p:
            continue
        for key in sorted(inner, key=len, reverse=True):     # name the flat key
            if key in p:
                p = p.replace(key, f"quad.{key}", 1)
                break
        problems.append(p)
    A = np.asarray(flat["quad.A"])
    if A.shape != (nz - nq, nq, nq):
        problems.append(f"quad.A has shape {A.shape}, expected ({nz - nq}, {nq}, {nq}) (nq = "
                        f"{nq} from Me.m0, {nz} from quad.Me.m0)")
    elif A.dtype.kind != "f" or not np.all(np.isfinite(A)):
        problems.append("array quad.A holds NaN or Inf, or is not a float array")
    elif A.size and np.abs(A - A.transpose(0, 2, 1)).max() > 1e-12 * np.abs(A).max():
        problems.append("quad.A is not symmetric in its last two indices (y_j = ½ qᵀ A_j q)")
    return problems
