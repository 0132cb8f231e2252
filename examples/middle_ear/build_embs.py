"""Build the middle-ear EMBS from nothing: FE sweep → basis → body → description → module.

Run from the repository root (README.md, "The assembled EMBS")::

    python examples/middle_ear/build_embs.py [--dir DATA] [--refine 1] [--tol 3e-4]
        [--coordinate volume|dp] [--slope-step 20] [--interpolation quintic-hermite|hermite]
        [-q]

One command, with progress on stderr (:class:`neweul_py.progress.Tracker`):

1. **FE sweep** ``neweul fem middle-ear --pressures -4000:4000:9`` into ``DATA/fem`` (skipped
   when it is there with the same refinement and working points);
2. **basis**: a snapshot global basis (:mod:`neweul_py.elastic.parametric.snapshot_basis`): full FE
   responses of every working point at 20 Hz and 10 frequencies 100 Hz–8 kHz to the canal
   sound source and to the six rigid motions of the malleus seen through the TM–manubrium
   springs (36 933 N/m in all, equal per manubrium node), and the adjoint responses of the
   probe pressure, the umbo and the six malleus loads (same factorizations), POD-compressed
   per u/p block in the energy norms (cached in ``DATA/embs/basis3_r*.npz``);
3. **refinement** (``--tol``; 0 switches it off): working points are added where the
   parametric body between two samples differs from the FE model projected there by more
   than ``tol`` (:func:`refine`; their FE models in ``DATA/fem_refine``); docs §7;
4. **body**: every working point's FE model projected on the basis (fixed-frame invariants:
   the body is on ISYS, gravity 0), with its static state (static reduced coordinates, node
   displacements and interface forces at the manubrium, static outputs; ``static/*``,
   docs/equations-middle-ear.md §5) → ``DATA/embs/tm_air.npz`` (a parametric body with the
   samples' slopes and curvatures — the FE models at every working point ∓ 20 Pa in
   ``DATA/fem_slopes``, their static states included, docs/equations.md §4.2 — and quintic
   Hermite weights (``--interpolation hermite``: cubic, slopes only) in the TM's
   static volume displacement, §4.1 — the sweep also writes its static curve every 100 Pa;
   ``--coordinate dp``: in ``dp``; ``--slope-step 0``: cubic weights without slopes), and
   ``DATA/embs/build.json`` (samples, node ids, chain factors);
5. **description**: ``middle_ear.yaml`` retargeted to this body and its manubrium nodes →
   ``DATA/embs/middle_ear.yaml``, loaded (a node that is not in the body, an input or output
   the body lacks: one error naming the key);
6. **module**: generated into ``DATA/embs/generated`` (``--no-generate`` skips it).

Bad input is one error line and writes nothing it has not finished: a working point without
a static state or with forces at other nodes, samples on different meshes, a description node
that is not in the body. Each output file is written atomically. ``data/`` is not committed.
The studies then run with ``python examples/middle_ear/studies.py --dir DATA``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sps

from neweul_py.atomic import atomic_write
from neweul_py.elastic import read_fe_model
from neweul_py.elastic.io.body_files import save_parametric_body
from neweul_py.elastic.io.working_point import read_static
from neweul_py.elastic.parametric.snapshot_basis import (
    basis_parametric_body,
    check_same_mesh,
    snapshot_basis,
)
from neweul_py.elastic.reductors.projection import build_reduced_body
from neweul_py.errors import DataError, NeweulError
from neweul_py.middle_ear.parameters import MiddleEarParameters
from neweul_py.middle_ear.transfer import LumpedChain
from neweul_py.progress import QUIET_HELP, Tracker

HERE = Path(__file__).resolve().parent
SNAPSHOT_HZ = np.r_[20.0, np.geomspace(100.0, 8000.0, 10)]
#: Frequencies of the refinement indicator [Hz].
INDICATOR_HZ = np.geomspace(100.0, 5000.0, 24)
#: Narrowest interval the refinement splits [Pa] (file names hold whole pascals).
MIN_INTERVAL = 125.0


def model_file(fem: Path, dp: float) -> Path:
    """The working point's file (the name ``neweul fem`` gives it)."""
    return fem / f"model_dp{dp:+06.0f}.npz"


