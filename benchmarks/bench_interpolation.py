"""Benchmark: parametric middle-ear body between working points.

The u–p FE models of ``neweul fem middle-ear --refine 1`` at 17 static pressures
(−4000:4000:17 Pa) give 9 samples (every 1000 Pa) and the 8 midpoints (±500, ±1500, ±2500,
±3500 Pa). Each sample is reduced alone (two-sided modal, ``--modes 30 --static-correction
--store-bases``); at every midpoint the frequency response umbo_uz and probe_pressure per
canal_volume_acceleration, 100 Hz–5 kHz (log), of

* ``local``: Panzer et al. (2010) matrix interpolation of the local bodies in common
  coordinates (:func:`neweul_py.elastic.parametric.local_interpolation.interpolate`, its default
  metric);
* ``global``/``global-cubic``: one global basis of all samples, every sample's full FE model
  projected onto it (:mod:`neweul_py.elastic.parametric.global_basis`), linear / cubic-spline
  weights;
* ``global-cubic-V``: the same global sample bodies, with the cubic-spline weights taken in
  the TM's static volume displacement ``V(Δp)`` (the work conjugate of the static pressure,
  ``docs/equations.md`` §4.1) instead of in ``Δp``: ``w_i(Δp) = S_i(V(Δp))``, ``S_i`` the
  cardinal not-a-knot splines through ``V(Δp_i)`` of the samples, ``V(Δp)`` from the sweep's
  static curve (static solves every 100 Pa, ``--static-curve 100``; the static solve is
  cheap, the reduction is not) — what ``neweul interpolate --coordinate
  DIR/static_curve.csv:dp_Pa:volume_displacement_m3`` writes;
* ``global-hermite``/``global-hermite-V``: the same global sample bodies with their
  slopes (``docs/equations.md`` §4.2): the FE models at every sample ``± 20 Pa`` (static
  solves and assemblies only, no reduction; ``DIR/slopes``) projected on the same basis,
  central differences, and cubic Hermite weights in ``Δp`` / in ``V`` — what ``neweul
  interpolate --slope-models … --slope-step 20`` writes;
* ``global-quintic``/``global-quintic-V``: the same, with the samples' curvatures too — the
  central second differences of the same slope models with the samples themselves (no
  more FE solves), quintic Hermite weights in ``Δp`` / in ``V`` (``docs/equations.md`` §4.2;
  ``neweul interpolate … --interpolation quintic-hermite``);
* ``nearest-``/``nearest+``: the local body of the lower / upper neighbouring sample
  (equidistant: both are "the nearest sample")

is compared with the unreduced FE model linearized at the midpoint (checked sweep,
:func:`neweul_py.elastic.quality.measures.frf_full`: relative error ≤ 1e-6 at held-out full solves).
Printed per midpoint and method: median and max over frequency of the relative error
``|H_r − H| / |H|`` of each output. Acceptance: global median ≤ 1 %, max ≤ 5 % and below both
neighbours' median and max at every midpoint.

Run: ``python benchmarks/bench_interpolation.py [--dir DIR] [--modes 30]`` (builds the
FE sweep with its static curve into ``--dir`` when it is missing; caches reductions and full
FRFs there).
"""

from __future__ import annotations

import argparse
import csv
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from neweul_py.elastic import interpolate, read_fe_model, reduce_modal
from neweul_py.elastic.io.body_files import load_reduced_body, save_reduced_body
from neweul_py.elastic.parametric.global_basis import global_parametric_body
from neweul_py.elastic.parametric.samples import coordinate_table
from neweul_py.elastic.quality.measures import frf_full, frf_reduced

INPUT = "canal_volume_acceleration"
#: Step of the slope models [Pa] (central differences; 5, 20 and 50 Pa give the same table
#: within 0.04 % median / 0.3 % max).
SLOPE_STEP = 20.0
OUTPUTS = ["umbo_uz", "probe_pressure"]


def _model(d: Path, dp: float) -> Path:
    return d / f"model_dp{int(dp):+06d}.npz"


