"""The FE working points of a middle-ear build: where each is, read once, solved when missing.

A build uses its FE models (one per working point, docs/fe-file-format.md) many times: the
reduction basis solves them, the refinement projects every sample and slope model of each
candidate body, and every body checks that its models share one mesh. At refine 2 a model
is about 50 MB and takes 0.16 s to read and check, and the models of the last bodies do not
fit in memory together. So

* :class:`WorkingPoints` keeps the models read most recently within a byte cap
  (:attr:`WorkingPoints.cap`, least recently used first out; a pinned one, such as the base
  the projections are differences to, stays) and remembers of every model
  it has read what a body needs without its matrices: its mesh (nodes and DOF map), source
  and fingerprint;
* :class:`LazyModels` is a sequence of working points that reads a model only when it is
  indexed, and with ``handles=True`` gives :class:`ModelHandle` objects instead, which read
  nothing for the mesh check
  (:func:`~neweul_py.elastic.parametric.snapshot_basis.check_same_mesh`) or for a projection
  already made (:class:`~neweul_py.elastic.parametric.snapshot_basis.ProjectionCache`, found
  by fingerprint).
"""

from __future__ import annotations

import json
from collections import OrderedDict
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from ..elastic.io.fe_files import read_fe_model
from .embs import model_path
from .parameters import MiddleEarParameters
from .sweep import pressure_sweep

__all__ = ["BASIS_CACHE_BYTES", "CURVE_STEP", "MODEL_CACHE_BYTES", "SWEEP_GLOB",
           "LazyModels", "ModelHandle", "WorkingPoints", "model_bytes"]

#: Step of the static curve of the volume coordinate [Pa].
CURVE_STEP = 100.0
#: The sweep directories of a build: ``fem`` (the working points asked for), then one per
#: further call of the FE sweep, named by what it holds (``fem_slopes``, ``fem_refine``, and
#: ``fem_slopes_2`` … for later calls: a sweep directory is never solved again).
SWEEP_GLOB = "fem*"
#: The FE models a build keeps in memory [bytes] (at refine 2 about 50 MB each; a refinement
#: reads 50–60 working points, of which the body of the last step needs about 40 at once).
MODEL_CACHE_BYTES = 1e9
#: … and while the reduction basis is computed (all models of refine 1, four of refine 2:
#: beside them the snapshot matrix, 1.5 GB at refine 2, and the workers' factorizations).
BASIS_CACHE_BYTES = 2.5e8
#: What :class:`WorkingPoints` remembers of a model it has read (:class:`ModelHandle`).
KEPT = ("n_dofs", "nodes", "dof_node", "dof_kind", "source")

Progress = Callable[..., None]


def model_bytes(fe: Any) -> int:
    """Bytes of the sparse matrices of an FE model."""
    return sum(m.data.nbytes + m.indices.nbytes + m.indptr.nbytes
               for m in (fe.M, fe.K, fe.D, fe.G) if m is not None)


