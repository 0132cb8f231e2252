"""``neweul interpolate BODY1.npz BODY2.npz … --parameter NAME [--values V1,V2,…]
[--method global|local] [--models FE1,FE2,…]
[--interpolation linear|cubic|hermite|quintic-hermite]
[--basis auto|full|kept] [--row-scaling kind|none] [--pressure-weight W] [--weights W1,…]
[--coordinate CURVE.csv:SIGMA:XI] [--slope-models FE1- FE1+ … --slope-step D] [--store-bases]
-o pbody.npz``: local reduced bodies → parametric body (``docs/equations.md`` §4;
``--coordinate``: cubic weights in the coordinate ``XI`` of the curve instead of in the
parameter, §4.1; ``--slope-models``: the FE models at every sample value ∓ ``D`` give the
samples' slopes and curvatures, and the weights are quintic Hermite, §4.2 —
``--interpolation hermite``: the slopes alone, cubic Hermite weights).

``--method global`` (default): one global basis of all samples, every sample's FE model
projected onto it (:mod:`neweul_py.elastic.parametric.global_basis`); the FE models are the files
the
bodies record as their source (``--models`` to give them), checked against the bodies'
fingerprints. ``--method local``: Panzer et al. (2010) common coordinates of the local
bodies alone (no FE model needed)."""

from __future__ import annotations

import argparse
import functools
import os
import sys
import time
from typing import Any

from ..errors import NeweulError
from . import common as shared
from . import number, values_type