#: Step of the slope models [Pa] (``--slope-step``; whole pascals: file names hold them).
SLOPE_STEP = 20.0
#: Step of the static curve of the volume coordinate [Pa] (``--coordinate volume``).
CURVE_STEP = 100.0


def build_sweep(fem: Path, refine: int, pressures, quiet: bool, curve: bool = False) -> None:
    """``neweul fem middle-ear`` at ``pressures`` into ``fem`` (atomically: all or nothing;
    an unconverged static state is its one error line, and nothing is written); ``curve``:
    with its static curve (``--static-curve``)."""
    cmd = [sys.executable, "-m", "neweul_py.cli", "fem", "middle-ear", "--pressures",
           ",".join(f"{p:g}" for p in pressures), "--refine", str(refine), "-o", str(fem)]
    cmd += ["--static-curve", f"{CURVE_STEP:g}"] if curve else []
    done = subprocess.run(cmd + (["-q"] if quiet else []), stderr=subprocess.PIPE, text=True)
    if done.returncode:
        lines = [x for x in done.stderr.splitlines() if x.strip()]
        raise NeweulError(f"FE sweep into {fem} failed: {lines[-1] if lines else done.returncode}")
    if not quiet:
        sys.stderr.write(done.stderr)


def ensure_sweep(fem: Path, refine: int, pressures: np.ndarray, quiet: bool,
                 curve: bool = False) -> dict:
    """The FE sweep in ``fem`` (built when missing, of another refinement or other points,
    or without the static curve that ``curve`` asks for)."""
    sweep = fem / "sweep.json"
    if sweep.exists() and json.loads(sweep.read_text()).get("refine") == refine and all(
            model_file(fem, p).exists() for p in pressures) and (
            not curve or (fem / "static_curve.csv").exists()):
        return json.loads(sweep.read_text())
    build_sweep(fem, refine, pressures, quiet, curve)
    return json.loads(sweep.read_text())


def rigid_map(fe, names: list[str], umbo: int) -> np.ndarray:
    """(3m, 6) rigid malleus map ``u = t + θ × (x − x_umbo)`` in the row order of ``names``
    (``manubrium.<id>.u?``; the FE inputs are ordered as strings, "20" before "8")."""
    xyz = {int(r[0]): r[1:4] for r in fe.nodes}
    T = np.zeros((len(names), 6))
    e = np.eye(3)
    for row, name in enumerate(names):
        _, node, kind = name.split(".")
        a = "xyz".index(kind[1])
        r = xyz[int(node)] - xyz[umbo]
        T[row, a] = 1.0
        T[row, 3:] = [np.cross(e[b], r)[a] for b in range(3)]
    return T


