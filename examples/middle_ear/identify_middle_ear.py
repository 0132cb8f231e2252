"""The middle ear identified: its uncertain parameters fitted to a stated calibration set.

Run from the repository root after ``neweul middle-ear build --dir DATA --refine 0`` (the build
gives the chain's description and the mesh's manubrium nodes)::

    python examples/middle_ear/identify_middle_ear.py --build DATA [--refine 0]
        [--fit all|tympanogram|gyo-goode|none] [--params NAME,...] [--evaluate NAME=VALUE ...]
        [--max-nfev N] [--tolerance TOL] [--mesh-offsets FINE.json] [--out FIT.json]
        [--figure FIT.png]

The forward model, the calibration set and the held-out measurements are
:mod:`neweul_py.middle_ear.calibration`; the fit is
:func:`neweul_py.analysis.identify_function` (bounded least squares in ``ln θ``, standard errors
from the Jacobian at the optimum, the residuals in units of the data's standard deviations).
By default the pars flaccida, the chain and the TM's static modulus are fitted; a parameter
whose default lies outside its bounds (no pars flaccida: ``pf_compliance`` = 0) starts at the
geometric mean of its bounds unless ``--evaluate`` gives it.
``--fit tympanogram`` and ``--fit gyo-goode`` fit one data set each (with Murakami's signs),
to show what each asks of the model; ``--fit none`` evaluates ``--evaluate`` values.
``--mesh-offsets FINE.json`` (the ``--out`` of ``--fit none`` with the same values on a finer
``--refine``) adds the finer mesh's values minus this mesh's at the start to every evaluation
(:func:`~neweul_py.middle_ear.calibration.mesh_offsets`), so that the fit on this mesh aims at
what the finer one gives. docs/middle-ear-clinical.md §5 has the method and the result.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

from neweul_py.analysis import Bound, identify_function
from neweul_py.atomic import atomic_write
from neweul_py.middle_ear.calibration import (
    CALIBRATION,
    FIT_BOUNDS,
    CalibrationChain,
    calibration_residuals,
    evaluate,
    held_out,
    mesh_offsets,
    residual_labels,
)
from neweul_py.middle_ear.parameters import MiddleEarParameters
from neweul_py.middle_ear.plots import calibration_figure

SETS = {"all": (*CALIBRATION, "murakami"),
        "tympanogram": ("tw", "ytm", "f_res", "murakami"),
        "gyo-goode": ("umbo+1kPa", "umbo+2kPa", "umbo+3kPa", "murakami")}
DEFAULT_PARAMS = ("pf_compliance", "pf_stiffening_pressure", "pf_surface_density", "k_chain",
                  "chain_limit_medial", "chain_limit_lateral", "tm_E_static")


def summary(m: dict) -> str:
    lo = m["loss"]
    return (f"TW {m['tw']:.0f} daPa, Ytm {m['ytm_mmho']:.3f} mmho, TPP {m['tpp']:+.0f} daPa, "
            f"f_res {m['f_res']:.0f} Hz; umbo/stapes dB "
            + "; ".join(f"{dp / 1e3:+.0f} kPa {lo['umbo'][dp]:+.1f}/{lo['stapes'][dp]:+.1f}"
                        for dp in sorted(lo["umbo"]))
            + f"; stapes peak {m['stapes_peak_mm_s_Pa']:.3f} mm/s/Pa at "
              f"{m['stapes_peak_hz']:.0f} Hz")


def start_of(name: str, base: MiddleEarParameters, given: set[str]) -> float:
    """The start of a fitted parameter: its value in ``base``, or — when it was not given
    and its default lies outside the bounds (``pf_compliance`` = 0: no pars flaccida) — the
    geometric mean of its bounds."""
    lo, hi, _why = FIT_BOUNDS[name]
    value = getattr(base, name)
    if name in given or lo <= value <= hi:
        return value
    start = float(np.sqrt(lo * hi))
    print(f"start: {name} = {start:.4g} (the default {value:g} is outside its bounds)")
    return start


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", type=Path, required=True, help="a middle-ear build (its chain)")
    ap.add_argument("--refine", type=int, default=0)
    ap.add_argument("--fit", choices=(*SETS, "none"), default="all")
    ap.add_argument("--params", default=",".join(DEFAULT_PARAMS),
                    help="the parameters to fit (comma list of FIT_BOUNDS names)")
    ap.add_argument("--evaluate", nargs="*", default=[], metavar="NAME=VALUE",
                    help="start (or, with --fit none, evaluate) at these values")
    ap.add_argument("--max-nfev", type=int, default=30)
    ap.add_argument("--tolerance", type=float, default=1e-3,
                    help="ftol/xtol/gtol of the least squares")
    ap.add_argument("--mesh-offsets", type=Path, default=None, metavar="FINE.json",
                    help="the --out of --fit none with the same values on a finer mesh: its "
                    "values minus this mesh's are added to every evaluation")
    ap.add_argument("--out", type=Path, default=None, help="the fit and measures (JSON)")
    ap.add_argument("--figure", type=Path, default=None, help="the figure (PNG)")
    args = ap.parse_args(argv)
    base = MiddleEarParameters(**{k: float(v) for k, v in (a.split("=") for a in args.evaluate)})
    chain = CalibrationChain(args.build, args.build / "identify_chain")
    start = evaluate(base, chain, args.refine)
    if start is None:
        ap.error("the start's static states leave the model's validity (--evaluate)")
    print("start:", summary(start))
    out: dict = {"refine": args.refine, "start_parameters": dataclasses.asdict(base),
                 "start": start}
    offsets = None
    if args.mesh_offsets:
        fine = json.loads(args.mesh_offsets.read_text())
        if fine.get("parameters") != dataclasses.asdict(base) or fine.get("refine", -1) <= \
                args.refine:
            ap.error(f"--mesh-offsets {args.mesh_offsets}: not an evaluation of these values "
                     "on a finer mesh (--fit none --out with the same --evaluate)")
        offsets = mesh_offsets(start, fine["end"])
        out["mesh_offsets"] = {"refine": fine["refine"], "offsets": offsets}
        print(f"mesh offsets (refine {fine['refine']} − {args.refine}):",
              ", ".join(f"{k} {v:+.3g}" for k, v in offsets.items()))
    fitted, end = base, start
    if args.fit != "none":
        keys = SETS[args.fit]
        given = {a.split("=")[0] for a in args.evaluate}
        bounds = [Bound(n, FIT_BOUNDS[n][0], FIT_BOUNDS[n][1], start_of(n, base, given))
                  for n in args.params.split(",")]

        def residuals(values):
            r = calibration_residuals(evaluate(dataclasses.replace(base, **values), chain,
                                               args.refine), keys, offsets)
            print("  " + ", ".join(f"{n}={v:.4g}" for n, v in values.items())
                  + f": cost {0.5 * float(r @ r):.3f}", flush=True)
            return r

        fit = identify_function(residuals, bounds, labels=residual_labels(keys),
                                max_nfev=args.max_nfev, tolerance=args.tolerance,
                                model_name="middle ear",
                                data_name=f"calibration set {args.fit}")
        print(fit)
        fitted = dataclasses.replace(base, **fit.end_point)
        end = evaluate(fitted, chain, args.refine)
        _, sv, vt = np.linalg.svd(np.array(fit.curve["jacobian"]), full_matrices=False)
        out["fit"] = fit.to_dict() | {"labels": fit.curve["labels"],
                                      "residuals": fit.curve["residuals"],
                                      "singular_values": sv.tolist(),
                                      "directions": vt.tolist()}
        print("determined combinations of ln p (singular value: direction):")
        for s, v in zip(sv, vt, strict=True):
            print(f"  {s:8.3f}: " + " ".join(f"{c:+.2f}·{n}" for c, n in
                                                zip(v, fit.scale, strict=True) if abs(c) > 0.1))
        print(json.dumps({k: out["fit"][k] for k in ("parameters", "standard_errors",
                                                     "undetermined", "at_bounds", "cost",
                                                     "labels", "residuals")}, indent=1))
    print("end:", summary(end))
    out |= {"parameters": dataclasses.asdict(fitted), "end": end, "held_out": held_out(end)}
    print("held out:", json.dumps(out["held_out"], indent=1))
    if args.out:
        atomic_write(args.out, json.dumps(out, indent=1, default=float) + "\n")
    if args.figure:
        shipped = start if not args.evaluate else evaluate(MiddleEarParameters(), chain,
                                                            args.refine)
        calibration_figure(shipped, end, args.refine, args.figure)
    return 0


if __name__ == "__main__":
    sys.exit(main())
