"""``neweul middle-ear build``: the middle-ear EMBS from nothing, in one directory.

The steps (docs/equations-middle-ear.md; each reported to ``progress``):

1. **FE sweep**: the working points of the TM + air model over the static pressure difference
   (:func:`~neweul_py.middle_ear.sweep.pressure_sweep`, with its static curve when the body's
   weights are taken in the TM's volume displacement) into ``DIR/fem``;
2. **basis**: one basis of the FE models of all working points (:func:`reduction_basis`);
3. **refinement**: working points are added where the interpolated body misses the FE model
   projected there (:func:`~neweul_py.middle_ear.sampling.refine`; FE models in
   ``DIR/fem_refine``);
4. **body**: every working point's FE model projected on the basis, with its static state
   and the slopes and curvatures from the FE models next to it (``DIR/fem_slopes``) →
   ``DIR/embs/tm_air.npz`` (a parametric body, docs/reduced-body-format.md);
5. **description**: the template retargeted to the body, its manubrium nodes and the chain's
   stiffening factor (:func:`~neweul_py.middle_ear.embs.retarget`) → ``DIR/middle_ear.yaml``;
6. **module**: generated into ``DIR/generated``.

What only the build itself reads — the FE models next to the working points that gave the
slopes and curvatures (``DIR/fem_slopes*``) and the cache of the reduction basis
(``DIR/embs/basis*.npz``) — is removed at the end unless ``keep_intermediate`` is set; the
body records each such FE file with its fingerprint (``slope_sources``). The FE working
points the body was built from and the refinement's midpoints (``DIR/fem``,
``DIR/fem_refine*``), against which the EMBS is validated, stay.

The directory is written atomically
(:func:`~neweul_py.middle_ear.output.write_directory_atomically`): a build interrupted at any
point leaves the previous complete directory or none. The FE working points of a previous
build in ``DIR`` with the same refinement and parameters are reused (linked, not solved
again). ``DIR/build.json`` records the settings and the result; it is written last.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..api import generate
from ..atomic import atomic_write
from ..description.loader import load_description_text
from ..elastic.bodies.static import node_rows
from ..elastic.io.body_files import save_parametric_body
from ..elastic.io.npz import save_npz_deterministic
from ..elastic.io.reader import read_elastic_data
from ..elastic.io.working_point import read_static
from ..elastic.parametric.snapshot_basis import (
    ProjectionCache,
    basis_parametric_body,
    check_same_mesh,
    snapshot_basis,
)
from ..elastic.parametric.two_sided_basis import balanced_snapshot_basis, zero_mode_pairs
from ..errors import NeweulError
from .embs import model_path, retarget, template
from .output import write_directory_atomically
from .parameters import MiddleEarParameters
from .sampling import (
    MIN_INTERVAL,
    interface_loads,
    refine,
    static_states,
    volume_coordinate,
)
from .transfer import LumpedChain
from .working_points import (
    BASIS_CACHE_BYTES,
    MODEL_CACHE_BYTES,
    SWEEP_GLOB,
    LazyModels,
    WorkingPoints,
)

__all__ = ["BASES", "BUILD_RECORD", "BuildOptions", "build", "reduction_basis",
           "snapshot_plan"]

#: The record of a build (written last: a directory holding it is complete).
BUILD_RECORD = "build.json"
#: Frequencies of the snapshots of the Galerkin basis [Hz], each with its first derivative in
#: ``ω`` (:data:`SNAPSHOT_MOMENTS`; Hermite interpolation, one sparse LU per working point and
#: frequency serves both): 7 from 20 Hz to 6.5 kHz, where the band checked ends
#: (docs/equations-middle-ear.md, "Choice of reduction").
SNAPSHOT_HZ = np.array([20.0, 100.0, 300.0, 800.0, 2000.0, 4000.0, 6500.0])
#: Snapshots per frequency of the Galerkin basis: the response and its first derivative.
SNAPSHOT_MOMENTS = 2
#: Frequencies of the snapshots of the two-sided basis [Hz] (responses only): 20 Hz, 10 from
#: 100 Hz to 8 kHz, and 5.5 and 6.5 kHz.
BALANCED_HZ = np.sort(np.r_[20.0, np.geomspace(100.0, 8000.0, 10), 5500.0, 6500.0])
#: The reduction bases of ``neweul middle-ear build --basis`` (:func:`reduction_basis`) and
#: their default relative cut ``rtol``: of the singular values of the balanced pairing
#: (two-sided), of the POD energy (Galerkin); accuracy of both in docs/equations-middle-ear.md,
#: "Choice of reduction" (benchmarks/bench_two_sided.py).
BASES = {"two-sided": 1e-10, "galerkin": 5e-9}
Progress = Callable[..., None]


@dataclass(frozen=True)
class BuildOptions:
    """Settings of a middle-ear build (the options of ``neweul middle-ear build``).

    Parameters
    ----------
    refine
        Mesh refinement of the FE model (0 coarse … 3).
    pressures
        Working points of the FE sweep [Pa], at least two, increasing.
    basis
        ``"galerkin"`` (``W = V``: POD of the primal and adjoint snapshots, per u/p block)
        or ``"two-sided"`` (Petrov–Galerkin, ``W ≠ V``: their balanced POD);
        :func:`reduction_basis`.
    rtol
        Relative cut of the basis: of the singular values of the balanced pairing
        (two-sided) or of the POD energy (Galerkin); ``None``: that of :data:`BASES`.
    order
        Cap on the number of basis directions (``None``: all the cut keeps).
    tol
        Refinement tolerance of the interpolation indicator (0: no refinement).
    coordinate
        ``"volume"`` (the weights in the TM's static volume displacement, docs/equations.md
        §4.1) or ``"dp"``.
    slope_step
        The samples' slopes and curvatures from the FE models at every working point ∓ this
        [Pa] (Hermite weights, §4.2); 0: cubic weights through the values alone. ``None``:
        20 Pa, or with a pars flaccida an eighth of ``min_interval`` (a whole number of
        pascals, at least 1).
    min_interval
        The refinement splits no interval narrower than twice this [Pa]
        (:func:`~neweul_py.middle_ear.sampling.refine`). ``None``: :data:`MIN_INTERVAL`, or with
        a pars flaccida an eighth of its stiffening pressure if that is smaller — its
        stiffness changes fourfold within ``±p_s`` (docs/equations-middle-ear.md §8), and the
        interpolation must follow it there.
    interpolation
        ``"quintic-hermite"`` (slopes and curvatures) or ``"hermite"`` (slopes).
    generate
        Generate the module (``DIR/generated``).
    jobs
        Processes solving the snapshot systems of the working points (the same basis for
        any number).
    parameters
        The middle ear's data that differ from :class:`MiddleEarParameters`' defaults, by
        name (``neweul middle-ear build --parameters FILE``,
        :func:`~neweul_py.middle_ear.parameters.read_parameters`).
    keep_intermediate
        Keep the slope FE models and the basis cache (module docstring), so that a rebuild
        with other reduction settings reuses them.
    """

    refine: int = 1
    pressures: tuple[float, ...] = tuple(np.linspace(-4000.0, 4000.0, 9).tolist())
    basis: str = "galerkin"
    rtol: float | None = None
    order: int | None = None
    tol: float = 3e-4
    coordinate: str = "volume"
    slope_step: float | None = None
    min_interval: float | None = None
    interpolation: str = "quintic-hermite"
    generate: bool = True
    jobs: int = 1
    parameters: dict[str, float] = dataclasses.field(default_factory=dict)
    keep_intermediate: bool = False

    def __post_init__(self) -> None:
        try:
            params = MiddleEarParameters(**self.parameters)
        except TypeError as exc:
            raise NeweulError(f"parameters: {exc} (the fields of MiddleEarParameters)") from None
        flaccida = params.pf_compliance > 0
        if self.min_interval is None:
            object.__setattr__(self, "min_interval", min(
                MIN_INTERVAL, params.pf_stiffening_pressure / 8) if flaccida else MIN_INTERVAL)
        if not (np.isfinite(self.min_interval) and self.min_interval > 0):
            raise NeweulError(f"min interval: a positive number of pascals, got "
                              f"{self.min_interval!r}")
        if self.slope_step is None:
            object.__setattr__(self, "slope_step", float(max(
                1, self.min_interval // 8)) if flaccida else 20.0)
        p = np.asarray(self.pressures, dtype=float)
        if p.size < 2 or not np.all(np.isfinite(p)) or np.any(np.diff(p) <= 0):
            raise NeweulError(f"pressures: at least two increasing, finite values, got "
                              f"{list(self.pressures)}")
        if self.refine not in (0, 1, 2, 3):
            raise NeweulError(f"refine: 0, 1, 2 or 3, got {self.refine!r}")
        step = self.slope_step
        if not (np.isfinite(step) and 0 <= step < self.min_interval / 2
                and step == round(step)):
            raise NeweulError(f"slope step {step:g}: a whole number of pascals in [0, "
                              f"{self.min_interval / 2:g})")
        if self.basis not in BASES:
            raise NeweulError(f"basis: {' or '.join(map(repr, BASES))}, got {self.basis!r}")
        if self.coordinate not in ("volume", "dp"):
            raise NeweulError(f"coordinate: 'volume' or 'dp', got {self.coordinate!r}")
        if self.interpolation not in ("quintic-hermite", "hermite"):
            raise NeweulError(f"interpolation: 'quintic-hermite' or 'hermite', got "
                              f"{self.interpolation!r}")
        if not (np.isfinite(self.tol) and self.tol >= 0):
            raise NeweulError(f"tol: a number ≥ 0, got {self.tol!r}")
        if self.rtol is None:
            object.__setattr__(self, "rtol", BASES[self.basis])
        if not (np.isfinite(self.rtol) and 0 < self.rtol < 1):
            raise NeweulError(f"rtol: in (0, 1), got {self.rtol!r}")
        if not (isinstance(self.jobs, int) and self.jobs >= 1):
            raise NeweulError(f"jobs: a positive number of processes, got {self.jobs!r}")
        if self.order is not None and self.order < 1:
            raise NeweulError(f"order: a positive number of directions, got {self.order!r}")


def _quiet(*_args: Any, **_kwargs: Any) -> None:
    """A progress hook that says nothing."""


def _sources_relative(body: Any, where: Path) -> Any:
    """``body`` with the FE files of its sample and slope sources relative to ``where`` (the
    body file's folder): the build's temporary directory is renamed when it is complete,
    and a build moved as a whole still names its FE models (the same bytes in any ``DIR``)."""
    def rel(source: Any) -> dict[str, Any]:
        out = dict(source)
        if out.get("file"):
            out["file"] = Path(os.path.relpath(out["file"], where)).as_posix()
        return out

    return body.with_(sample_sources=tuple(map(rel, body.sample_sources)),
                      slope_sources=tuple(map(rel, body.slope_sources)))


def _reuse(old: Path, tmp: Path, refine: int, parameters: dict[str, float]) -> None:
    """Link the FE sweeps and the basis cache of a previous build ``old`` of the same
    refinement and parameters into ``tmp`` (hard links: no copy, and the old directory stays
    intact)."""
    record = old / BUILD_RECORD
    if not record.is_file():
        return
    made = json.loads(record.read_text())
    if made.get("refine") != refine or made.get("parameters", {}) != parameters:
        return
    for src in (*sorted(old.glob(SWEEP_GLOB)), old / "embs"):
        if not src.is_dir():
            continue
        name = src.name
        for path in src.rglob("*"):
            if path.is_dir() or path.is_symlink() or (name == "embs" and
                                                      not path.name.startswith("basis")):
                continue
            dst = tmp / path.relative_to(old)
            dst.parent.mkdir(parents=True, exist_ok=True)
            try:
                os.link(path, dst)
            except OSError:
                shutil.copy2(path, dst)


def _remove_intermediate(tmp: Path, keep: set[Path]) -> None:
    """Remove from the build ``tmp`` what only the build reads (module docstring): the slope
    FE models and the basis cache. A slope sweep that holds a working point of the body
    (``keep``: a rebuild may take a sample from a previous build's slope models) stays. No
    other FE model is stored relative to them (every delta file's base is a working point
    of ``DIR/fem``)."""
    for path in sorted(tmp.glob("fem_slopes*")):
        if path.resolve() not in keep:
            shutil.rmtree(path)
    for path in sorted((tmp / "embs").glob("basis*.npz")):
        path.unlink()


def snapshot_plan(basis: str) -> tuple[np.ndarray, int]:
    """The snapshot frequencies [Hz] of a reduction basis (``"galerkin"`` or ``"two-sided"``)
    and the snapshots per frequency (the response and its derivatives)."""
    return (BALANCED_HZ, 1) if basis == "two-sided" else (SNAPSHOT_HZ, SNAPSHOT_MOMENTS)


def reduction_basis(fes: Sequence[Any], umbo: int, k_attach: float, cache: Path,
                    options: BuildOptions, progress: Progress
                    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """The reduction bases ``V``, ``W`` of the TM + air body (``W`` ``None``: ``W = V``) and
    the weight of each direction, from full FE responses of every working point at
    :data:`SNAPSHOT_HZ` with their first derivatives (Galerkin) or at :data:`BALANCED_HZ`
    (two-sided) (:func:`~neweul_py.middle_ear.sampling.interface_loads`): primal to
    the canal source and the six rigid malleus motions seen through the TM–manubrium
    springs, adjoint to the probe pressure, the umbo and the malleus loads.

    ``options.basis``: ``"two-sided"`` — balanced POD
    (:func:`~neweul_py.elastic.parametric.two_sided_basis.balanced_snapshot_basis`): ``V``
    from the primal, ``W`` from the adjoint snapshots and the zero modes of every working
    point as right/left pairs (the constant pressures of the closed air volumes, which keep
    ``λ = 0``), ``Wᵀ M̄ V = I``, weights ``σ²``;
    ``"galerkin"`` — one basis of both, POD-compressed per u/p block in the energy norms
    (:func:`~neweul_py.elastic.parametric.snapshot_basis.snapshot_basis`), weights the POD
    energies (docs/equations-middle-ear.md, "Choice of reduction"). Cached in ``cache``;
    a Galerkin basis is extended by the missing frequencies (a cache of other moments is
    solved anew), a two-sided one rebuilt."""
    Kx, F, Cadj = interface_loads(fes[0], umbo, k_attach)
    n = len(fes)

    def say(m: str) -> None:
        if "snapshots: sample" in m:
            progress("basis", int(m.split()[2]), n)
        else:
            progress(m)

    two = options.basis == "two-sided"
    freqs, moments = snapshot_plan(options.basis)
    done, prior, W = np.zeros(0), None, None
    if cache.is_file():
        with np.load(cache) as z:
            cached = int(z["moments"]) if "moments" in z.files else 1
            if cached == moments:           # else solved anew
                V, energy, done = z["V"], z["energy"], z["freqs"]
                W = z["W"] if "W" in z.files else None
                prior = V
    todo = np.array([f for f in freqs if not np.any(np.isclose(f, done))])
    if todo.size and two:
        b = balanced_snapshot_basis(fes, [F] * n, [Cadj] * n, freqs, Kx,
                                    rtol=options.rtol, progress=say,
                                    pairs=[zero_mode_pairs(fe) for fe in fes],
                                    workers=options.jobs)
        V, W, energy = b.V, b.W, b.singular_values[:b.order] ** 2
        todo = freqs
    elif todo.size:
        V, energy = snapshot_basis(fes, [F] * n, todo, Kx, rtol=options.rtol, prior=prior,
                                   adjoint=[Cadj] * n, progress=say, workers=options.jobs,
                                   moments=moments)
    if todo.size:
        solved = np.union1d(done, todo)
        cache.parent.mkdir(parents=True, exist_ok=True)
        # deflated where it pays: a u–p basis is block-diagonal, four fifths zeros
        save_npz_deterministic(cache, {"V": V, "energy": energy, "freqs": solved,
                                       "moments": np.asarray(moments),
                                       **({"W": W} if two else {})})
    k = options.order
    return V[:, :k], (W[:, :k] if two else None), energy[:k]


def _fill(tmp: Path, options: BuildOptions, progress: Progress) -> dict[str, Any]:
    """Build into the temporary directory ``tmp`` (the steps of the module docstring)."""
    t0 = time.perf_counter()
    sweeps = WorkingPoints(tmp, options.refine, progress,
                           MiddleEarParameters(**options.parameters))
    pressures = [float(p) for p in options.pressures]
    volume = options.coordinate == "volume"
    fem = tmp / "fem"
    progress(f"1/6 FE sweep (refine {options.refine})")
    record = fem / "sweep.json"
    if not (record.is_file() and all(p in sweeps.where for p in pressures)
            and (not volume or (fem / "static_curve.csv").is_file())):
        sweeps.solve("fem", pressures, curve=volume)
    sweep = json.loads(record.read_text())
    params = MiddleEarParameters(**sweep["parameters"])
    manubrium = [int(i) for i in sweep["interface_nodes"]["manubrium"]]
    umbo = int(sweep["interface_nodes"]["umbo"])
    fes = LazyModels(sweeps, pressures)
    check_same_mesh(fes, pressures)
    progress("2/6 reduction basis")
    tag = "basis2" if options.basis == "two-sided" else "basis"
    sweeps.cap = BASIS_CACHE_BYTES          # the snapshot matrix and the workers need the room
    V, W, energy = reduction_basis(fes, umbo, params.k_tm_manubrium,
                                   tmp / "embs" / f"{tag}_r{options.refine}_{options.rtol:g}.npz",
                                   options, progress)
    sweeps.cap = MODEL_CACHE_BYTES
    step = float(options.slope_step)
    projections = ProjectionCache()         # each FE model projected on (V, W) once
    sweeps.pinned.add(pressures[0])         # the first projected: the others' base

    def slope_keywords(pts: list[float], static: bool) -> dict[str, Any]:
        if step <= 0:
            return {}
        side = [[p + sign * step for p in pts] for sign in (-1.0, 1.0)]
        sweeps.need("fem_slopes", side[0] + side[1])
        return {"slope_models": tuple(LazyModels(sweeps, ps, handles=True) for ps in side),
                "slope_step": step,
                "slope_static": tuple(static_states(sweeps.where, ps, manubrium)
                                      for ps in side) if static else None}

    def body_of(points: Sequence[float], static: bool = False) -> Any:
        pts = [float(p) for p in points]
        models = LazyModels(sweeps, pts, handles=True)   # read as the projections need
        if len(pts) == 1:     # a midpoint's reference: its difference to the base projected
            return projections.body(models[0], V, W, keep_nodes=manubrium, remember=False)
        pb = basis_parametric_body(
            models, V, pts, parameter="dp", keep_nodes=manubrium, energy=energy, W=W,
            static=static_states(sweeps.where, pts, manubrium) if static else None,
            interpolation=options.interpolation if step > 0 else "cubic",
            projections=projections, **slope_keywords(pts, static))
        if not volume:
            return pb
        return pb.with_(coordinate=volume_coordinate(sweeps.where, fem / "static_curve.csv",
                                                     pts),
                        coordinate_name="volume_displacement_m3")

    samples = np.array(pressures)
    if options.tol > 0:
        progress(f"3/6 refinement (tol {options.tol:g})")
        b0 = body_of(pressures[:1])
        rows = node_rows(b0.nodes, b0.dof_node, b0.dof_kind).ravel()
        samples = refine(pressures, body_of, options.tol, b0.V_kept[rows],
                         params.k_tm_manubrium / len(manubrium),
                         lambda pts: sweeps.need("fem_refine", pts), progress,
                         min_interval=float(options.min_interval))
    progress(f"4/6 parametric body ({samples.size} working points)")
    body = _sources_relative(body_of(samples, static=True), tmp / "embs")
    save_parametric_body(body, tmp / "embs" / "tm_air.npz")
    sample_dirs = {(tmp / "embs" / s["file"]).resolve().parent for s in body.sample_sources
                   if s.get("file")}
    made = {"interpolation_used": body.interpolation,
            "static_residual": body.static.residual.tolist()}
    # the FE models and projections are done with: free them before the module is generated
    del fes, body
    sweeps.models.clear()
    projections.bodies.clear()
    projections.base = None
    progress("5/6 description")
    text = retarget(template(), fem, manubrium, tmp / "embs" / "tm_air.npz",
                    tmp / "embs" / "chain_factor", where=tmp)
    desc = tmp / "middle_ear.yaml"
    load_description_text(text, str(desc), elastic_reader=read_elastic_data)  # then write
    atomic_write(desc, text)
    if options.generate:
        progress("6/6 generated module")
        generate(desc, tmp / "generated", progress=progress, reference_bodies=True)
    tangent = [float(read_static(model_path(sweeps.where[p], p))["chain_tangent"][2, 2])
               for p in samples]
    chain = LumpedChain()
    snap_hz, snap_moments = snapshot_plan(options.basis)
    if not options.keep_intermediate:
        _remove_intermediate(tmp, sample_dirs)
    return {
        "format": "neweul-middle-ear-build", "version": 1,
        **dataclasses.asdict(options),
        "pressures": pressures, "order": int(V.shape[1]), "two_sided": W is not None,
        "samples_Pa": samples.tolist(),
        "snapshot_Hz": snap_hz.tolist(), "snapshot_moments": snap_moments,
        "manubrium": manubrium, "umbo": umbo,
        "body": "embs/tm_air.npz", "description": "middle_ear.yaml",
        "module": "generated/middle_ear.py" if options.generate else None,
        **made,
        "chain_tangent_N_per_m": tangent,
        "ligament_factor": [chain.ligament_factor(k) for k in tangent],
        "seconds": round(time.perf_counter() - t0, 1),
    }


def build(directory: str | os.PathLike, options: BuildOptions | None = None,
          progress: Progress = _quiet) -> dict[str, Any]:
    """Build the middle-ear EMBS into ``directory`` (module docstring) and return its record.

    Parameters
    ----------
    directory
        The build directory: new, empty, or a previous build (replaced atomically; its FE
        working points of the same refinement and parameters are reused).
    options
        :class:`BuildOptions` (default: refine 1, −4000…4000 Pa in 9 working points).
    progress
        ``progress(message)`` and ``progress(stage, done, total)`` (a
        :class:`~neweul_py.progress.Tracker` fits).

    Raises
    ------
    NeweulError
        Bad options, a directory that holds other data, an unconverged static state, samples
        on different meshes, a description node that is not in the body: one error, and the
        previous directory is left as it was.
    """
    options = options or BuildOptions()
    out = Path(directory)

    def fill(tmp: Path) -> dict[str, Any]:
        _reuse(out, tmp, options.refine, options.parameters)
        return _fill(tmp, options, progress)

    write_directory_atomically(out, fill, manifest=BUILD_RECORD)
    return json.loads((out / BUILD_RECORD).read_text())
