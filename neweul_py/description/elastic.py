"""The ``elastic_bodies`` section of a description (docs/description-format.md; equations.md §2).

An example::

    elastic_bodies:
      beam:
        frame: hub                 # reference frame (ISYS: fixed to the ground)
        data: beam.SID_FEM         # SID text file or reduced-body .npz, relative to this file
        nodes: {tip: 1793, root: 1860}   # node frames beam.tip, beam.root
        modes: 4                   # optional: the first 4 modes, or a list of mode numbers
        initial: [0.01, 0, 0, 0]   # optional: initial elastic coordinates beam_q1 …, one per mode
        velocity: {q2: 0.5}        # optional: or a mapping qK (or beam_qK): value
        inertia: consistent        # optional: consistent (default, needs J.m2) | sid
        schedule: dp               # parametric bodies (neweul interpolate): the scheduling
                                   # variable, an expression of parameters, inputs, t and
                                   # coordinates of the rigid part
        inputs: {canal_volume_acceleration: Q}   # optional: the body's own FE inputs, driven
                                   # by an expression (of inputs, parameters, t, …)
        outputs: {probe_pressure: p_probe}      # optional: the body's own FE outputs as
                                   # description outputs (C V q)

The body's own FE inputs and outputs (reduced-body and parametric files, the ``io.*`` arrays of
:func:`neweul_py.elastic.io.reader.read_elastic_data`): an input becomes one generalized force
``(Wᵀb)_k · EXPR`` on every elastic coordinate ``NAME_qk``, an output the expression
``Σ_k (C V)_k NAME_qk``. A parametric body's modal loads and output rows must be the same at
every sample (a global basis, ``neweul_py.elastic.parametric.global_basis``, has them so when the FE
inputs and outputs do not move with the schedule); otherwise the key is refused.

Unlisted modes start at 0. The values go into the generated module's ``INITIAL_STATE``.

The data are read by a reader function that the caller passes in (layering: ``description``
imports only ``model``): :func:`neweul_py.elastic.io.reader.read_elastic_data`, which
:mod:`neweul_py.api` passes, returns the flat NumPy arrays (never symbolic). Errors in the data
file name the key path and the file (and, for SID syntax errors, the line).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import sympy as sp

from ..errors import DataError, ModelError
from ..model import ElasticBody
from .schema import Schema, section_items

__all__ = ["DataFiles", "load_elastic_bodies"]

#: ``reader(path, modes) -> dict of arrays`` (the flat invariants), may raise DataError.
ElasticReader = Callable[[Path, Any], dict]


@dataclass(frozen=True)
class DataFiles:
    """Where the data files a description names are (elastic bodies' ``data``, inputs'
    ``table``) and how elastic bodies' data are read; passed to the section loaders that read
    files.

    Attributes
    ----------
    base
        The directory relative names are resolved in: the description's, or the working
        directory for text without a file.
    reader
        ``reader(path, modes) -> flat invariant arrays`` of elastic bodies (``None``: the
        description may have none).
    """

    base: Path
    reader: ElasticReader | None = None

    @classmethod
    def of(cls, filename: str, reader: ElasticReader | None = None) -> DataFiles:
        """Data files relative to the description ``filename`` (``<…>``: no file)."""
        base = (Path(filename).parent if filename and not filename.startswith("<")
                else Path.cwd())
        return cls(base, reader)


def load_elastic_bodies(b: Any, section: Any, path: str, files: DataFiles) -> None:
    """Section loader: every entry becomes an :class:`ElasticBody` on the builder ``b``, its
    data read with ``files.reader`` relative to ``files.base``."""
    schema = Schema(required=("frame", "data"),
                    optional=("nodes", "modes", "initial", "velocity", "inertia", "schedule",
                              "inputs", "outputs"))
    for name, spec in section_items(section, path, "elastic body definitions"):
        item = f"{path}.{name}"
        spec = schema.check(spec, item, "an elastic body")
        frame = spec["frame"]
        if not isinstance(frame, str):
            raise ModelError(f"expected a frame name, got {frame!r}", f"{item}.frame")
        data_file = spec["data"]
        if not isinstance(data_file, str) or not data_file:
            raise ModelError(f"expected a file name, got {data_file!r}", f"{item}.data")
        nodes = spec.get("nodes") or {}
        if not isinstance(nodes, dict):
            raise ModelError(f"expected a mapping label: node id, got {nodes!r}",
                             f"{item}.nodes")
        pairs = []
        for label, node in nodes.items():
            if isinstance(node, bool) or not isinstance(node, int):
                raise ModelError(f"a node id must be an integer, got {node!r}",
                                 f"{item}.nodes.{label}")
            pairs.append((str(label), node))
        modes = spec.get("modes")
        if modes is not None and not (
            (isinstance(modes, int) and not isinstance(modes, bool))
            or (isinstance(modes, list) and all(isinstance(k, int) for k in modes))
        ):
            raise ModelError(f"modes must be a count or a list of mode numbers, got {modes!r}",
                             f"{item}.modes")
        base, reader = files.base, files.reader
        if reader is None:
            raise ModelError("elastic bodies need a data reader: load the description with "
                             "elastic_reader=neweul_py.elastic.io.reader.read_elastic_data (as "
                             "neweul_py.api does)", item)
        file = Path(data_file) if os.path.isabs(data_file) else base / data_file
        try:
            data = reader(file, modes)
        except DataError as exc:
            key = f"{item}.modes" if exc.item == "modes" else f"{item}.data"
            raise ModelError(f"elastic data: {exc}", key) from None
        samples, extra = _samples(data, spec.get("schedule"), file, item)
        first = samples[0] if samples else data
        inertia = _inertia(spec.get("inertia"), first, file, f"{item}.inertia")
        body = ElasticBody(str(name), frame, first, tuple(pairs), os.fspath(file), inertia,
                           **extra)
        schedule = spec.get("schedule")
        start = {key: _per_mode(spec.get(key), body, f"{item}.{key}")
                 for key in ("initial", "velocity")}
        b.elastic_body(body, start["initial"], start["velocity"], schedule)
        _body_io(b, body, spec, item)


#: Largest change of a used input column or output row of a parametric body over its
#: samples, relative to its own largest entry, for the description's constant coefficients
#: (the first sample's): below the error of a reduced body against its FE model. A global
#: basis gives rows equal at every sample; local bases in common coordinates differ by
#: about 1e-5 (the piston duct of the tests: 8.8e-6); a row that the static state turns
#: (the middle ear's TM volume: 3 %) is refused.
IO_VARIATION = 1e-4


def _check_io(body: ElasticBody, item: str) -> None:
    """A body whose data hold FE inputs and outputs (``io.B``, ``io.C``)."""
    if "io.B" not in body.data:
        raise ModelError(f"{body.source} holds no FE inputs/outputs (a reduced-body or "
                         "parametric-body .npz has them; SID and bare invariants files do "
                         "not)", item)


def _io_vector(body: ElasticBody, key: str, j: int, name: str, item: str) -> Any:
    """Input column ``j`` of ``io.B`` or output row ``j`` of ``io.C``: a description's
    coefficients are constants, so for a parametric body the vector must be the same at
    every sample within :data:`IO_VARIATION` of its own largest entry — one error naming
    the input or output otherwise (its row would need coefficients scheduled with the
    body's weights, which the description cannot express)."""
    def vector(data: dict) -> Any:
        return data[key][:, j] if key == "io.B" else data[key][j]

    first = vector(body.data)
    scale = float(abs(first).max(initial=0.0))
    for i, sample in enumerate(body.samples[1:], start=2):
        change = float(abs(vector(sample) - first).max(initial=0.0))
        if change > IO_VARIATION * scale:
            what = "input" if key == "io.B" else "output"
            by = (f"by {change / scale:.2g} of its largest coefficient" if scale > 0 else
                  f"from zero to coefficients of {change:.2g}")
            raise ModelError(f"the body's {what} {name!r} changes between sample 1 and sample "
                             f"{i} {by}: a description's {what} has constant coefficients "
                             "(leave it out, or mix the body's rows at the schedule's value "
                             "with ParametricBody.mix)", item)
    return first


def _number(v: float) -> str:
    return repr(float(v))


def _body_io(b: Any, body: ElasticBody, spec: dict, item: str) -> None:
    """``inputs``/``outputs`` of an elastic body: generalized forces on its elastic
    coordinates and expression outputs (module docstring)."""
    q = body.coordinate_names
    for key, array, names_key in (("inputs", "io.B", "io.inputs"),
                                  ("outputs", "io.C", "io.outputs")):
        given = spec.get(key)
        if given is None:
            continue
        path = f"{item}.{key}"
        if not isinstance(given, dict) or not given:
            raise ModelError(f"expected a mapping FE {key[:-1]} name: "
                             f"{'expression' if key == 'inputs' else 'output name'}", path)
        _check_io(body, path)
        names = [str(n) for n in body.data[names_key]]
        for fe_name, value in given.items():
            if str(fe_name) not in names:
                raise ModelError(f"unknown FE {key[:-1]} {fe_name!r}; the body has: "
                                 f"{', '.join(names)}", f"{path}.{fe_name}")
            j = names.index(str(fe_name))
            vector = _io_vector(body, array, j, str(fe_name), f"{path}.{fe_name}")
            if key == "inputs":
                if isinstance(value, bool) or not isinstance(value, str | int | float):
                    raise ModelError(f"expected an expression, got {value!r}",
                                     f"{path}.{fe_name}")
                for k, coef in enumerate(vector):
                    if coef != 0.0:
                        b.generalized_force(f"{q[k]}_{_slug(str(fe_name))}", q[k],
                                            f"{_number(coef)}*({value})")
            else:
                if not isinstance(value, str):
                    raise ModelError(f"expected an output name, got {value!r}",
                                     f"{path}.{fe_name}")
                terms = [f"{_number(c)}*{q[k]}" for k, c in enumerate(vector) if c != 0.0]
                b.output(value, " + ".join(terms) or "0")


def _slug(name: str) -> str:
    """An FE input name as a part of a force name (letters, digits, underscores)."""
    return "".join(ch if ch.isalnum() or ch == "_" else "_" for ch in name)


def _samples(data: dict, schedule: Any, file: Path, item: str) -> tuple[list[dict], dict]:
    """The per-sample flat invariants of a parametric body file (equations.md §2.3) and the
    ElasticBody keywords; a schedule without parametric data, or parametric data without
    a schedule, is an error naming the key."""
    if "parametric.values" not in data:
        if schedule is not None:
            raise ModelError(f"{file} is not a parametric body (neweul interpolate makes one); "
                             "a schedule needs one", f"{item}.schedule")
        return [], {}
    if schedule is None:
        raise ModelError(f"{file} is a parametric body: give its scheduling variable as "
                         "'schedule: EXPR' (parameters, inputs, t, coordinates)",
                         f"{item}.schedule")
    values = [float(v) for v in data["parametric.values"]]
    samples, slopes, curvatures = ([{k.split("/", 1)[1]: v for k, v in data.items()
                                     if k.startswith(f"{prefix}{i}/")}
                                    for i in range(len(values))]
                                   for prefix in ("sample", "slope", "curvature"))
    extra = {"samples": tuple(samples), "sample_values": tuple(values),
             "slopes": tuple(s for s in slopes if s),
             "curvatures": tuple(s for s in curvatures if s),
             "interpolation": str(data["parametric.interpolation"]),
             "coordinate": data.get("parametric.coordinate"),
             "schedule": sp.Integer(0)}          # the builder parses the expression
    return samples, extra


def _inertia(value: Any, data: dict, file: Path, path: str) -> str:
    """The inertia form of a body (``consistent`` by default): a body whose data lack the
    second-order inertia ``J.m2`` (SID files) falls back to the SID truncation with one
    warning, or is refused when ``inertia: consistent`` is asked for explicitly."""
    from ..ffrf.schema import INERTIA_FORMS  # the NumPy kernel: elastic models only

    if value is not None and value not in INERTIA_FORMS:
        raise ModelError(f"inertia must be one of {', '.join(INERTIA_FORMS)}, got {value!r}",
                         path)
    if value == "sid" or "J.m2" in data:
        return value or "consistent"
    if value == "consistent":
        raise ModelError(f"{file} lacks the second-order inertia terms J.m2 that the "
                         "consistent form needs (SID data hold none): recompute the "
                         "invariants from the FE model or use 'inertia: sid'", path)
    warnings.warn(f"{file}: no second-order inertia terms (J.m2); the body uses the SID "
                  "truncation (J linear in q, Gr constant), which is not energy-consistent "
                  f"(set {path}: sid to silence this)", stacklevel=2)
    return "sid"


def _per_mode(value: Any, body: ElasticBody, path: str) -> list[Any] | None:
    """Initial values of the elastic coordinates: ``None``, a list of ``nq`` values or a
    mapping ``qK`` / ``NAME_qK`` → value (mode K = 1 … nq; the others 0); the numbers
    themselves are checked by the builder."""
    nq = body.nq
    if value is None:
        return None
    if isinstance(value, list):
        return value
    if isinstance(value, dict):
        out: list[Any] = [0.0] * nq
        names = body.coordinate_names
        for key, v in value.items():
            short = f"q{names.index(key) + 1}" if key in names else key
            k = short[1:] if short.startswith("q") else ""
            if not (k.isdigit() and 1 <= int(k) <= nq):
                raise ModelError(f"expected q1 … q{nq} or {names[0]} … {names[-1]}, got "
                                 f"{key!r}", f"{path}.{key}")
            out[int(k) - 1] = v
        return out
    raise ModelError(f"expected a list of {nq} numbers or a mapping qK: value, got {value!r}",
                     path)
