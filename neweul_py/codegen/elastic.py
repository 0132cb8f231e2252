"""Generated modules of systems with elastic bodies, composed from parts (equations.md §2).

The module of a model with elastic bodies is put together from

1. the symbolic part, rendered by :func:`.writer.module_parts` with the prefix ``_rigid_``
   from :attr:`Equations.elastic <neweul_py.equations.Equations>`: the active (non-elastic)
   coordinates, and as hidden outputs the reference-frame kinematics of every body
   (:meth:`~neweul_py.equations.elastic.ElasticSplice.expressions`); ``_rigid_rhs_parts``
   computes those, ``M_s`` and ``(q − k)_s`` in one CSE'd function (one call per ``rhs``);
2. the floating-frame kernel, **embedded verbatim** — the source of
   :data:`neweul_py.ffrf.body.KERNEL_FUNCTIONS` (the body equations) and
   :data:`neweul_py.ffrf.splice.SPLICE_FUNCTIONS` (their splice into ``M``, ``q − k``, the
   Jacobians, outputs, energies and constraints), so that the generated code runs the same
   functions as the package and stays importable with NumPy alone;
3. the data, **by reference**: the prepared bodies of
   :func:`~neweul_py.ffrf.splice.ffrf_bodies` (for a parametric body its stacked samples),
   the node-coordinate maps ``S_V``, ``S_W`` and the node clouds go to the data file
   (:class:`DataFile`, :mod:`neweul_py.ffrf.data_file`); the module holds their skeleton
   ``_ELASTIC`` (arrays replaced by references), the file's name, SHA-256 and schema, and
   loads and checks it at import. ``_MASS_PATTERN`` lists the rows and columns of the
   symbolic part's mass matrix that are not zero by construction (so that ``S_Wᵀ M_s S_V``
   needs no search for them per call) and ``_KIN_PATTERN`` the hidden outputs not zero by
   construction (together they show whether the elastic block of ``M`` is constant,
   :func:`~neweul_py.ffrf.splice.ffrf_block`);
4. one-line protocol functions that call the splice with the module's context ``_FFRF``.

Nothing is derived here and no rendered text is edited: parts are selected, renamed and
added. The text and the data file depend only on the equations, the arrays and the kernel's
source, so regeneration is byte-identical.
"""

from __future__ import annotations

import ast
import dataclasses
import functools
import hashlib
import inspect
import pprint
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp

from ..ffrf import (
    FIXED_ARRAYS,
    KERNEL_ARRAYS,
    KERNEL_FUNCTIONS,
    MAX_BLOCK_CONDITION,
    PROTOCOL,
    SPLICE_FUNCTIONS,
    ffrf_bodies,
    ffrf_cloud,
)
from ..ffrf.body import ffrf_loss_matrix
from ..ffrf.data_file import (
    DATA_FUNCTIONS,
    ArrayStore,
    ElasticDataError,
    data_file_bytes,
    ffrf_encode,
    ffrf_split,
    schema_of,
)
from ..ffrf.parametric import weight_polynomials
from ..progress import StagedProgress
from .blocks import units
from .body_reference import body_sources
from .writer import ModuleParts, module_parts

__all__ = ["DataFile", "data_file_name", "elastic_module_parts"]