#: ``--interpolation`` and ``--basis`` choices and the default ``--pressure-weight``; the same as
#: :mod:`neweul_py.elastic.bodies.parametric` and
#: :mod:`~neweul_py.elastic.parametric.local_interpolation`
#: (kept here so that building the parser imports no elastic code; a test checks they agree).
INTERPOLATIONS: tuple[str, ...] = ("linear", "cubic", "hermite", "quintic-hermite")
BASES: tuple[str, ...] = ("auto", "full", "kept")
PRESSURE_WEIGHT = 1e-3


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``interpolate`` sub-command."""
    parser = subparsers.add_parser(
        "interpolate",
        help="combine reduced bodies at parameter samples into a parametric body",
        description="Parametric model order reduction by matrix interpolation of local "
        "reduced bodies (one per sample of the parameter, same FE discretization): by "
        "default one global basis of all samples onto which every sample's FE model is "
        "projected (--method global), or the local bodies brought to common coordinates "
        "(--method local, Panzer et al. 2010); writes the parametric body (.npz, see "
        "docs/reduced-body-format.md) atomically.",
    )
    parser.add_argument("bodies", nargs="+", metavar="BODY",
                        help="reduced-body files (.npz), in increasing parameter order")
    parser.add_argument("--parameter", required=True, metavar="NAME",
                        help="name of the parameter")
    parser.add_argument("--values", type=values_type("--values"), metavar="V1,V2,…",
                        help="sample values, one per body (default: the values the bodies "
                        "record in their parameters)")
    parser.add_argument("--method", choices=("global", "local"), default="global",
                        help="global = one basis for all samples, each sample's FE model "
                        "projected onto it (default; needs the FE models); local = common "
                        "coordinates of the local bodies (Panzer et al. 2010)")
    parser.add_argument("--models", nargs="+", metavar="FE",
                        help="FE model of each body (--method global; default: the file "
                        "each body records as its source)")
    parser.add_argument("--interpolation", choices=INTERPOLATIONS, default=None,
                        help="default weights between samples (default: cubic spline for "
                        "--method global — on the middle-ear sweep at worst 4.1 %% median "
                        "error between samples against 15.6 %% linear, 0.56 %% with "
                        "--coordinate — linear for --method local; with --slope-models "
                        "quintic-hermite, the samples' slopes and curvatures from the same "
                        "models, or hermite, the slopes alone)")
    parser.add_argument("--basis", choices=BASES, default="auto",
                        help="(--method local) basis rows for the common subspace: full "
                        "bases (needs --store-bases at reduction) or the kept rows (default "
                        "auto)")
    parser.add_argument("--row-scaling", choices=("kind", "none"), default=None,
                        help="(--method local) row metric of the common subspace: kind = "
                        "one factor per group of DOF kinds (translations, rotations, "
                        "pressure), balanced, "
                        "pressure down-weighted (structure first); none = plain rows "
                        "(default: kind when the bodies record the DOF kinds of their "
                        "bases, else none)")
    parser.add_argument("--pressure-weight", default=PRESSURE_WEIGHT,
                        type=functools.partial(number, option="--pressure-weight",
                                               positive=True),
                        metavar="W", help="(--method local) factor of the pressure rows on "
                        f"top of the balanced kind scaling (default {PRESSURE_WEIGHT:g}; "
                        "1 = balanced)")
    parser.add_argument("--weights", type=values_type("--weights", minimum=0.0),
                        metavar="W1,W2,…",
                        help="(--method local) SVD weights of the samples (default all 1)")
    parser.add_argument("--coordinate", metavar="CURVE.csv:SIGMA:XI", default=None,
                        help="take the cubic weights in the coordinate XI instead of in the "
                        "parameter: the columns SIGMA (the parameter) and XI of a CSV curve "
                        "that holds every sample value, e.g. the TM's static volume "
                        "displacement, DIR/static_curve.csv:dp_Pa:volume_displacement_m3 "
                        "of neweul fem middle-ear --static-curve STEP (docs/equations.md "
                        "§4.1)")
    parser.add_argument("--slope-models", nargs="+", metavar="FE",
                        help="--method global: per body, in order, its FE model at the "
                        "sample value minus and plus --slope-step (2 files per body); the "
                        "samples then carry their slopes and curvatures and the weights "
                        "are quintic Hermite (docs/equations.md §4.2; on the middle-ear "
                        "sweep with --coordinate 0.075 %% median / 2.1 %% max error between "
                        "samples, 0.44 %% / 11.3 %% with --interpolation hermite, the slopes "
                        "alone). Working-point "
                        "files record their static dp, which is checked against the sample "
                        "∓ step; other FE files are taken in the order given")
    parser.add_argument("--slope-step", default=None,
                        type=functools.partial(number, option="--slope-step", positive=True),
                        metavar="D", help="the step D of --slope-models (parameter units)")
    parser.add_argument("--store-bases", action="store_true",
                        help="also store the transformed full bases")
    shared.add_output_argument(parser, "PBODY.npz", "parametric-body file to write",
                               required=True)
    parser.set_defaults(func=run)


def _progress(msg: str) -> None:
    print(f"  {msg}", file=sys.stderr, flush=True)


def _models(args: argparse.Namespace, bodies: list) -> list:
    """The FE model of every body (``--models`` or the recorded source), checked."""
    from ..elastic import read_fe_model
    from ..elastic.quality.measures import check_source
    from ..errors import DataError

    if args.models is not None and len(args.models) != len(bodies):
        raise NeweulError(f"--models has {len(args.models)} files for {len(bodies)} bodies")
    fes = []
    for i, (path, body) in enumerate(zip(args.bodies, bodies, strict=True)):
        model = args.models[i] if args.models else _recorded_model(path, body)
        if not model:
            raise DataError("the body records no FE model file: give --models (or use "
                            "--method local)", path, "source")
        shared.refuse_overwrite(args.output, {f"FE model (recorded by {path})": model})
        _progress(f"reading {model}")
        fe = read_fe_model(model)
        check_source(fe, body, path)
        fes.append(fe)
    return fes


#: Largest ``--coordinate`` curve read (bytes; docs/limits.md).
MAX_CURVE_BYTES = 64 * 2**20


def _curve(spec: str) -> tuple[str, str, list[float], list[float]]:
    """``(file, name, σ, ξ)`` of ``--coordinate CURVE.csv:SIGMA:XI``."""
    import csv
    import io
    import math

    from ..errors import DataError
    from ..files import read_text

    parts = spec.rsplit(":", 2)
    if len(parts) != 3 or not all(parts):
        raise NeweulError(f"--coordinate must be CURVE.csv:SIGMA:XI, got {spec!r}")
    path, sig_col, xi_col = parts
    # a regular UTF-8 file (a spreadsheet's byte-order mark dropped), checked before reading
    text = read_text(path, "curve (--coordinate)", MAX_CURVE_BYTES)
    try:
        reader = csv.DictReader(io.StringIO(text, newline=""), skipinitialspace=True)
        header = [h.strip() for h in (reader.fieldnames or [])]
        reader.fieldnames = header
        rows = list(reader)
    except csv.Error as exc:
        raise DataError(f"cannot read the curve ({exc})", path, "coordinate") from None
    if not rows:
        raise DataError("the curve has no rows", path, "coordinate")
    twice = sorted({h for h in header if header.count(h) > 1})
    if twice:
        raise DataError(f"the header names {', '.join(twice)} more than once", path, twice[0])
    for col in (sig_col, xi_col):
        if col not in header:
            raise DataError(f"no column {col!r} (columns: {', '.join(header)})", path, col)
    values: dict[str, list[float]] = {sig_col: [], xi_col: []}
    for line, row in enumerate(rows, start=2):
        if None in row:
            raise DataError(f"line {line}: more fields than the header's {len(header)}",
                            path, "coordinate")
        for col in values:
            try:
                v = float(row[col])
            except (TypeError, ValueError):
                v = math.nan
            if not math.isfinite(v):
                raise DataError(f"line {line}: {col} = {row[col]!r} is not a finite number",
                                path, col)
            values[col].append(v)
    return path, xi_col, values[sig_col], values[xi_col]


def _check_slope_options(args: argparse.Namespace) -> None:
    """``--slope-models`` and ``--slope-step``: together, 2 per body, global method, Hermite
    weights."""
    if (args.slope_models is None) != (args.slope_step is None):
        raise NeweulError("--slope-models and --slope-step go together")
    if args.slope_models is None:
        if args.interpolation in ("hermite", "quintic-hermite"):
            raise NeweulError(f"--interpolation {args.interpolation} needs the samples' "
                              "slopes (--slope-models, --slope-step"
                              + (", which --method global takes)" if args.method == "local"
                                 else ")"))
        return
    if args.method != "global":
        raise NeweulError("--slope-models applies to --method global only")
    if len(args.slope_models) != 2 * len(args.bodies):
        raise NeweulError(f"--slope-models has {len(args.slope_models)} files for "
                          f"{len(args.bodies)} bodies (2 per body: the FE models at the "
                          "sample value minus and plus --slope-step)")
    if args.interpolation not in (None, "hermite", "quintic-hermite"):
        raise NeweulError(f"--slope-models gives Hermite weights (hermite or "
                          f"quintic-hermite), not --interpolation {args.interpolation}")


def _slope_models(files: list[str], bodies: list, values, step: float
                  ) -> tuple[tuple, tuple | None]:
    """The FE models of ``--slope-models`` as (minus, plus), and, when the bodies carry
    static states, the static states of those working-point files (minus, plus) — a file
    without one is a :class:`DataError` naming it. A working-point file records its static
    pressure difference (``static_dp``): one that is not its sample value ∓ ``step`` (files
    swapped, or of another step) is a :class:`DataError` naming it."""
    from ..elastic import read_fe_model
    from ..elastic.io.working_point import read_static, static_loads
    from ..errors import DataError

    fes, states = [], []
    need = bodies[0].static is not None
    for i, path in enumerate(files):
        _progress(f"reading {path}")
        fes.append(read_fe_model(path))
        want = float(values[i // 2]) + (step if i % 2 else -step)
        st = read_static(path) if str(path).endswith(".npz") else None
        if st is not None and "dp" in st and abs(float(st["dp"]) - want) > 1e-9 * max(
                1.0, abs(want)):
            raise DataError(f"this slope model is the working point at {float(st['dp']):g}, "
                            f"--slope-models wants {want:g} here (sample {values[i // 2]:g} "
                            f"{'+' if i % 2 else '−'} {step:g}: per body the model below, "
                            "then the one above)", path, "static_dp")
        if need:
            kept = {int(n) for n in bodies[i // 2].nodes[:, 0]}
            states.append(static_loads(path, kept))
            if states[-1] is None:
                raise DataError("the bodies carry static states, this slope model has none "
                                "(a working point of neweul fem middle-ear has one)", path,
                                "static")
    return (fes[0::2], fes[1::2]), ((states[0::2], states[1::2]) if need else None)


def _recorded_model(path: str, body: Any) -> str | None:
    """The FE model file the body at ``path`` records (``source.file``): as written, or, when
    that is relative and not there, relative to the body file's folder (a body of a
    parametric one names its models so; docs/reduced-body-format.md)."""
    model = body.source.get("file")
    if model and not os.path.isabs(model) and not os.path.exists(model):
        near = os.path.join(os.path.dirname(path), model)
        if os.path.exists(near):
            return near
    return model


def _sample_statics(args: argparse.Namespace, bodies: list) -> list:
    """The samples' own FE static states (their working-point files: ``--models`` or the
    files the bodies record), for the curvatures of their static states — projected like
    the slope models' (:func:`~neweul_py.elastic.parametric.global_basis.global_slopes`); a file
    without one is a :class:`DataError` naming it."""
    from ..elastic.io.working_point import static_loads
    from ..errors import DataError

    out = []
    for i, body in enumerate(bodies):
        path = args.models[i] if args.models else _recorded_model(args.bodies[i], body)
        kept = {int(n) for n in body.nodes[:, 0]}
        out.append(static_loads(path, kept))
        if out[-1] is None:
            raise DataError("the curvatures of the static states need each sample's FE "
                            "static state; this FE model has none (a working point of "
                            "neweul fem middle-ear has one)", path, "static")
    return out


def run(args: argparse.Namespace) -> int:
    """Read the bodies, interpolate, write; print a summary."""
    from ..elastic.io.body_files import load_reduced_body, save_parametric_body
    from ..elastic.parametric.global_basis import global_parametric_body
    from ..elastic.parametric.local_interpolation import interpolate
    from ..elastic.parametric.samples import coordinate_table, sample_values

    shared.check_files(args.output, (".npz",), "parametric bodies")
    shared.refuse_overwrite(args.output, {"BODY": args.bodies, "--models": args.models,
                                          "--slope-models": args.slope_models})
    if args.values is not None and len(args.values) != len(args.bodies):
        raise NeweulError(f"--values has {len(args.values)} entries for {len(args.bodies)} "
                          "bodies")
    if args.coordinate is not None and args.interpolation == "linear":
        raise NeweulError("--coordinate needs cubic weights (--interpolation cubic)")
    curve = _curve(args.coordinate) if args.coordinate is not None else None
    _check_slope_options(args)
    if args.method == "global":
        local_only = [o for o, given in (("--basis", args.basis != "auto"),
                                         ("--row-scaling", args.row_scaling is not None),
                                         ("--pressure-weight",
                                          args.pressure_weight != PRESSURE_WEIGHT),
                                         ("--weights", args.weights is not None)) if given]
        if local_only:
            verb = "applies" if len(local_only) == 1 else "apply"
            raise NeweulError(f"{' and '.join(local_only)} {verb} to --method local only (the "
                              "global basis has no common-coordinate SVD)")
    elif args.models is not None:
        raise NeweulError("--models applies to --method global only")
    t0 = time.perf_counter()
    bodies = []
    for path in args.bodies:
        _progress(f"reading {path}")
        bodies.append(load_reduced_body(path))
    values = sample_values(bodies, args.values, args.parameter)
    table = None
    if curve is not None:                 # checked before any projection
        path, _name, sig, xi = curve
        table = coordinate_table(values, sig, xi, path)
    if args.method == "global":
        slopes, statics = (_slope_models(args.slope_models, bodies, values, args.slope_step)
                           if args.slope_models else (None, None))
        fes = _models(args, bodies)
        quintic = args.interpolation in (None, "quintic-hermite")
        pb = global_parametric_body(fes, bodies, args.values, parameter=args.parameter,
                                    interpolation=args.interpolation,
                                    store_bases=args.store_bases, labels=args.bodies,
                                    slope_models=slopes, slope_step=args.slope_step,
                                    slope_statics=statics,
                                    sample_statics=_sample_statics(args, bodies)
                                    if quintic and statics is not None else None,
                                    progress=_progress)
    else:
        pb = interpolate(bodies, args.values, parameter=args.parameter, basis=args.basis,
                         row_scaling=args.row_scaling or "auto",
                         pressure_weight=args.pressure_weight, weights=args.weights,
                         interpolation=args.interpolation or "linear",
                         store_bases=args.store_bases, progress=_progress,
                         labels=args.bodies)
    if table is not None:
        pb = pb.with_(interpolation=pb.interpolation if pb.slopes is not None else "cubic",
                      coordinate=table, coordinate_name=curve[1])
    save_parametric_body(pb, args.output)
    lo, hi = pb.range
    sv = pb.singular_values
    if args.method == "global":     # the POD energies of the kept directions, nothing cut
        how = (f"global basis, smallest kept POD energy {(sv[-1] / sv[0]) ** 2:.2g} of the "
               "largest" if sv.size and sv[0] > 0 else "global basis")
    else:                           # σ_r+1/σ_1: what the common subspace leaves out
        how = (f"local, {pb.basis} bases, row scaling {pb.row_scaling}, "
               + (f"σ_r+1/σ_1 = {sv[pb.order] / sv[0]:.3g}" if sv.size > pb.order
                  else "every direction kept"))
    print(f"{args.output}: {pb.n_samples} samples of {pb.parameter} in [{lo:g}, {hi:g}], "
          f"order {pb.order} ({'two' if pb.two_sided else 'one'}-sided, {how}"
          + (f", weights in {pb.coordinate_name}" if pb.coordinate is not None else "")
          + (", with the samples' slopes and curvatures (quintic Hermite)"
             if pb.curvatures is not None else ", with the samples' slopes (Hermite)"
             if pb.slopes is not None else "")
          + f"), {time.perf_counter() - t0:.2f} s")
    return 0
