#!/usr/bin/env python3
"""Benchmark: three reductions of the middle-ear TM + air body in the coupled EMBS.

On one FE sweep of ``neweul fem middle-ear`` (9 working points −4000:1000:4000 Pa, their
slope models at ∓20 Pa, and the FE models at the 8 midpoints ±500 … ±3500 Pa and at +600 Pa)
three parametric bodies are built from the same 9 samples:

* ``local``: the seed paper's pipeline — every sample reduced alone, two-sided modal
  (``reduce_modal(modes=30, static_correction=True)``, right and left eigenvectors), the
  local bodies brought to common coordinates and interpolated entrywise (Panzer et al.
  2010; :func:`neweul_py.elastic.parametric.local_interpolation.interpolate`, linear
  weights in Δp);
* ``two-sided``: one global Petrov–Galerkin pair ``V ≠ W`` from primal and adjoint
  frequency-response snapshots of all samples, balanced POD
  (:func:`neweul_py.elastic.parametric.two_sided_basis.balanced_snapshot_basis`);
* ``galerkin``: one global Galerkin basis ``W = V``, POD of the same snapshots per u/p block
  (:func:`neweul_py.elastic.parametric.snapshot_basis.snapshot_basis`).

The two global bodies are built as ``neweul middle-ear build`` builds them (the snapshots of
:func:`neweul_py.middle_ear.build.reduction_basis`, the samples' static states, quintic
Hermite weights in the TM's static volume displacement with the slopes and curvatures of the
slope models). Each body is attached at its manubrium nodes to the ossicular chain of the
build's description linearized at Δp (the coupled EMBS's linearization,
:func:`neweul_py.middle_ear.validation.body_coupled`) and compared with the **unreduced FE
model** of that working point coupled with the same chain
(:func:`neweul_py.middle_ear.validation.reference_frf`): relative error of the umbo, malleus
and stapes velocity per probe pressure, median and max over 100 Hz–6 kHz (log), at every
sample and midpoint; the right-half-plane poles of the coupled EMBS (viscous damping, the time
domain) at the same points; the order, the body file size and the CPU time of the reduction
(basis + projection + interpolation; the FE sweep, common to all, is reported alone).

Run (about 12 min CPU at refine 1, the FE sweep included)::

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_two_sided.py --dir DIR --refine 1

The FE sweep, the description and the reference FRFs are cached in ``DIR``.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from neweul_py.elastic import interpolate, read_fe_model, reduce_modal
from neweul_py.elastic.io.body_files import save_parametric_body
from neweul_py.elastic.parametric.snapshot_basis import ProjectionCache, basis_parametric_body
from neweul_py.middle_ear.build import BuildOptions, reduction_basis
from neweul_py.middle_ear.embs import model_path, retarget, template
from neweul_py.middle_ear.parameters import MiddleEarParameters
from neweul_py.middle_ear.sampling import static_states, volume_coordinate
from neweul_py.middle_ear.study import transfer
from neweul_py.middle_ear.sweep import pressure_sweep
from neweul_py.middle_ear.validation import (
    body_coupled_frf,
    chain_matrices,
    chain_module,
    coupled_poles,
    reference_frf,
)

SAMPLES = np.arange(-4000.0, 4001.0, 1000.0)
MIDPOINTS = np.r_[0.5 * (SAMPLES[1:] + SAMPLES[:-1]), 600.0]
STEP = 20.0
BAND = (100.0, 6000.0)


def sweep(d: Path, name: str, pressures, refine: int, curve: bool = False) -> Path:
    """The FE working points ``pressures`` in ``d/name`` (solved once)."""
    out = d / name
    if not (out / "sweep.json").is_file():
        pressure_sweep(sorted(pressures), refine=refine, out_dir=str(out),
                       static_curve=100.0 if curve else None)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", type=Path,
                    default=Path(tempfile.gettempdir()) / "neweul-bench-two-sided")
    ap.add_argument("--refine", type=int, default=1)
    ap.add_argument("--nf", type=int, default=60)
    ap.add_argument("--modes", type=int, default=30)
    ap.add_argument("--rtol", type=float, default=None,
                    help="relative cut of both global bases (default: the build's per basis)")
    args = ap.parse_args()
    d: Path = args.dir / f"r{args.refine}"
    d.mkdir(parents=True, exist_ok=True)
    t0 = time.process_time()
    fem = sweep(d, "fem", SAMPLES, args.refine, curve=True)
    mid = sweep(d, "fem_mid", MIDPOINTS, args.refine)
    slopes = sweep(d, "fem_slopes", [p + s * STEP for p in SAMPLES for s in (-1, 1)],
                   args.refine)
    t_fe = time.process_time() - t0
    info = json.loads((fem / "sweep.json").read_text())
    manubrium = [int(i) for i in info["interface_nodes"]["manubrium"]]
    umbo = int(info["interface_nodes"]["umbo"])
    k_attach = MiddleEarParameters(**info["parameters"]).k_tm_manubrium
    where = {float(p): fem for p in SAMPLES} | {float(p): mid for p in MIDPOINTS} | {
        float(p + s * STEP): slopes for p in SAMPLES for s in (-1, 1)}
    fes = [read_fe_model(model_path(fem, p)) for p in SAMPLES]
    side = tuple([read_fe_model(model_path(slopes, p + s * STEP)) for p in SAMPLES]
                 for s in (-1, 1))
    coord = volume_coordinate(where, fem / "static_curve.csv", SAMPLES)

    bodies, cpu, sizes = {}, {}, {}
    for name in ("two-sided", "galerkin"):
        t0 = time.process_time()
        opts = BuildOptions(refine=args.refine, basis=name, rtol=args.rtol, generate=False)
        V, W, energy = reduction_basis(fes, umbo, k_attach, d / f"nocache-{name}.npz", opts,
                                       lambda *a: None)
        (d / f"nocache-{name}.npz").unlink()
        pb = basis_parametric_body(
            fes, V, SAMPLES, parameter="dp", keep_nodes=manubrium, energy=energy, W=W,
            static=static_states(where, SAMPLES, manubrium), slope_models=side,
            slope_step=STEP, slope_static=tuple(static_states(where, [p + s * STEP for p in
                                                                      SAMPLES], manubrium)
                                                for s in (-1, 1)),
            interpolation="quintic-hermite", projections=ProjectionCache())
        bodies[name] = pb.with_(coordinate=coord, coordinate_name="volume_displacement_m3")
        cpu[name] = time.process_time() - t0
    t0 = time.process_time()
    local = [reduce_modal(fe, modes=args.modes, static_correction=True, store_bases=True,
                          keep_nodes=manubrium).with_(parameters={"dp": float(p)})
             for fe, p in zip(fes, SAMPLES, strict=True)]
    bodies["local"] = interpolate(local, SAMPLES, parameter="dp")
    cpu["local"] = time.process_time() - t0
    for name, pb in bodies.items():
        path = d / f"body_{name}.npz"
        save_parametric_body(pb, path)
        sizes[name] = path.stat().st_size

    desc = d / "middle_ear.yaml"
    if not desc.is_file():
        desc.write_text(retarget(template(), fem, manubrium, d / "body_galerkin.npz",
                                 d / "gen_factor", where=d), encoding="utf-8")
    chain_mod = chain_module(desc, fem, d / "gen_chain")
    f = np.geomspace(*BAND, args.nf)
    points = np.sort(np.r_[SAMPLES, MIDPOINTS])
    print(f"refine {args.refine} ({fes[0].n_dofs} DOFs): FE sweep {t_fe:.0f} s CPU "
          f"({SAMPLES.size} samples, {MIDPOINTS.size} midpoints, {2 * SAMPLES.size} slope "
          f"models); {args.nf} frequencies {BAND[0]:g}–{BAND[1]:g} Hz")
    print(f"{'dp [Pa]':>8} {'body':>10}  " + "  ".join(
        f"{k + ' med/max [%]':>22}" for k in ("umbo", "malleus", "stapes")) + "  RHP poles")
    summary = {name: {"err": [], "rhp": 0, "rhp_at": []} for name in bodies}
    for p in points:
        cache = d / f"ref_{p:+06.0f}_{args.nf}.npz"
        if cache.is_file():
            with np.load(cache) as z:
                ref = dict(z)
        else:
            ref = transfer(reference_frf(chain_mod, model_path(where[float(p)], p), p, f), f)
            np.savez(cache, **ref)
        chain, own, node = chain_matrices(chain_mod, p)
        chain_v, _, _ = chain_matrices(chain_mod, p, "viscous")
        for name, pb in bodies.items():
            b = pb.at(p)
            got = transfer(body_coupled_frf(chain, own, node, b, f), f)
            err = np.array([np.abs(got[k] - ref[k]) / np.abs(ref[k])
                            for k in ("umbo", "malleus", "stapes")])
            rhp = coupled_poles(chain_v, own, node, b)
            summary[name]["err"].append(err)
            summary[name]["rhp"] += rhp.size
            if rhp.size:
                summary[name]["rhp_at"].append(f"{p:+g}: {rhp[0]:.3g}")
            tag = " (sample)" if p in SAMPLES else ""
            cells = "  ".join(f"{100 * np.median(e):>10.4f} / {100 * e.max():<9.4f}"
                              for e in err)
            print(f"{p:>+8g} {name:>10}  {cells}  {rhp.size}{tag}")
        if p == 600.0:
            hi = f >= 4900
            print("         +600 Pa above 4.9 kHz, stapes error [%] at "
                  + ", ".join(f"{x:.0f}" for x in f[hi]) + " Hz: "
                  + "; ".join(f"{name} " + " ".join(
                      f"{100 * v:.2f}" for v in summary[name]["err"][-1][2][hi])
                      for name in bodies))
    print("\nsummary over all samples and midpoints (umbo, malleus, stapes):")
    print(f"{'body':>10} {'order':>5} {'file [MB]':>9} {'CPU [s]':>8} {'median [%]':>11} "
          f"{'max mid [%]':>11} {'max smp [%]':>11} {'RHP poles':>9}")
    is_mid = np.array([p not in SAMPLES for p in points])
    for name, pb in bodies.items():
        e = np.array(summary[name]["err"])          # (point, output, f)
        print(f"{name:>10} {pb.order:>5} {sizes[name] / 1e6:>9.2f} {cpu[name]:>8.1f} "
              f"{100 * np.median(e):>11.4f} {100 * e[is_mid].max():>11.4f} "
              f"{100 * e[~is_mid].max():>11.4f} {summary[name]['rhp']:>9}"
              + (f"  ({'; '.join(summary[name]['rhp_at'])})" if summary[name]["rhp_at"]
                 else ""))


if __name__ == "__main__":
    main()