@dataclasses.dataclass(frozen=True)
class DataFile:
    """The data file of a module with elastic bodies (:mod:`neweul_py.ffrf.data_file`).

    Attributes
    ----------
    name
        Its file name, next to the module (:func:`data_file_name`).
    content
        Its bytes.
    sha256
        Their SHA-256 (hex), recorded in the module.
    arrays
        The arrays the module uses, by key: those of ``content`` (:attr:`stored`) and those
        it reads from other files.
    sources
        The other files (a parametric body's file, by reference): file name relative to the
        module → ``{"sha256", "owner", "arrays"}``
        (:func:`~neweul_py.ffrf.data_file.ffrf_load_sources`).
    encodings
        The arrays of :attr:`stored` that the file holds compactly, by key
        (:func:`~neweul_py.ffrf.data_file.ffrf_encode`).
    schema
        What the module expects of the file's members
        (:func:`~neweul_py.ffrf.data_file.schema_of`).
    """

    name: str
    content: bytes
    sha256: str
    arrays: dict[str, np.ndarray] = dataclasses.field(repr=False)
    sources: dict[str, Any] = dataclasses.field(default_factory=dict)
    encodings: dict[str, list] = dataclasses.field(default_factory=dict)
    schema: dict[str, Any] = dataclasses.field(default_factory=dict)

    @property
    def stored(self) -> dict[str, np.ndarray]:
        """The arrays in the file itself (the others are read from :attr:`sources`)."""
        taken = {key for spec in self.sources.values() for key in spec["arrays"]}
        return {k: v for k, v in self.arrays.items() if k not in taken}


def data_file_name(model: str, sha256: str) -> str:
    """``<model>.<first 16 hex digits of its SHA-256>.npz``: a regenerated module with other
    data names another file, so the module and the data it was generated with stay a pair
    until the new module replaces the old one."""
    return f"{model}.{sha256[:16]}.npz"

#: Functions of the symbolic part that the splice calls (the others are not emitted).
_RIGID_USED = ("rhs_parts", "mass_matrix", "force_vector", "force_jacobians",
               "mass_matrix_times_derivative", "outputs", "output_jacobians", "energy",
               "constraints", "constraint_jacobian", "constraint_time_derivative",
               "constraint_gamma", "force_parameter_jacobian",
               "mass_matrix_parameter_derivative", "output_parameter_jacobian")


def _entry(splice: Any, first: int, offset: int) -> dict[str, Any]:
    """One body's entry for :func:`~neweul_py.ffrf.splice.ffrf_bodies`: its flat kernel
    arrays (per data set for parametric bodies, with the sample values and the weight
    polynomials)."""
    b = splice.body
    entry: dict[str, Any] = {"name": b.name, "first": first, "kin": offset,
                             "inertia": b.inertia}
    datasets = b.datasets
    # order-1/2 parts that are zero in every sample are left out (absent means zero)
    keys = tuple(k for k in KERNEL_ARRAYS if not k.endswith((".m1", ".m2"))
                 or any(k in d and np.any(d[k]) for d in datasets))
    if splice.elastic_rows_only:
        # a frame that never moves and no stiffening: the elastic rows alone (§2.2)
        entry["fixed"] = True
        keys = FIXED_ARRAYS

    def flat(d: Any) -> dict[str, Any]:
        out = {"m": float(d["m"]), "two_sided": bool(d["two_sided"])}
        out.update({k: np.asarray(d[k], dtype=np.float64) for k in keys if d.get(k) is not None})
        return out

    if not b.parametric:
        entry.update(flat(b.data))
        return entry
    breaks, coeff = weight_polynomials(np.asarray(b.sample_values, dtype=np.float64),
                                       b.interpolation, b.coordinate)
    entry.update(values=breaks, coeff=coeff, samples=[flat(d) for d in b.samples])
    for what in ("slopes", "curvatures"):   # Hermite weights: the samples' derivatives (§4.2)
        if getattr(b, what):
            entry[what] = [flat(d) for d in getattr(b, what)]
    return entry