class WorkingPoints:
    """The FE working points of a build under ``root``: where each is, read through a cache
    of at most :attr:`cap` bytes, solved when missing (module docstring).

    Parameters
    ----------
    root
        The build's directory (its sweep directories :data:`SWEEP_GLOB`).
    refine
        The mesh refinement of the FE sweeps solved here.
    progress
        Progress hook of the FE sweeps.
    params
        The middle ear's data of the FE sweeps solved here (default
        :class:`~neweul_py.middle_ear.parameters.MiddleEarParameters`).
    """

    def __init__(self, root: Path, refine: int, progress: Progress,
                 params: MiddleEarParameters | None = None) -> None:
        self.root, self.refine, self.progress = root, refine, progress
        self.params = params
        self.where: dict[float, Path] = {}
        self.models: OrderedDict[float, Any] = OrderedDict()      # least recently used first
        self.facts: dict[float, dict[str, Any]] = {}              # what KEPT names, per point
        self.pinned: set[float] = set()                          # kept whatever the cap
        self.cap = MODEL_CACHE_BYTES
        for d in sorted(root.glob(SWEEP_GLOB)):
            record = d / "sweep.json"
            if record.is_file():
                for wp in json.loads(record.read_text())["working_points"]:
                    if (d / wp["file"]).is_file():
                        self.where.setdefault(float(wp["dp_Pa"]), d)

    def solve(self, name: str, pressures: Sequence[float], curve: bool = False) -> None:
        """Solve the working points ``pressures`` into a new sweep directory named ``name``
        (``name_2`` … when that exists; written atomically); ``curve``: with the static curve
        every :data:`CURVE_STEP`."""
        d, k = self.root / name, 1
        while (d / "sweep.json").exists():
            k += 1
            d = self.root / f"{name}_{k}"
        todo = sorted({float(p) for p in pressures})
        self.progress(f"FE models at {', '.join(f'{p:+.0f}' for p in todo)} Pa")
        pressure_sweep(todo, self.params, refine=self.refine, out_dir=str(d),
                       progress=self.progress,
                       static_curve=CURVE_STEP if curve else None, base=self.base())
        self.where.update({p: d for p in todo})

    def base(self) -> Path | None:
        """The complete working-point file of the first sweep ``fem``, which later sweeps are
        stored against (delta files: the shared matrices once per build); ``None`` before
        ``fem`` exists."""
        fem = self.root / "fem"
        record = fem / "sweep.json"
        if not record.is_file():
            return None
        sweep = json.loads(record.read_text())
        name = sweep.get("fe_base", sweep["working_points"][0]["file"])  # older: all complete
        return fem / name if "/" not in name and (fem / name).is_file() else None

    def need(self, name: str, pressures: Sequence[float]) -> None:
        """The working points ``pressures``, solved into ``name`` where they are missing."""
        new = [float(p) for p in pressures if float(p) not in self.where]
        if new:
            self.solve(name, new)

    def model(self, p: float) -> Any:
        """The FE model of the working point ``p``, read once and kept while the models
        kept take less than ``self.cap`` bytes (the least recently used go first)."""
        if p in self.models:
            self.models.move_to_end(p)
            return self.models[p]
        fe = self.models[p] = read_fe_model(model_path(self.where[p], p))
        self.facts.setdefault(p, {}).update({k: getattr(fe, k) for k in KEPT})
        while sum(map(model_bytes, self.models.values())) > self.cap:
            old = next((q for q in self.models if q not in self.pinned and q != p), None)
            if old is None:
                break
            del self.models[old]
        return fe

    def fact(self, p: float, name: str) -> Any:
        """``name`` of :data:`KEPT` or ``"fingerprint"`` of the model at ``p``, read (once)
        only when the point has not been read before."""
        known = self.facts.get(p, {})
        if name not in known:
            value = getattr(self.model(p), name)
            known = self.facts[p]
            known[name] = value
        return known[name]


def _known(name: str, doc: str) -> property:
    """A read-only property of :class:`ModelHandle`: ``name`` as its store knows it."""
    return property(lambda self: self.points.fact(self.p, name), doc=doc)


class ModelHandle:
    """The FE model of one working point of :class:`WorkingPoints`, read only when more than
    its mesh (:data:`KEPT`) or fingerprint is asked of it; then every attribute is the
    model's (read through the cache)."""

    __slots__ = ("p", "points")

    def __init__(self, points: WorkingPoints, p: float) -> None:
        self.points, self.p = points, float(p)

    n_dofs = _known("n_dofs", "Number of DOFs.")
    nodes = _known("nodes", "The node table.")
    dof_node = _known("dof_node", "Node of every DOF.")
    dof_kind = _known("dof_kind", "Kind of every DOF.")
    source = _known("source", "The model's file.")
    fingerprint = _known("fingerprint", ":attr:`~neweul_py.elastic.fe_model.FEModel"
                                        ".fingerprint`, computed once.")

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):           # no copy or pickle protocol through the model
            raise AttributeError(name)
        return getattr(self.points.model(self.p), name)

    def __reduce__(self) -> Any:
        raise TypeError("a ModelHandle stays in its process (it would carry the whole "
                        "model store); pass the model itself")


class LazyModels(Sequence[Any]):
    """The FE models of the working points ``points``, each read through the cache of
    ``store`` (:meth:`WorkingPoints.model`) when it is indexed: a list would hold them all
    at once (at refine 2 a body with its slope models reads about 40), this holds none.
    ``handles``: give :class:`ModelHandle` objects (for the main process only: a handle
    does not travel to a worker process)."""

    def __init__(self, store: WorkingPoints, points: Sequence[float],
                 handles: bool = False) -> None:
        self.store, self.points = store, [float(p) for p in points]
        self.handles = handles

    def __len__(self) -> int:
        return len(self.points)

    def __getitem__(self, i: Any) -> Any:
        if isinstance(i, slice):
            return LazyModels(self.store, self.points[i], self.handles)
        p = self.points[i]
        return ModelHandle(self.store, p) if self.handles else self.store.model(p)
