"""``neweul middle-ear build|study|tympanogram|absorbance``: the flagship application.

``build --dir DIR [--refine L]`` makes the middle-ear EMBS from nothing (FE sweep → reduction
→ interpolation → description ``DIR/middle_ear.yaml`` → generated module), with progress;
``study --dir DIR`` writes the studies' tables and plots of a build
(docs/equations-middle-ear.md); ``tympanogram`` and ``absorbance`` give what a clinic
measures of it (docs/middle-ear-clinical.md). All are thin layers over
:mod:`neweul_py.middle_ear`.
"""

from __future__ import annotations

import argparse
import functools
from pathlib import Path

from ..progress import QUIET_HELP, Tracker
from . import CAPS, comma_floats, count, number, range_type
from . import common as common


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``middle-ear`` with its sub-commands ``build`` and ``study``."""
    parser = subparsers.add_parser(
        "middle-ear", help="the middle-ear EMBS: build it from nothing, study it",
        description="The flagship application: the nonlinear middle ear (ossicles on the "
        "parametric TM + ear-canal + tympanic-cavity body scheduled by the static pressure "
        "difference dp).")
    sub = parser.add_subparsers(dest="middle_ear_command",
                                metavar="{build,study,tympanogram,absorbance}", required=True)
    b = sub.add_parser(
        "build", help="FE sweep → reduction → parametric body → description → module",
        description="Build the middle-ear EMBS into DIR (atomically: an interrupted build leaves "
        "the previous complete DIR or none; FE working points of a previous build of the same "
        "refinement and parameters are reused).")
    b.add_argument("--dir", type=Path, required=True, help="the build directory")
    b.add_argument("--refine", type=count("--refine", minimum=0), default=1,
                   help="mesh refinement of the FE model (default 1)")
    b.add_argument("--pressures", type=range_type("--pressures"),
                   default=None, metavar="START:STOP:N",
                   help="working points of the FE sweep [Pa] (default -4000:4000:9)")
    b.add_argument("--tol", type=functools.partial(number, option="--tol", minimum=0.0),
                   default=3e-4,
                   help="refinement tolerance of the interpolation (default 3e-4; 0: none)")
    b.add_argument("--coordinate", choices=("volume", "dp"), default="volume",
                   help="the variable of the interpolation weights (default: the TM's static "
                   "volume displacement)")
    b.add_argument("--slope-step",
                   type=functools.partial(number, option="--slope-step", minimum=0.0),
                   default=None, metavar="PA",
                   help="slopes and curvatures from FE models at every working point ∓ PA "
                   "(default 20, with a pars flaccida an eighth of the minimum interval; 0: "
                   "cubic weights through the values alone)")
    b.add_argument("--min-interval",
                   type=functools.partial(number, option="--min-interval", minimum=0.0),
                   default=None, metavar="PA",
                   help="the refinement splits no interval narrower than twice this (default "
                   "125, with a pars flaccida an eighth of its stiffening pressure)")
    b.add_argument("--interpolation", choices=("quintic-hermite", "hermite"),
                   default="quintic-hermite", help="Hermite weights (default quintic)")
    b.add_argument("--basis", choices=("galerkin", "two-sided"), default="galerkin",
                   help="galerkin (W = V, the default) or two-sided (Petrov-Galerkin, "
                   "W != V: balanced POD of primal and adjoint snapshots)")
    b.add_argument("--rtol", type=functools.partial(number, option="--rtol", minimum=0.0),
                   default=None, help="relative cut of the basis (default 1e-10 two-sided, "
                   "1e-8 galerkin)")
    b.add_argument("--order", type=count("--order", cap=100_000),
                   default=None, help="cap on the number of basis directions")
    b.add_argument("--parameters", type=Path, default=None, metavar="FILE",
                   help="the middle ear's data that differ from the defaults: a YAML mapping "
                   "of MiddleEarParameters names to numbers (e.g. "
                   "examples/middle_ear/identified.yaml)")
    b.add_argument("--no-generate", action="store_true", help="skip the generated module")
    b.add_argument("--keep-intermediate", action="store_true",
                   help="keep the slope FE models (DIR/fem_slopes*) and the basis cache, "
                   "which a rebuild with other reduction settings reuses")
    b.add_argument("--jobs", type=count("--jobs", cap=256), default=1,
                   help="processes solving the snapshot systems of the working points "
                   "(default 1; the same body for any number)")
    b.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    b.set_defaults(func=_build)
    s = sub.add_parser("study", help="static and dynamic studies of a build vs Δp",
                       description="Tables (results.md, frf.csv) and plots of a build: the "
                       "static state vs dp, the transfer functions at the sampled pressures, "
                       "the low-frequency change against Gyo & Goode 1987.")
    s.add_argument("--dir", type=Path, required=True, help="a build of neweul middle-ear build")
    s.add_argument("--out", type=Path, default=None, help="output directory (default DIR/study)")
    s.add_argument("--nf", type=count("--nf", minimum=2, cap=CAPS["--f"]),
                   default=80, help="log-spaced frequencies 100 Hz–8 kHz (default 80)")
    s.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    s.set_defaults(func=_study)
    t = sub.add_parser(
        "tympanogram", help="admittance vs ear-canal static pressure: Ytm, TPP, TW, Vea",
        description="The admittance at the probe tip (the canal entrance) and at the TM against "
        "the ear-canal static pressure, swept from +200 to -400 daPa as a tympanometer does "
        "(dp = 10 P Pa, the cavity at ambient), with the peak compensated static admittance "
        "Ytm (compensated at +200 daPa), the peak pressure TPP, the width TW and the "
        "equivalent ear-canal volume Vea (ANSI S3.39, ASHA 1990).")
    t.add_argument("--dir", type=Path, required=True, help="a build of neweul middle-ear build")
    t.add_argument("--f", type=functools.partial(comma_floats, option="--f"), default=[226.0],
                   metavar="HZ[,HZ...]", help="probe frequencies (default 226; e.g. 226,678,1000)")
    t.add_argument("--pressures", type=range_type("--pressures", increasing=False),
                   default=None, metavar="START:STOP:N",
                   help="ear-canal pressures in daPa, in sweep order (default 200:-400:121); "
                   "+200 must be one of them")
    t.add_argument("--vector", action="store_true",
                   help="compensate the complex admittance (|Y - Y(+200)|) instead of its "
                   "magnitude")
    t.add_argument("-o", "--output", metavar="CSV", help="write the tympanogram (.csv)")
    t.add_argument("--plot", metavar="FIG", help="plot (.png/.pdf/.svg; matplotlib)")
    t.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    t.set_defaults(func=_tympanogram)
    a = sub.add_parser(
        "absorbance", help="absorbance, reflectance and admittance at the probe tip vs frequency",
        description="The impedance at the probe tip (the canal entrance), its reflectance R = "
        "(Z - Z0)/(Z + Z0) with the canal's characteristic impedance Z0 = rho c/A (A: the "
        "entrance's cross-section), the absorbance 1 - |R|^2 and the TM's admittance, at one "
        "static pressure difference dp.")
    a.add_argument("--dir", type=Path, required=True, help="a build of neweul middle-ear build")
    a.add_argument("--dp", type=functools.partial(number, option="--dp"), required=True,
                   metavar="PA", help="static pressure difference p_canal - p_cavity [Pa]")
    a.add_argument("--f", type=range_type("--f", minimum=0.0), default=None,
                   metavar="START:STOP:N", help="frequencies in Hz, log-spaced (or a comma "
                   "list; default 100:8000:120)")
    a.add_argument("-o", "--output", metavar="CSV", help="write the spectra (.csv)")
    a.add_argument("--plot", metavar="FIG", help="plot (.png/.pdf/.svg; matplotlib)")
    a.set_defaults(func=_absorbance)


def _build(args: argparse.Namespace) -> int:
    from ..middle_ear.build import BuildOptions, build
    from ..middle_ear.parameters import read_parameters

    options = BuildOptions(
        parameters=read_parameters(args.parameters) if args.parameters else {},
        refine=args.refine, tol=args.tol, coordinate=args.coordinate,
        slope_step=args.slope_step, min_interval=args.min_interval,
        interpolation=args.interpolation, order=args.order,
        basis=args.basis, rtol=args.rtol, jobs=args.jobs,
        generate=not args.no_generate, keep_intermediate=args.keep_intermediate,
        **({"pressures": tuple(args.pressures.values())} if args.pressures else {}))
    with Tracker("middle-ear build", quiet=args.quiet) as track:
        record = build(args.dir, options, progress=track)
    print(f"wrote {args.dir}: body of order {record['order']} at {len(record['samples_Pa'])} "
          f"working points, {record['description']}"
          + (f", {record['module']}" if record["module"] else "")
          + f" ({record['seconds']:.0f} s)")
    return 0


def _study(args: argparse.Namespace) -> int:
    from ..middle_ear.study import study

    out = args.out or args.dir / "study"
    with Tracker("middle-ear study", quiet=args.quiet) as track:
        files = study(args.dir, out, nf=args.nf, progress=track)
    print(f"wrote {', '.join(str(f) for f in files)}")
    return 0


def _tympanogram(args: argparse.Namespace) -> int:
    import numpy as np

    from ..errors import NeweulError
    from ..middle_ear.clinical import (
        DAPA,
        MAX_PROBE_TONES,
        SWEEP_DAPA,
        build_model,
        check_frequencies,
        eardrum_volume,
        tympanogram,
    )
    from ..middle_ear.tympanometry import COMPENSATION_DAPA

    common.check_files(args.output, (".csv",), "tympanograms", args.plot)
    f = check_frequencies(args.f, most=MAX_PROBE_TONES)
    p = np.asarray(args.pressures.values() if args.pressures else SWEEP_DAPA, dtype=float)
    if not np.any(p == COMPENSATION_DAPA):
        raise NeweulError(f"--pressures: the sweep must include {COMPENSATION_DAPA:+g} daPa "
                          "(the compensation and Vea pressure)")
    mod, params = build_model(args.dir, *(DAPA * p))
    eardrum = eardrum_volume(args.dir, mod)
    with Tracker("middle-ear tympanogram", quiet=args.quiet) as track:
        tg = tympanogram(mod, params, f, p, progress=track, eardrum=eardrum)
    for m in tg.measures(vector=args.vector):
        print(m.summary())
    if args.output:
        print(f"tympanogram: {tg.to_csv(args.output)}")
    if args.plot:
        print(f"plot: {tg.plot(args.plot, vector=args.vector)}")
    return 0


def _absorbance(args: argparse.Namespace) -> int:
    import numpy as np

    from ..middle_ear.clinical import (
        build_model,
        check_frequencies,
        eardrum_volume,
        immittance,
    )

    common.check_files(args.output, (".csv",), "absorbance spectra", args.plot)
    f = check_frequencies(args.f.values(log=True) if args.f else np.geomspace(100.0, 8000.0,
                                                                                120))
    mod, params = build_model(args.dir, args.dp)
    im = immittance(mod, params, args.dp, f, eardrum=eardrum_volume(args.dir, mod))
    a = im.absorbance
    bands = [(lo, hi) for lo, hi in ((250, 500), (500, 1000), (1000, 2000), (2000, 4000),
                                     (4000, 8000)) if np.any((f >= lo) & (f < hi))]
    means = (", ".join(f"{lo / 1e3:g}-{hi / 1e3:g} kHz {a[(f >= lo) & (f < hi)].mean():.2f}"
                       for lo, hi in bands) if bands
             else f"{a.mean():.2f} over {f.min():g}-{f.max():g} Hz")
    print(f"dp = {args.dp:+g} Pa, Z0 = rho c/A = {im.z0:.4g} Pa s/m^3; mean absorbance "
          + means)
    if args.output:
        print(f"spectra: {im.to_csv(args.output)}")
    if args.plot:
        print(f"plot: {im.plot(args.plot)}")
    return 0