def _symmetric(splices: tuple[Any, ...]) -> bool:
    """Whether every body's ``M_b`` is symmetric for all ``q`` (to round-off): one-sided data
    without geometric stiffening in the mass blocks (``Ct = md¹ᵀ``, ``Cr = Crv``)."""

    def same(a: np.ndarray | None, b: np.ndarray | None) -> bool:
        a = np.zeros(0) if a is None else np.asarray(a)
        b = np.zeros(0) if b is None else np.asarray(b)
        if not a.size or not b.size:
            return not np.any(a) and not np.any(b)
        scale = max(float(np.abs(a).max()), float(np.abs(b).max()), 1e-300)
        return a.shape == b.shape and float(np.abs(a - b).max()) <= 1e-12 * scale

    for s in splices:
        d = s.body.data
        if s.body.two_sided:
            return False
        md1 = d["md.m1"][:, :, 0].T if "md.m1" in d else None
        if not (same(d.get("Ct.m1"), None) and same(d["Cr.m0"], d["Crv.m0"])
                and same(d.get("Cr.m1"), d.get("Crv.m1")) and same(d["Ct.m0"], md1)
                and same(d["Me.m0"], d["Me.m0"].T)):
            return False
    return True


def _wrapper(name: str, splice_fn: Any) -> tuple[str, ...]:
    """``def name(args): return ffrf_name(_FFRF, args)`` with the splice function's summary."""
    params = list(inspect.signature(splice_fn).parameters)[1:]
    args = ", ".join("u=None" if a == "u" else a for a in params)
    call = ", ".join(params)
    doc = (inspect.getdoc(splice_fn) or "").split("\n\n")[0].replace("\n", " ")
    state = "y" if "y" in params else "x"
    return (f"def {name}({args}):", f'    """{doc}"""',
            f"    return {splice_fn.__name__}(ffrf_at(_FFRF, t, p, {state}, u), {call})")


def _node_clouds(el: Any, frames: list[str], firsts: list[int]) -> list[dict[str, Any]]:
    """Per elastic body the entry of ``node_positions``
    (:func:`~neweul_py.ffrf.splice.ffrf_node_positions`): its node cloud
    (:func:`~neweul_py.ffrf.splice.ffrf_cloud`; per data set for parametric bodies), its
    reference frame's index in ``FRAMES`` (−1: ISYS), its elastic coordinates and, for a
    parametric body, the index of its schedule."""
    out, k = [], 0
    for s, first in zip(el.splices, firsts, strict=True):
        b = s.body
        entry = {"name": b.name, "frame": frames.index(b.frame) if b.frame in frames else -1,
                 "first": first, "nq": b.nq}
        if b.parametric:
            values, coeff = weight_polynomials(np.asarray(b.sample_values, dtype=np.float64),
                                               b.interpolation, b.coordinate)
            entry.update(k=k, cloud=ffrf_cloud(b.datasets, values, coeff, len(b.samples)))
            k += 1
        else:
            entry["cloud"] = ffrf_cloud(b.datasets)
        out.append(entry)
    return out


def _literal(name: str, value: Any) -> tuple[str, ...]:
    """``name = value`` as source lines (``pprint``: deterministic, dict order kept)."""
    return tuple(f"{name} = {pprint.pformat(value, width=96, sort_dicts=False)}".splitlines())


def _owners(el: Any) -> dict[str, str]:
    """What the first component of a data file key names, in the module's error messages."""
    names = ", ".join(repr(s.body.name) for s in el.splices)
    every = f"elastic bod{'ies' if len(el.splices) > 1 else 'y'} {names}"
    return {"": every, "_splice": f"the node maps of the {every}",
            **{s.body.name: f"elastic body {s.body.name!r}" for s in el.splices}}


