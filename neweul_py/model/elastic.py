"""The :class:`ElasticBody`: an elastic body in the floating frame of reference (equations.md §2).

An elastic body sits on a reference frame of the system (which moves like a rigid body) and
brings its elastic coordinates ``NAME_q1 … NAME_q<nq>`` and its node frames ``NAME.label``.
Its invariants (``m``, ``md``, ``J``, ``Ct``, ``Cr``, ``Me``, ``Gr``, ``Ge``, ``Oe``, ``Ke``,
``De`` … with their first-order terms, the node ``origin``, ``Φ``, ``Ψ``, ``AP``) are kept as
*numeric arrays* — the flat form of :class:`neweul_py.elastic.bodies.invariants.Invariants`
(``Invariants.to_flat``) — and never become symbolic expressions: the generated module does
matrix products with them (``docs/architecture.md``, "Elastic bodies").

Only the node frames are symbolic, to first order in ``q`` (SID convention), through six
dependent node coordinates ``[u; θ] = [Φ_P; Ψ_P] q`` each::

    origin = x_P + u,      AP ≈ R_x(θx) R_y(θy) R_z(θz) · AP⁰   (≈ (I + θ̃) AP⁰)

so force elements, outputs, constraints and child frames use them like any frame, and the
generated module maps node coordinates to modes numerically (:meth:`ElasticBody.node_frames`).

This module imports nothing outside ``model`` but the NumPy-only :mod:`neweul_py.ffrf.schema`
that checks the arrays (read by :func:`neweul_py.elastic.io.reader.read_elastic_data`, called by
the description layer). NumPy and that schema are imported where an elastic body is made or
read, not with the module: a rigid model (``neweul generate`` of a chain) never imports NumPy.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import sympy as sp

from ..errors import ModelError
from .elements import Frame
from .symbols import check_name, symbol

if TYPE_CHECKING:
    import numpy as np

__all__ = ["ElasticBody", "is_node_frame_name"]

#: Names of the six node components (dependent node coordinates ``NAME_label_<c>``).
NODE_COMPONENTS = ("ux", "uy", "uz", "rx", "ry", "rz")


def is_node_frame_name(name: str) -> bool:
    """``True`` for a node-frame name ``BODY.label`` (two valid names joined by a dot)."""
    parts = name.split(".")
    return len(parts) == 2 and all(check_name(p) is None for p in parts)


def _frozen(a: object) -> np.ndarray:
    import numpy as np

    arr = np.array(a)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class ElasticBody:
    """An elastic body on a reference frame (equations.md §2).

    Parameters
    ----------
    name
        Body name; its coordinates are ``{name}_q1 …`` and its node frames ``{name}.{label}``.
    frame
        The reference frame (a frame of the system; ``ISYS`` for a body fixed to the ground).
    data
        Flat invariants (:meth:`neweul_py.elastic.bodies.invariants.Invariants.to_flat`), read-only
        NumPy arrays.
    nodes
        ``(label, node_id)`` pairs: the node frames the model uses.
    source
        Where the data came from (shown in messages, not part of the model's identity).
    inertia
        ``"consistent"`` (default): the second-order inertia terms ``J.m2`` are used where the
        data hold them (energy-consistent body, equations.md §2.1); ``"sid"``: the SID
        truncation (``J`` linear in q, ``Gr`` constant).
    samples
        Parametric bodies (equations.md §2.3): the flat invariants at each sample of the
        scheduling variable, in common coordinates (``data`` is the first); empty otherwise.
    sample_values
        The sample values ``s_1 < … < s_k``.
    interpolation
        ``"linear"``, ``"cubic"``, ``"hermite"`` or ``"quintic-hermite"`` weights between
        the samples.
    coordinate
        Optional (2, n) interpolation coordinate table ``(σ_j, ξ_j)``: the cubic or Hermite
        weights are taken in ``ξ(σ)`` (equations.md §4.1,
        :func:`neweul_py.ffrf.parametric.weight_polynomials`).
    schedule
        The scheduling variable ``σ`` (an expression of parameters, inputs, time and the
        coordinates of the rigid part).
    slopes
        With ``hermite`` weights (equations.md §4.2): per sample the slopes ``dX/dσ`` of its
        flat invariants (the float arrays; the other entries those of the sample).
    curvatures
        With ``quintic-hermite`` weights: per sample the curvatures ``d²X/dσ²`` of its flat
        invariants, like ``slopes``.

    Raises
    ------
    ModelError
        Missing arrays, inconsistent mode counts, unknown node ids (key path
        ``elastic_bodies.NAME…``).
    """

    name: str
    frame: str
    data: Mapping[str, np.ndarray]
    nodes: tuple[tuple[str, int], ...] = ()
    source: str = field(default="", compare=False)
    inertia: str = "consistent"
    samples: tuple[Mapping[str, np.ndarray], ...] = ()
    sample_values: tuple[float, ...] = ()
    interpolation: str = "linear"
    schedule: sp.Expr | None = None
    coordinate: np.ndarray | None = None
    slopes: tuple[Mapping[str, np.ndarray], ...] = ()
    curvatures: tuple[Mapping[str, np.ndarray], ...] = ()

    def __post_init__(self) -> None:
        from ..ffrf.schema import INERTIA_FORMS, check_flat

        path = f"elastic_bodies.{self.name}"
        why = check_name(self.name)
        if why is not None:
            raise ModelError(why, path)
        if self.inertia not in INERTIA_FORMS:
            raise ModelError(f"inertia must be one of {', '.join(INERTIA_FORMS)}, got "
                             f"{self.inertia!r}", f"{path}.inertia")
        data = {k: _frozen(v) for k, v in dict(self.data).items()}
        data.setdefault("format", _frozen("neweul-invariants-1"))
        problems = check_flat(data)
        if problems:
            raise ModelError(problems[0], f"{path}.data")
        object.__setattr__(self, "data", data)
        self._check_samples(path, data)
        ids = [int(i) for i in data["nodes.id"]]
        nodes = tuple((str(label), int(node)) for label, node in self.nodes)
        seen: set[str] = set()
        for label, node in nodes:
            why = check_name(label)
            if why is not None:
                raise ModelError(f"node label: {why}", f"{path}.nodes.{label}")
            if label in seen:
                raise ModelError(f"node label {label!r} used twice", f"{path}.nodes.{label}")
            seen.add(label)
            if node not in ids:
                raise ModelError(f"node {node} is not in the elastic data (nodes: "
                                 f"{', '.join(map(str, ids))})", f"{path}.nodes.{label}")
        object.__setattr__(self, "nodes", nodes)

    def _check_samples(self, path: str, data: Mapping[str, np.ndarray]) -> None:
        """Parametric bodies: every sample valid and of the first sample's layout."""
        import numpy as np

        from ..ffrf.schema import check_flat

        if not self.samples:
            if self.schedule is not None:
                raise ModelError("a schedule needs parametric data (samples)", f"{path}.schedule")
            return
        if self.schedule is None:
            raise ModelError("parametric data need a schedule expression", f"{path}.schedule")
        values = tuple(float(v) for v in self.sample_values)
        if len(values) != len(self.samples) or len(values) < 2 or not all(
                np.isfinite(values)) or np.any(np.diff(values) <= 0):
            raise ModelError("the sample values must be at least two increasing numbers, one "
                             "per sample", f"{path}.data")
        from ..ffrf.parametric import HERMITE_ORDERS

        if self.interpolation not in ("linear", "cubic", *HERMITE_ORDERS):
            raise ModelError(f"unknown interpolation {self.interpolation!r}", f"{path}.data")
        if (HERMITE_ORDERS.get(self.interpolation, 0) != bool(self.slopes)
                + bool(self.curvatures)) or (self.curvatures and not self.slopes):
            raise ModelError("Hermite weights and their data come together (hermite: the "
                             "sample slopes; quintic-hermite: the slopes and curvatures)",
                             f"{path}.data")
        if self.coordinate is not None:
            from ..ffrf.parametric import coordinate_problem

            why = coordinate_problem(np.asarray(values), self.coordinate)
            if why is None and self.interpolation not in ("cubic", *HERMITE_ORDERS):
                why = "an interpolation coordinate needs cubic or Hermite weights"
            if why is not None:
                raise ModelError(f"interpolation coordinate: {why}", f"{path}.data")
            object.__setattr__(self, "coordinate", _frozen(
                np.asarray(self.coordinate, dtype=np.float64)))
        samples = []
        for i, sample in enumerate(self.samples):
            flat = {k: _frozen(v) for k, v in dict(sample).items()}
            flat.setdefault("format", data["format"])
            problems = check_flat(flat)
            if problems:
                raise ModelError(f"sample {i + 1}: {problems[0]}", f"{path}.data")
            if sorted(flat) != sorted(data) or any(
                    flat[k].shape != data[k].shape for k in data):
                raise ModelError(f"sample {i + 1} has other arrays or shapes than sample 1 "
                                 "(samples must share nodes, modes and DOFs)", f"{path}.data")
            samples.append(flat)
        object.__setattr__(self, "samples", tuple(samples))
        object.__setattr__(self, "sample_values", values)
        for what in ("slopes", "curvatures"):
            if getattr(self, what):
                object.__setattr__(self, what, self._checked_slopes(path, samples, what))

    def _checked_slopes(self, path: str, samples: list[dict], what: str = "slopes"
                        ) -> tuple[dict, ...]:
        """One slope (or curvature) per sample, of its sample's arrays and shapes, finite."""
        import numpy as np

        given = getattr(self, what)
        if len(given) != len(samples):
            raise ModelError(f"{len(given)} sample {what} for {len(samples)} samples",
                             f"{path}.data")
        out = []
        for i, (slope, sample) in enumerate(zip(given, samples, strict=True)):
            flat = {k: _frozen(v) for k, v in dict(slope).items()}
            flat.setdefault("format", sample["format"])
            bad = next((k for k in sample if k not in flat or flat[k].shape != sample[k].shape),
                       None) or next((k for k in flat if k not in sample), None)
            if bad is None:
                bad = next((k for k, v in flat.items() if v.dtype.kind == "f"
                            and not np.all(np.isfinite(v))), None)
            if bad is not None:
                raise ModelError(f"{what[:-1]} of sample {i + 1}: array {bad!r} missing, of "
                                 "another shape than the sample's, or not finite",
                                 f"{path}.data")
            out.append(flat)
        return tuple(out)

    @property
    def datasets(self) -> tuple[Mapping[str, np.ndarray], ...]:
        """What the interpolation weights mix, in the order of their columns: the samples,
        then their slopes (``hermite``), then their curvatures (``quintic-hermite``);
        ``(data,)`` for a body without a schedule."""
        return ((*self.samples, *self.slopes, *self.curvatures) if self.parametric
                else (self.data,))

    @property
    def parametric(self) -> bool:
        """Whether the body depends on a scheduling variable."""
        return bool(self.samples)

    # ------------------------------------------------------------------ access
    @property
    def nq(self) -> int:
        """Number of elastic coordinates."""
        return int(self.data["Me.m0"].shape[0])

    @property
    def two_sided(self) -> bool:
        """Whether the data come from a two-sided projection (``W ≠ V``)."""
        return bool(self.data["two_sided"])

    @property
    def coordinate_names(self) -> tuple[str, ...]:
        """``NAME_q1 … NAME_q<nq>``."""
        return tuple(f"{self.name}_q{k + 1}" for k in range(self.nq))

    def node_frame_name(self, label: str) -> str:
        """``NAME.label``."""
        return f"{self.name}.{label}"

    def node_index(self, node_id: int) -> int:
        """Index of ``node_id`` in the node arrays of :attr:`data`."""
        return [int(i) for i in self.data["nodes.id"]].index(int(node_id))

    def digest(self) -> str:
        """SHA-256 of the numeric data (sorted keys, dtype, shape, bytes; every sample of a
        parametric body, its sample values and interpolation)."""
        import numpy as np

        h = hashlib.sha256()
        for data in (self.data, *self.samples, *self.slopes, *self.curvatures):
            for key in sorted(data):
                arr = np.ascontiguousarray(data[key])
                h.update(f"{key}|{arr.dtype.str}|{arr.shape}|".encode())
                h.update(arr.tobytes() if arr.dtype.kind != "U" else str(arr.tolist()).encode())
        h.update(f"{self.sample_values!r}|{self.interpolation}".encode())
        if self.coordinate is not None:
            h.update(b"coordinate|" + np.ascontiguousarray(self.coordinate).tobytes())
        return h.hexdigest()

    def __repr__(self) -> str:  # canonical: the System fingerprint uses it
        return (f"ElasticBody(name={self.name!r}, frame={self.frame!r}, nodes={self.nodes!r}, "
                f"inertia={self.inertia!r}, schedule={self.schedule!r}, "
                f"data=sha256:{self.digest()})")

    # ------------------------------------------------------------- node frames
    def node_components(self, label: str) -> tuple[int, ...]:
        """Components ``0…5`` (``ux uy uz rx ry rz``) in which node ``label`` moves or takes
        loads: rows of ``[Φ; Ψ]`` (or of the left basis ``[Φ_W; Ψ_W]``) that are not zero."""
        import numpy as np

        i = self.node_index(dict(self.nodes)[label])
        moving = np.zeros(6, dtype=bool)
        for d in (self.data, *self.samples):
            rows = np.vstack((d["nodes.phi"][i], d["nodes.psi"][i]))
            rows_w = np.vstack((d["nodes.phi_w"][i], d["nodes.psi_w"][i]))
            moving |= np.any(rows != 0, axis=1) | np.any(rows_w != 0, axis=1)
        return tuple(int(a) for a in np.flatnonzero(moving))

    def node_coordinate_names(self, label: str) -> tuple[str, ...]:
        """Names of the node's dependent coordinates ``NAME_label_ux … _rz`` (the moving
        components only, :meth:`node_components`)."""
        return tuple(f"{self.name}_{label}_{NODE_COMPONENTS[a]}"
                     for a in self.node_components(label))

    def node_maps(self, label: str, sample: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(T_V, T_W)``: the node coordinates are ``T_V q`` (rows of ``[Φ; Ψ]``), their
        generalized forces act on the elastic rows through ``T_Wᵀ`` (left basis); of the data
        set ``sample`` of :attr:`datasets` for parametric bodies (default: the first sample)."""
        import numpy as np

        d = self.data if sample is None else self.datasets[sample]
        i = self.node_index(dict(self.nodes)[label])
        comps = list(self.node_components(label))
        tv = np.vstack((d["nodes.phi"][i], d["nodes.psi"][i]))[comps]
        tw = np.vstack((d["nodes.phi_w"][i], d["nodes.psi_w"][i]))[comps]
        return tv, tw

    @property
    def all_node_coordinate_names(self) -> tuple[str, ...]:
        """The dependent node coordinates of all node frames, in node order."""
        return tuple(n for label, _ in self.nodes for n in self.node_coordinate_names(label))

    def node_frames(self) -> tuple[Frame, ...]:
        """The node frames ``NAME.label`` as symbolic frames, children of :attr:`frame`.

        Each node frame moves with six *dependent node coordinates* ``u`` (translation) and
        ``θ`` (small rotation angles), ``[u; θ] = [Φ_P; Ψ_P] q`` (only the components that
        move): translation ``x_P + u``, rotation ``R_x(θx) R_y(θy) R_z(θz)`` followed by the
        Cardan angles of ``AP⁰`` (``≈ (I + θ̃) AP⁰``, first order as in SID). The symbolic
        kinematics thus never sees the modes; the generated module maps the node coordinates
        to ``q`` numerically (``y_s = S_V y`` and ``S_Wᵀ`` for the generalized forces, see
        :mod:`neweul_py.codegen.elastic`), so a node costs six coordinates whatever ``nq``.
        """
        out = []
        for label, node in self.nodes:
            i = self.node_index(node)
            x0 = self.data["nodes.origin.m0"][i][:, 0]
            comps = self.node_components(label)
            sym = {a: symbol(n) for a, n in zip(comps, self.node_coordinate_names(label),
                                                  strict=True)}
            trans = sp.ImmutableMatrix([
                (sp.Float(float(x0[a])) if x0[a] != 0.0 else sp.Integer(0))
                + sym.get(a, sp.Integer(0)) for a in range(3)])
            rot: list[tuple[str, sp.Expr]] = [
                (axis, sym[3 + a]) for a, axis in enumerate("xyz") if 3 + a in sym]
            for axis, angle in zip("xyz", _cardan_xyz(self.data["nodes.AP.m0"][i]), strict=True):
                if angle != 0.0:
                    rot.append((axis, sp.Float(angle)))
            out.append(Frame(self.node_frame_name(label), self.frame, trans, tuple(rot)))
        return tuple(out)


def _cardan_xyz(R: np.ndarray) -> tuple[float, float, float]:
    """Angles ``(a, b, c)`` with ``R = R_x(a) R_y(b) R_z(c)`` (0 for the identity)."""
    import numpy as np

    R = np.asarray(R, dtype=np.float64)
    if np.allclose(R, np.eye(3), atol=1e-14, rtol=0):
        return (0.0, 0.0, 0.0)
    b = math.asin(max(-1.0, min(1.0, float(R[0, 2]))))
    a = math.atan2(-float(R[1, 2]), float(R[2, 2]))
    c = math.atan2(-float(R[0, 1]), float(R[0, 0]))
    return (a, b, c)