def interface_loads(fe, umbo: int, k_attach: float
                    ) -> tuple[sps.csr_matrix, np.ndarray, np.ndarray]:
    """``K_x`` (the TM–manubrium springs to ground), the loads ``[b_canal, K_x T]`` and the
    output rows (transposed) ``[c_probe, c_umbo, K_x T]`` of the adjoint snapshots."""
    man = [name for name in fe.inputs if name.startswith("manubrium.")]
    dofs = np.array([fe.inputs[name][0][0] for name in man])
    k = k_attach / (dofs.size // 3)
    n = fe.n_dofs
    Kx = sps.csr_matrix((np.full(dofs.size, k), (dofs, dofs)), shape=(n, n))
    F = np.zeros((n, 7))
    F[:, 0] = fe.B("canal_volume_acceleration")[:, 0]
    F[dofs, 1:] = k * rigid_map(fe, man, umbo)
    Cadj = np.zeros((n, 8))
    for j, name in enumerate(("probe_pressure", "umbo_uz")):
        for i, w in fe.outputs[name]:
            Cadj[i, j] += w
    Cadj[:, 2:] = F[:, 1:]
    return Kx, F, Cadj


def swept_volumes(paths) -> dict[float, float]:
    """``Δp → V``: the exact swept volume of the rows of the sweeps' ``static.csv`` (or
    ``static_curve.csv``) files ``paths``."""
    volume: dict[float, float] = {}
    for path in paths:
        rows = np.genfromtxt(path, delimiter=",", names=True)
        volume |= dict(zip(np.atleast_1d(rows["dp_Pa"]).tolist(),
                           np.atleast_1d(rows["volume_displacement_m3"]).tolist(), strict=True))
    return volume


def volume_coordinate(where: dict[float, Path], curve: Path, points) -> np.ndarray:
    """The (2, n) volume-coordinate table of a body of the working points ``points``
    (docs/equations.md §4.1): the static curve ``curve`` and the exact swept volume of every
    known working point (``static.csv`` of each directory in ``where``)."""
    from neweul_py.elastic.parametric.samples import coordinate_table

    table = swept_volumes([curve, *sorted({d / "static.csv" for d in where.values()})])
    sig = np.array(sorted(table))
    return coordinate_table(np.sort(np.asarray(points, dtype=float)), sig,
                            np.array([table[v] for v in sig]), str(curve))


def static_states(where: dict[float, Path], pressures, manubrium: list[int]) -> list[dict]:
    """Per working point (in the sweep directory ``where[p]``) the static state the body
    carries (docs/equations-middle-ear.md §5): the FE file's ``static_x``, the static forces
    of the malleus on the manubrium nodes, and the exact nonlinear swept volume
    (``static.csv``) as the static value of the body's ``tm_volume_displacement`` output (its
    row applied to ``x_s`` is only the linearized volume). A working point without a static
    group, or whose malleus forces act on other nodes than ``manubrium``, is one
    :class:`DataError`."""
    volume = swept_volumes(d / "static.csv" for d in set(where.values()))
    out = []
    for p in pressures:
        path = model_file(where[float(p)], p)
        st = read_static(path)
        if st is None or float(p) not in volume:
            raise DataError("the working point carries no static state (static_* arrays, "
                            "static.csv): rebuild it with neweul fem middle-ear", str(path),
                            "static_x")
        ids = [int(i) for i in st["manubrium_node_id"]]
        if sorted(ids) != sorted(manubrium):
            raise DataError(f"static forces at nodes {ids}, the body's manubrium nodes are "
                            f"{manubrium}", str(path), "static_manubrium_node_id")
        out.append({"x": st["x"], "node_force": dict(zip(ids, st["manubrium_force"],
                                                         strict=True)),
                    "outputs": {"tm_volume_displacement": volume[float(p)]}})
    return out


def write_description(out: Path, data: Path) -> Path:
    """``middle_ear.yaml`` retargeted to this build (the body file, the sweep's manubrium
    nodes, one bushing per node): ``DATA/embs/middle_ear.yaml``; its loader checks the body
    (nodes, inputs, outputs, schedule) — a manubrium node that is not a node of the body is
    one error naming the key."""
    from neweul_py.api import read_elastic_data
    from neweul_py.description.loader import load_description_text

    sys.path.insert(0, str(HERE))
    import chain_factor
    import validate_embs

    if out.resolve() != (data / "embs").resolve():
        raise ValueError(f"the body must be in {data / 'embs'}, not {out}")
    # the manubrium nodes, the per-node TM–manubrium stiffness and the chain's φ(Δp) table
    # of this sweep (chain_factor.retarget; it generates the chain alone to find φ)
    text = chain_factor.retarget(validate_embs.DESCRIPTION.read_text(), data,
                                 out / "generated_chain_factor", where=out)
    path = out / "middle_ear.yaml"
    load_description_text(text, str(path), elastic_reader=read_elastic_data)   # then write
    atomic_write(path, text)
    return path


def indicator(body, ref, phi: np.ndarray, k_node: float) -> float:
    """Max relative difference of two bodies' transfer functions (canal source → probe
    pressure, umbo) over :data:`INDICATOR_HZ`, with the manubrium free and held by the
    TM–manubrium springs ``k_node`` at the node rows ``phi`` (the two ends of what a chain
    does): the interpolation error indicator of :func:`refine`."""
    from neweul_py.elastic.quality.measures import frf_reduced

    err = 0.0
    for k in (0.0, k_node):
        h = [frf_reduced(x.with_(K=x.K + k * phi.T @ phi), INDICATOR_HZ,
                         "canal_volume_acceleration", ["probe_pressure", "umbo_uz"])
             for x in (body, ref)]
        err = max(err, float(np.max(np.abs(h[0] - h[1]) / np.abs(h[1]))))
    return err


def refine(samples: np.ndarray, body_of, tol: float, phi: np.ndarray, k_node: float,
           more_models, progress) -> np.ndarray:
    """The working points with samples added where the parametric body misses (greedy
    sampling, e.g. Haasdonk 2017, *Reduced basis methods*, §2.4): at the middle of every
    interval the FE model is built (``more_models(points)``), projected on the basis and
    compared with the body interpolated there (:func:`indicator`); where they differ by more
    than ``tol`` the middle becomes a sample. Repeated until every interval passes or is
    :data:`MIN_INTERVAL` wide. ``body_of(points)`` is the parametric body of the samples
    ``points`` (a single point: that working point's body)."""
    s = np.array(samples, dtype=float)
    passed: set[tuple[float, float]] = set()
    rounds = 0
    while True:
        todo = [(a, b) for a, b in itertools.pairwise(s)
                if (a, b) not in passed and b - a >= 2 * MIN_INTERVAL]
        if not todo:
            return s
        rounds += 1
        mids = [0.5 * (a + b) for a, b in todo]
        more_models(mids)
        pb = body_of(s)
        added = []
        for i, ((a, b), m) in enumerate(zip(todo, mids, strict=True)):
            e = indicator(pb.at(m), body_of([m]), phi, k_node)
            progress(f"refinement {rounds}", i + 1, len(todo))
            progress(f"  {m:+7.1f} Pa (between {a:+.0f} and {b:+.0f}): indicator {e:.2e}"
                     + (" → sample" if e > tol else ""))
            (added.append(m) if e > tol else passed.add((a, b)))
        if not added:
            return s
        s = np.sort(np.r_[s, added])


def snapshot(fes, F, Kx, Cadj, cache: Path, rtol: float, progress) -> tuple[np.ndarray, ...]:
    """The snapshot basis (cached in ``cache``; a cached basis is extended by the missing
    frequencies only)."""
    done, prior = np.zeros(0), None
    if cache.exists():
        with np.load(cache) as z:
            V, energy = z["V"], z["energy"]
            done = z["freqs"]
        prior = V
    todo = np.array([f for f in SNAPSHOT_HZ if not np.any(np.isclose(f, done))])
    if todo.size:
        n = len(fes)
        V, energy = snapshot_basis(
            fes, [F] * n, todo, Kx, rtol=rtol, prior=prior, adjoint=[Cadj] * n,
            progress=lambda m: progress(m) if "snapshots: sample" not in m else progress(
                "basis", int(m.split()[2]), n))
        freqs = np.union1d(done, todo)
        atomic_write(cache, lambda fh: np.savez(fh, V=V, energy=energy, freqs=freqs))
    return V, energy


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--refine", type=int, default=1)
    ap.add_argument("--rtol", type=float, default=1e-8,
                    help="relative POD energy cut of the snapshot basis (default 1e-8)")
    ap.add_argument("--order", type=int, default=None, help="cap the number of directions")
    ap.add_argument("--tol", type=float, default=3e-4,
                    help="refinement: add working points where the interpolated body differs "
                    "from the projected FE model by more than this (default 3e-4, the basis "
                    "error at the midpoints; 0: no refinement)")
    ap.add_argument("--coordinate", choices=("dp", "volume"), default="volume",
                    help="the variable of the body's cubic weights: the TM's static volume "
                    "displacement (default; docs/equations.md §4.1; the sweep also solves its "
                    f"static curve every {CURVE_STEP:g} Pa) or dp itself")
    ap.add_argument("--slope-step", type=float, default=SLOPE_STEP, metavar="PA",
                    help="the samples' slopes from the FE models at every working point ∓ PA "
                    f"(Hermite weights, docs/equations.md §4.2; default {SLOPE_STEP:g} Pa; 0: "
                    "cubic weights through the values alone)")
    ap.add_argument("--interpolation", choices=("quintic-hermite", "hermite"),
                    default="quintic-hermite",
                    help="with the slope models: quintic Hermite weights — the samples' "
                    "slopes and curvatures, from the same models (default) — or cubic "
                    "Hermite weights (slopes only); docs/equations.md §4.2")
    ap.add_argument("--pressures", default="-4000:4000:9", metavar="START:STOP:N",
                    help="working points of the FE sweep [Pa] (START:STOP:N or a comma list; "
                    "default -4000:4000:9)")
    ap.add_argument("--dir", type=Path, default=HERE / "data")
    ap.add_argument("--no-generate", action="store_true", help="skip the generated module")
    ap.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    args = ap.parse_args()
    try:
        with Tracker("middle-ear EMBS", quiet=args.quiet) as track:
            build(args, track)
    except NeweulError as exc:
        sys.exit(f"error: {exc}")


def parse_pressures(text: str) -> np.ndarray:
    """``START:STOP:N`` or a comma list → at least two increasing working points [Pa]."""
    try:
        if ":" in text:
            a, b, n = text.split(":")
            p = np.linspace(float(a), float(b), int(n))
        else:
            p = np.array([float(v) for v in text.split(",")])
    except ValueError:
        raise NeweulError(f"--pressures {text!r}: START:STOP:N or a comma list of numbers"
                          ) from None
    if p.size < 2 or not np.all(np.isfinite(p)) or np.any(np.diff(p) <= 0):
        raise NeweulError(f"--pressures {text!r}: at least two increasing, finite values")
    return p


def build(args: argparse.Namespace, track: Tracker) -> None:
    """The six steps of the module docstring."""
    t0 = time.perf_counter()
    fem, extra, out = args.dir / "fem", args.dir / "fem_refine", args.dir / "embs"
    near, step = args.dir / "fem_slopes", args.slope_step
    if not (np.isfinite(step) and 0 <= step < MIN_INTERVAL / 2 and step == round(step)):
        raise NeweulError(f"--slope-step {step:g}: a whole number of pascals in [0, "
                          f"{MIN_INTERVAL / 2:g})")
    pressures = parse_pressures(args.pressures)
    track.say(f"1/6 FE sweep (refine {args.refine}) in {fem}")
    volume = args.coordinate == "volume"
    sweep = ensure_sweep(fem, args.refine, pressures, args.quiet, volume)
    params = MiddleEarParameters(**sweep["parameters"])
    manubrium = [int(i) for i in sweep["interface_nodes"]["manubrium"]]
    umbo = int(sweep["interface_nodes"]["umbo"])
    fes = [read_fe_model(model_file(fem, p)) for p in pressures]
    check_same_mesh(fes, pressures)
    Kx, F, Cadj = interface_loads(fes[0], umbo, params.k_tm_manubrium)
    track.say("2/6 snapshot basis")
    V, energy = snapshot(fes, F, Kx, Cadj, out / f"basis3_r{args.refine}_{args.rtol:g}.npz",
                         args.rtol, track)
    V, energy = V[:, :args.order], energy[:args.order]   # columns by decreasing energy
    where = {float(p): fem for p in pressures}
    models: dict[float, object] = dict(zip(pressures.tolist(), fes, strict=True))

    def model(p: float):
        if p not in models:
            models[p] = read_fe_model(model_file(where[p], p))
        return models[p]

    def slope_models(pts: list[float], static: bool) -> dict:
        """The keywords of the samples' slopes (``--slope-step``; docs/equations.md §4.2):
        the FE models at every working point ∓ ``step`` (built into ``DATA/fem_slopes`` when
        missing) and, for the final body, their static states."""
        if step <= 0:
            return {}
        side = [[p + sign * step for p in pts] for sign in (-1.0, 1.0)]
        new = [p for p in side[0] + side[1] if p not in where]
        if new:
            known = [p for p, d in where.items() if d == near]
            build_sweep(near, args.refine, sorted({*known, *new}), True)
            where.update({float(p): near for p in new})
        return {"slope_models": tuple([model(p) for p in ps] for ps in side),
                "slope_step": step,
                "slope_static": tuple(static_states(where, ps, manubrium) for ps in side)
                if static else None}

    def body_of(points, static: bool = False):
        pts = [float(p) for p in points]
        fe_list = [model(p) for p in pts]
        check_same_mesh(fe_list, pts)
        if len(pts) == 1:     # one working point: its FE model projected
            return build_reduced_body(fe_list[0], V, V, "snapshot", {}, keep_nodes=manubrium)
        pb = basis_parametric_body(
            fe_list, V, pts, parameter="dp", keep_nodes=manubrium, energy=energy,
            static=static_states(where, pts, manubrium) if static else None,
            interpolation=args.interpolation if step > 0 else "cubic",
            **slope_models(pts, static))
        if not volume:
            return pb
        return pb.with_(coordinate=volume_coordinate(where, fem / "static_curve.csv", pts),
                        coordinate_name="volume_displacement_m3")

    def more_models(points):
        new = [p for p in points if p not in where]
        if new:
            known = sorted(p for p, d in where.items() if d == extra)
            track.say(f"FE models at {', '.join(f'{p:+.0f}' for p in new)} Pa")
            build_sweep(extra, args.refine, sorted({*known, *new}), True)
            where.update({float(p): extra for p in new})

    if (extra / "sweep.json").exists() and json.loads((extra / "sweep.json").read_text()).get(
            "refine") == args.refine:
        for wp in json.loads((extra / "sweep.json").read_text())["working_points"]:
            if (extra / wp["file"]).exists():
                where.setdefault(float(wp["dp_Pa"]), extra)
    samples = pressures
    if args.tol > 0:
        track.say(f"3/6 refinement (tol {args.tol:g})")
        k_node = params.k_tm_manubrium / len(manubrium)
        b0 = body_of(pressures[:1])
        rows = node_rows(b0)
        samples = refine(pressures, body_of, args.tol, b0.V_kept[rows], k_node, more_models,
                         track)
    track.say(f"4/6 parametric body ({samples.size} working points)")
    body = body_of(samples, static=True)
    save_parametric_body(body, out / "tm_air.npz")
    chain = LumpedChain()
    tangent = [float(read_static(model_file(where[p], p))["chain_tangent"][2, 2])
               for p in samples]
    info = {"refine": args.refine, "order": int(V.shape[1]), "rtol": args.rtol,
            "tol": args.tol, "coordinate": args.coordinate, "slope_step_Pa": step,
            "interpolation": body.interpolation, "pressures_Pa": samples.tolist(),
            "snapshot_Hz": SNAPSHOT_HZ.tolist(), "manubrium": manubrium, "umbo": umbo,
            "static_residual": body.static.residual.tolist(),
            "chain_tangent_N_per_m": tangent,
            "ligament_factor": [chain.ligament_factor(k) for k in tangent]}
    atomic_write(out / "build.json", json.dumps(info, indent=1) + "\n")
    track.say("static state in the body's coordinates: relative residual "
              + ", ".join(f"{p:+.0f} Pa {r:.1e}" for p, r in
                          zip(samples, body.static.residual, strict=True)))
    track.say("5/6 description")
    desc = write_description(out, args.dir)
    if not args.no_generate:
        from neweul_py.api import generate

        track.say("6/6 generated module")
        generate(desc, out / "generated", progress=track)
    print(f"wrote {out}: tm_air.npz order {V.shape[1]} "
          f"({int(np.count_nonzero(np.any(V[fes[0].dof_kind == 'p'] != 0, axis=0)))} pressure "
          f"directions, {samples.size} working points), {time.perf_counter() - t0:.0f} s")


def node_rows(body) -> np.ndarray:
    """Rows of ``ux, uy, uz`` of the kept (manubrium) nodes in ``V_kept``."""
    from neweul_py.elastic.bodies.static import node_rows as rows

    return rows(body.nodes, body.dof_node, body.dof_kind).ravel()


if __name__ == "__main__":
    main()