def elastic_data(equations: Any, a_idx: list[int], true_index: dict[int, int],
                 body_files: tuple[Mapping[str, str], Any] | None = None
                 ) -> tuple[dict[str, Any], DataFile]:
    """The skeletons of the prepared bodies, the node maps and the node clouds
    (:func:`~neweul_py.ffrf.data_file.ffrf_split`) and the data file holding their arrays;
    with ``body_files`` (body name → file, and the module's directory) a parametric body's
    mixing stack is read from its body file where that holds it exactly
    (:func:`.body_reference.body_sources`)."""
    el = equations.elastic
    store = ArrayStore()
    entries = [_entry(s, true_index[s.first], off)
               for s, off in zip(el.splices, el.offsets, strict=True)]
    parts = [(v[:, a_idx], w[:, a_idx]) for v, w in el.parts]
    bodies = ffrf_bodies(entries, parts)
    skeleton: dict[str, Any] = {
        "bodies": [ffrf_split(b, b["name"], store) for b in bodies],
        "SV": ffrf_split(np.asarray(el.SV[a_idx], dtype=np.float64), "_splice/SV", store),
        "SW": ffrf_split(np.asarray(el.SW[a_idx], dtype=np.float64), "_splice/SW", store),
    }
    if equations.poses:
        clouds = _node_clouds(el, list(equations.poses.frames),
                              [true_index[s.first] for s in el.splices])
        skeleton["nodes"] = [ffrf_split(c, f"{c['name']}/nodes", store) for c in clouds]
    sources = {} if body_files is None else body_sources(
        [(s.body.name, body_files[0].get(s.body.name, "")) for s in el.splices
         if s.body.parametric], store.arrays, body_files[1])
    data = DataFile("", b"", "", store.arrays, sources)
    members, encodings = ffrf_encode(data.stored)
    content = data_file_bytes(members)
    digest = hashlib.sha256(content).hexdigest()
    name = data_file_name(equations.system.name, digest)
    return skeleton, dataclasses.replace(data, name=name, content=content, sha256=digest,
                                         encodings=encodings, schema=schema_of(members))


#: ``node_positions`` of a module with elastic bodies: the node clouds of ``_NODES``, moved by
#: the elastic coordinates (``x_P + Φ_P q``) and placed with the reference frame's pose.
_NODE_POSITIONS = (
    "def node_positions(t, x, p, u=None):",
    '    """Per elastic body of ``BODIES``: its data\'s nodes (nk, 3) at ``x_P + Φ_P q``, '
    'in ISYS."""',
    "    x = _np.asarray(x, dtype=_np.float64)",
    "    r, R = frame_poses(t, x, p, u)",
    "    return ffrf_node_positions(_FFRF, _ELASTIC['nodes'], r, R, t, x, p, u)",
)


@functools.cache
def _module_functions(path: str) -> dict[str, tuple[str, ...]]:
    """Source lines of each top-level function of a module file, decorators included."""
    text = Path(path).read_text(encoding="utf-8")
    lines = text.splitlines()
    out = {}
    for node in ast.parse(text).body:
        if isinstance(node, ast.FunctionDef):
            start = min([node.lineno] + [d.lineno for d in node.decorator_list])
            out[node.name] = tuple(lines[start - 1:node.end_lineno])
    return out


def kernel_source(fn: Any) -> tuple[str, ...]:
    """The source lines of a top-level kernel function, as ``inspect.getsource`` gives them
    (one parse of its module per process instead of tokenizing per function: 68 functions
    took 0.05 s CPU, a tenth of generating an elastic module)."""
    return _module_functions(inspect.getsourcefile(fn))[fn.__name__]


def symbolic_part(equations: Any) -> Any:
    """The equations of the symbolic part of a model with elastic bodies: the active
    (non-elastic) coordinates, and as hidden outputs (after the model's own) the frame
    kinematics of every body (:meth:`~neweul_py.equations.elastic.ElasticSplice.expressions`)."""
    el = equations.elastic
    a_idx = list(el.active)
    names = list(equations.output_names)
    hidden = [f"_elastic_{i}" for i in range(len(el.hidden))]
    ce = equations.constraints
    if ce is not None:
        ce = dataclasses.replace(ce, G=ce.G[:, a_idx])
    return dataclasses.replace(
        equations,
        coordinates=tuple(equations.coordinates[j] for j in a_idx),
        velocities=tuple(equations.velocities[j] for j in a_idx),
        mass_matrix=equations.mass_matrix[a_idx, a_idx],
        mass_factors=None if equations.mass_factors is None else tuple(
            (w, tuple(g[j] for j in a_idx)) for w, g in equations.mass_factors),
        force_vector=equations.force_vector[a_idx, 0],
        outputs=sp.ImmutableMatrix(len(names) + len(hidden), 1,
                                   [*equations.outputs, *el.hidden]),
        output_names=(*names, *hidden),
        constraints=ce,
        loss_matrix=None if equations.loss_matrix is None
        else equations.loss_matrix[a_idx, a_idx],
    )