def static_curve(d: Path) -> tuple[np.ndarray, np.ndarray]:
    """``(Δp, V)``: the TM's static volume displacement on the sweep's static curve
    (``static_curve.csv`` of ``--static-curve 100``: static solves every 100 Pa)."""
    with open(d / "static_curve.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    return (np.array([float(r["dp_Pa"]) for r in rows]),
            np.array([float(r["volume_displacement_m3"]) for r in rows]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dir", default=Path(tempfile.gettempdir()) / "neweul-bench-interp",
                    type=Path)
    ap.add_argument("--modes", type=int, default=30)
    ap.add_argument("--nf", type=int, default=100)
    ap.add_argument("--slope-step", type=float, default=SLOPE_STEP,
                    help=f"step of the slope models [Pa] (default {SLOPE_STEP:g}; another "
                    "step builds its own models in DIR/slopes<STEP>)")
    ap.add_argument("--order", type=int, default=None,
                    help="truncate the global basis to this many directions (default: all "
                    "above the numerical rank)")
    args = ap.parse_args()
    d: Path = args.dir
    samples = np.arange(-4000.0, 4001.0, 1000.0)
    mids = 0.5 * (samples[1:] + samples[:-1])
    if not (d / "static_curve.csv").exists():
        print(f"building the FE sweep in {d}", file=sys.stderr)
        subprocess.run([sys.executable, "-m", "neweul_py.cli", "fem", "middle-ear",
                        "--pressures", "-4000:4000:17", "--refine", "1", "--static-curve",
                        "100", "-o", str(d)], check=True)
    step = float(args.slope_step)
    slopes = d / ("slopes" if step == SLOPE_STEP else f"slopes{step:g}")
    if not (slopes / "sweep.json").exists():
        print(f"building the slope models in {slopes}", file=sys.stderr)
        near = ",".join(f"{p + sign * step:g}" for p in samples for sign in (-1, 1))
        subprocess.run([sys.executable, "-m", "neweul_py.cli", "fem", "middle-ear",
                        f"--pressures={near}", "--refine", "1", "-q", "-o", str(slopes)],
                       check=True)
    f = np.geomspace(100.0, 5000.0, args.nf)
    t0 = time.perf_counter()
    fes = [read_fe_model(_model(d, p)) for p in samples]
    bodies = []
    for p, fe in zip(samples, fes, strict=True):
        path = d / f"body{args.modes}_dp{int(p):+06d}.npz"
        if path.exists():
            bodies.append(load_reduced_body(path))
            continue
        b = reduce_modal(fe, modes=args.modes, static_correction=True, store_bases=True)
        b = b.with_(parameters={"dp": float(p)})
        save_reduced_body(b, path)
        bodies.append(b)
    t_red = time.perf_counter() - t0
    t0 = time.perf_counter()
    local = interpolate(bodies, samples, parameter="dp")
    t_local = time.perf_counter() - t0
    t0 = time.perf_counter()
    glob = global_parametric_body(fes, bodies, samples, parameter="dp", order=args.order)
    t_glob = time.perf_counter() - t0
    side = [[read_fe_model(_model(slopes, p + sign * step)) for p in samples]
            for sign in (-1, 1)]
    herm = global_parametric_body(fes, bodies, samples, parameter="dp", order=args.order,
                                  slope_models=(side[0], side[1]), slope_step=step)
    quint = global_parametric_body(fes, bodies, samples, parameter="dp", order=args.order,
                                   interpolation="quintic-hermite",
                                   slope_models=(side[0], side[1]), slope_step=step)
    print(f"reductions {t_red:.1f} s; local interpolation {t_local:.1f} s (order "
          f"{local.order}); global basis {t_glob:.1f} s (order {glob.order})")
    refs = {}
    for p in mids:
        path = d / f"full_frf_dp{int(p):+06d}_{args.nf}.npy"
        if path.exists():
            refs[p] = np.load(path)
            continue
        fe = read_fe_model(_model(d, p))
        t0 = time.perf_counter()
        refs[p] = frf_full(fe, f, INPUT, OUTPUTS)[:, :, 0]
        print(f"full FRF at {p:+g} Pa: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
        np.save(path, refs[p])
    sig, vol = static_curve(d)
    glob_v = glob.with_(coordinate=coordinate_table(samples, sig, vol, str(d)),
                        coordinate_name="volume_displacement_m3")
    herm_v = herm.with_(coordinate=glob_v.coordinate, coordinate_name=glob_v.coordinate_name)
    quint_v = quint.with_(coordinate=glob_v.coordinate,
                          coordinate_name=glob_v.coordinate_name)
    methods = {
        "local": lambda p: local.at(p),
        "global": lambda p: glob.at(p, "linear"),
        "global-cubic": lambda p: glob.at(p, "cubic"),
        "global-cubic-V": lambda p: glob_v.at(p),
        "global-hermite": lambda p: herm.at(p),
        "global-hermite-V": lambda p: herm_v.at(p),
        "global-quintic": lambda p: quint.at(p),
        "global-quintic-V": lambda p: quint_v.at(p),
        "nearest-": lambda p: bodies[int(np.searchsorted(samples, p)) - 1],
        "nearest+": lambda p: bodies[int(np.searchsorted(samples, p))],
    }
    print(f"relative FRF error per {INPUT}, {f[0]:g}–{f[-1]:g} Hz ({f.size} log points): "
          "median / max [%]")
    print(f"{'dp [Pa]':>8} {'method':>16} " + " ".join(f"{o:>22}" for o in OUTPUTS))
    summary = {m: [] for m in methods}
    for p in mids:
        H = refs[p]
        for name, body_at in methods.items():
            Hr = frf_reduced(body_at(p), f, INPUT, OUTPUTS)[:, :, 0]
            err = np.abs(Hr - H) / np.abs(H)
            med, mx = np.median(err, axis=0), err.max(axis=0)
            summary[name].append((med, mx))
            cells = " ".join(f"{100 * a:>10.3f} / {100 * b:<9.3f}" for a, b in
                             zip(med, mx, strict=True))
            print(f"{p:>+8g} {name:>16} {cells}")
    print("\nover all midpoints: worst median / worst max [%]; midpoints where the method "
          "beats both neighbours (median and max, every output)")
    near = np.array([[np.minimum(a, b) for a, b in zip(summary["nearest-"][i],
                                                     summary["nearest+"][i], strict=True)]
                     for i in range(mids.size)])
    for name, rows in summary.items():
        arr = np.array(rows)  # (mid, med/max, out)
        wins = int(np.sum(np.all(arr < near, axis=(1, 2))))
        print(f"{name:>16}: " + ", ".join(
            f"{o} {100 * arr[:, 0, j].max():.3f} / {100 * arr[:, 1, j].max():.3f}"
            for j, o in enumerate(OUTPUTS)) + f"; beats nearest at {wins}/{mids.size}")


if __name__ == "__main__":
    main()