def patterns(symbolic: Any, hidden: Any) -> tuple[tuple[list[int], list[int]], list[int]]:
    """The rows and columns of the symbolic part's mass matrix that are not zero by
    construction, and the hidden outputs (frame kinematics) that are not."""
    nonzero = symbolic.mass_matrix.todok()          # the entries not zero by construction
    mass = (sorted({i for i, _ in nonzero}), sorted({j for _, j in nonzero}))
    return mass, [i for i, e in enumerate(hidden) if e != 0]


def elastic_module_parts(equations: Any, source_hash: str, *, cse: bool = True,
                         progress: StagedProgress = None,
                         body_files: tuple[Mapping[str, str], Any] | None = None
                         ) -> tuple[ModuleParts, DataFile]:
    """The parts of the module of a system with elastic bodies (module docstring) and its
    data file.

    Parameters
    ----------
    equations
        :class:`~neweul_py.equations.Equations` with ``elastic`` set.
    source_hash
        SHA-256 of the description.
    cse, progress
        Passed to :func:`.writer.module_parts`.
    body_files
        Body name → body file, and the module's directory, when a parametric body's samples
        are to be read from its body file instead of copied into the data file
        (:func:`elastic_data`).
    """
    el = equations.elastic
    system = equations.system
    a_idx = list(el.active)
    names = list(equations.output_names)
    symbolic = symbolic_part(equations)
    rigid = module_parts(symbolic, source_hash, cse=cse, prefix="_rigid_", allow_empty=True,
                         schedules=el.schedules, schedule_jacobians=el.schedule_jacobians,
                         schedule_parameter_jacobian=el.schedule_parameter_jacobian,
                         rhs_parts=len(names), directional=False, progress=progress)

    keep = list(el.keep)
    true_index = {j: k for k, j in enumerate(keep)}
    coords = [system.coordinates[j] for j in keep]
    cu, _ou = units(system)
    constants = dict(rigid.constants)
    constants.update(
        COORDINATES=repr([c.name for c in coords]),
        COORDINATE_UNITS=repr([cu[j] for j in keep]),
        INITIAL_STATE=repr([float(c.initial) for c in coords]
                           + [float(c.velocity) for c in coords]),
        OUTPUTS=repr(names),
        STATE_SIZE=repr(2 * len(keep)),
        MASS_MATRIX_SYMMETRIC=repr(constants["MASS_MATRIX_SYMMETRIC"] == "True"
                                   and _symmetric(el.splices)
                                   and bool(np.array_equal(el.SV, el.SW))),
    )
    skeleton, data = elastic_data(equations, a_idx, true_index, body_files)
    mass_pattern, kin_pattern = patterns(symbolic, el.hidden)
    private = (*rigid.private, f"_NS = {len(a_idx)}",
               f"_MASS_PATTERN = ({mass_pattern[0]!r}, {mass_pattern[1]!r})",
               f"_KIN_PATTERN = {kin_pattern!r}",
               "# the elastic arrays are in the data file next to this module, checked at import",
               f"_DATA_FILE = {data.name!r}",
               f"_DATA_SHA256 = {data.sha256!r}",
               *_literal("_DATA_SCHEMA", data.schema),
               *_literal("_DATA_ENCODINGS", data.encodings),
               *_literal("_DATA_SOURCES", data.sources),
               *_literal("_DATA_OWNERS", _owners(el)),
               *_literal("_ELASTIC", skeleton))

    functions = {k: rigid.functions[k] for k in ("default_parameters", "default_inputs",
                                                  "default_inputs_parameter_jacobian")}
    used = (*_RIGID_USED, *(("loss_matrix",) if "loss_matrix" in rigid.functions else ()))
    functions.update({f"_rigid_{k}": rigid.functions[k] for k in used})
    if el.schedules:
        for name in ("schedule", "schedule_jacobians", "schedule_parameter_jacobian"):
            functions[f"_rigid_{name}"] = rigid.functions[name]
    functions["ElasticDataError"] = tuple(
        inspect.getsource(ElasticDataError).rstrip("\n").splitlines())
    for fn in (*DATA_FUNCTIONS, *KERNEL_FUNCTIONS, *SPLICE_FUNCTIONS):
        functions[fn.__name__] = kernel_source(fn)
    rigid_map = ", ".join(f"{k!r}: _rigid_{k}" for k in used)
    functions["_DATA"] = (
        "_DATA = ffrf_decode(ffrf_load_data(os.path.dirname(os.path.abspath(__file__)),",
        "                                   _DATA_FILE, _DATA_SHA256, _DATA_SCHEMA,",
        "                                   _DATA_OWNERS), _DATA_ENCODINGS)",
        "_DATA.update(ffrf_load_sources(os.path.dirname(os.path.abspath(__file__)),",
        "                               _DATA_SOURCES, _DATA_OWNERS))",
        "_ELASTIC = ffrf_restore(_ELASTIC, _DATA)")
    functions["_FFRF"] = (
        "_FFRF = ffrf_system(_ELASTIC['bodies'], _NS, _ELASTIC['SV'], _ELASTIC['SW'],",
        "                    len(OUTPUTS),",
        f"                    {{{rigid_map}}},",
        "                    default_inputs,",
        f"                    {'_rigid_schedule' if el.schedules else 'None'},",
        f"                    {'_rigid_schedule_jacobians' if el.schedules else 'None'},",
        f"                    _MASS_PATTERN, _KIN_PATTERN, {float(MAX_BLOCK_CONDITION)!r},",
        f"                    {'_rigid_schedule_parameter_jacobian' if el.schedules else 'None'})")
    for name, fn in PROTOCOL.items():
        functions[name] = _wrapper(name, fn)
    if "loss_matrix" in rigid.functions or any(
            "Le.m0" in d for s in el.splices for d in (s.body.samples or (s.body.data,))):
        # loss factors of the force elements and the bodies' Le (equations.md §1.1)
        functions["loss_matrix"] = _wrapper("loss_matrix", ffrf_loss_matrix)
        constants["LOSS_REFERENCE_FREQUENCY"] = repr(float(system.loss_reference_frequency))
    if "frame_poses" in rigid.functions:  # poses of the frames and the node clouds
        functions["_rigid_frame_poses"] = rigid.functions["frame_poses"]
        functions["frame_poses"] = (
            "def frame_poses(t, x, p, u=None):",
            f'    """{rigid.functions["frame_poses"][1].strip()[3:-3]}"""',
            "    return _rigid_frame_poses(t, ffrf_symbolic_state(ffrf_at(_FFRF, t, p, x, u), x),"
            " p, u)")
        functions["body_properties"] = rigid.functions["body_properties"]
        functions["node_positions"] = _NODE_POSITIONS

    bodies = ", ".join(f"{s.body.name!r} ({s.body.nq} modes"
                       f"{', two-sided' if s.body.two_sided else ''}, {s.body.inertia} inertia)"
                       for s in el.splices)
    return rigid.with_(
        docstring=(*rigid.docstring, "", f"Elastic bodies: {bodies}; the floating-frame "
                   "kernel (neweul_py.ffrf) is embedded below,", f"their arrays are in the "
                   f"data file {data.name} next to this module"
                   + "".join(f" and in {f}" for f in data.sources) + " (checked at import)."),
        imports=("import hashlib", "import math as _math", "import mmap", "import os",
                 "import stat", "import struct", "import struct as _struct", "",
                 "import numpy as _np", "import numpy as np"),
        constants=constants,
        private=private,
        functions=functions,
    ), data
