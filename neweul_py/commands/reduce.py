"""``neweul reduce MODEL --method modal|krylov [--two-sided|--one-sided] --modes N |
--band FMIN:FMAX [--static-correction] [--points F,…] [--invariants] -o body.npz``;
``--method craig-bampton --interface NODESET --modes N``, ``--interface-frame ID=NODESET``,
``--stiffening``."""

from __future__ import annotations

import argparse
import functools
import math
import sys
import time

from ..errors import NeweulError
from . import CAPS, count, interval, number, range_type
from . import common as shared

#: Highest frequency of ``--band`` [Hz]: ω² = (2π f)² stays far from overflow.
MAX_BAND_HZ = 1e12


def _ints(text: str) -> list[int]:
    try:
        return [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated node ids, got {text!r}"
                                         ) from None


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``reduce`` sub-command."""
    parser = subparsers.add_parser(
        "reduce",
        help="reduce an FE model (modal or Krylov, two-sided) to a reduced-body file",
        description="Reduce an FE model (JSON manifest or .npz) by two-sided (Petrov–Galerkin) "
        "or one-sided modal truncation or second-order Krylov moment matching, and write the "
        "reduced body (.npz, see docs/reduced-body-format.md) atomically.",
    )
    parser.add_argument("model", metavar="MODEL", help="FE model: manifest .json or .npz")
    parser.add_argument("--method", choices=("modal", "krylov", "craig-bampton"),
                        default="modal")
    side = parser.add_mutually_exclusive_group()
    side.add_argument("--two-sided", dest="two_sided", action="store_true", default=True,
                      help="Petrov–Galerkin projection with left eigen/Krylov vectors (default)")
    side.add_argument("--one-sided", dest="two_sided", action="store_false",
                      help="Galerkin projection W = V")
    sel = parser.add_mutually_exclusive_group()
    sel.add_argument("--modes", type=count("--modes"), metavar="N",
                     help="number of modes (modal)")
    sel.add_argument("--band", type=interval("--band", minimum=0.0, maximum=MAX_BAND_HZ),
                     metavar="FMIN:FMAX",
                     help="keep the modes in this band [Hz] (modal)")
    parser.add_argument("--static-correction", action="store_true",
                        help="add static (attachment) vectors of the inputs/outputs")
    parser.add_argument("--shift", type=functools.partial(number, option="--shift"),
                        metavar="SIGMA",
                        help="eigensolver shift in λ = ω² units (modal; default automatic)")
    parser.add_argument("--points", type=range_type("--points", minimum=0.0,
                                                    increasing=False), metavar="F1,F2,…",
                        help="Krylov expansion frequencies [Hz] (s0 = 2πj·f)")
    parser.add_argument("--order", type=count("--order"), metavar="Q",
                        help="Krylov moments per point and input (default 4, at most "
                        f"{CAPS['--order']})")
    parser.add_argument("--keep-nodes", type=_ints, metavar="ID,…",
                        help="node ids whose basis rows are stored (default: input/output "
                        "nodes)")
    parser.add_argument("--store-bases", action="store_true",
                        help="also store the full bases V and W")
    parser.add_argument("--skip-rigid", action="store_true",
                        help="leave out the zero-frequency (λ = 0) modes: the rigid-body "
                        "modes of a free body, whose floating frame carries that motion, but "
                        "also the constant-pressure modes of closed air volumes (their "
                        "compliance is then missing); static correction vectors are "
                        "deflated of them. A supported body needs no skip (modal)")
    parser.add_argument("--fixed-frame", action="store_true",
                        help="the body's reference frame is fixed (e.g. ISYS): no check that "
                        "the elastic coordinates leave out rigid motion (--invariants)")
    parser.add_argument("--invariants", action="store_true",
                        help="attach the floating-frame invariants (node frames: the kept "
                        "nodes), so that the file can be an elastic body in a description")
    _register_interface_options(parser)
    shared.add_output_argument(parser, "BODY.npz", "reduced-body file to write",
                               required=True)
    parser.set_defaults(func=run)


def _frame_spec(text: str) -> tuple[int, str]:
    name, sep, nodes = text.partition("=")
    try:
        if not sep or not nodes.strip():
            raise ValueError
        return int(name), nodes
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected ID=NODESET (a new integer node id), got "
                                         f"{text!r}") from None


def _register_interface_options(parser: argparse.ArgumentParser) -> None:
    """Options of Craig–Bampton reduction, averaged interface frames and stiffening."""
    parser.add_argument("--interface", metavar="NODESET",
                        help="interface nodes of --method craig-bampton: ids, ranges A:B and "
                        "node-set names of the FE file, comma-separated (e.g. root or 1:12); "
                        "with --skip-rigid the constraint modes leave out the interface's "
                        "rigid motions (floating frame)")
    parser.add_argument("--clamped-interface", action="store_true",
                        help="craig-bampton: fixed-interface modes only, no constraint modes "
                        "(the interface clamped to the floating frame)")
    parser.add_argument("--interface-frame", action="append", type=_frame_spec, default=[],
                        metavar="ID=NODESET",
                        help="add an averaged (RBE3-like) node frame with the new node id ID "
                        "following the mean motion of NODESET (repeatable; implies "
                        "--invariants)")
    parser.add_argument("--stiffening", action="store_true",
                        help="attach the geometric stiffness K_G,c stored in the FE file "
                        "(KG.<case> group) to the invariants (implies --invariants)")


def _check_interface_options(args: argparse.Namespace) -> None:
    """Craig–Bampton needs --modes and --interface; --interface needs Craig–Bampton."""
    if args.method != "craig-bampton":
        wrong = (["--interface"] if args.interface is not None else []) + (
            ["--clamped-interface"] if args.clamped_interface else [])
        if wrong:
            raise NeweulError(f"{' and '.join(wrong)} {_verb(wrong)} to --method "
                              "craig-bampton only")
        return
    if args.interface is None or args.modes is None:
        raise NeweulError("--method craig-bampton needs --interface NODESET and --modes N")
    wrong = [o for o in ("--band", "--points", "--order", "--shift")
             if getattr(args, o[2:]) is not None] + (["--static-correction"]
                                                     if args.static_correction else [])
    if wrong:
        raise NeweulError(f"{' and '.join(wrong)} {_verb(wrong)} to --method modal or krylov, "
                          "not --method craig-bampton (which takes --interface and --modes)")


def _reduce_craig_bampton(args: argparse.Namespace, fe, common: dict):
    from ..elastic.io.fe_files import read_node_sets
    from ..elastic.reductors.craig_bampton import reduce_craig_bampton
    from ..elastic.reductors.interface import parse_node_set

    nodes = parse_node_set(args.interface, fe, read_node_sets(args.model), "interface")
    common = {k: v for k, v in common.items() if k != "static_correction"}
    return reduce_craig_bampton(fe, nodes, args.modes, skip_rigid=args.skip_rigid,
                                constraint_modes=not args.clamped_interface, **common)


def _interface_invariants(args: argparse.Namespace, body, fe):
    """Invariants with stiffening (``--stiffening``) and averaged frames (``--interface-frame``)."""
    from ..elastic.io.fe_files import read_node_sets
    from ..elastic.reductors.interface import add_interface_frames, parse_node_set
    from ..elastic.reductors.invariants import attach_invariants
    from ..elastic.reductors.stiffening import attach_stiffening, load_responses, load_stiffening

    if args.stiffening:
        body = attach_stiffening(body, fe, load_stiffening(args.model, fe), args.model,
                                 responses=load_responses(args.model, fe))
    else:
        body = attach_invariants(body, fe)
    if args.interface_frame:
        named = read_node_sets(args.model)
        frames = {fid: parse_node_set(spec, fe, named, f"interface_frames.{fid}")
                  for fid, spec in args.interface_frame}
        body = add_interface_frames(body, fe, frames)
    return body


def _progress(msg: str) -> None:
    print(f"  {msg}", file=sys.stderr, flush=True)


def _verb(options: list[str]) -> str:
    return "applies" if len(options) == 1 else "apply"


def _check_options(args: argparse.Namespace) -> None:
    """Refuse options that the chosen method would silently ignore."""
    def given(*options: str) -> list[str]:
        return [o for o in options if getattr(args, o[2:].replace("-", "_")) is not None]

    _check_interface_options(args)
    if args.method == "craig-bampton":
        return
    if args.method == "modal":
        if args.modes is None and args.band is None:
            raise NeweulError("--method modal needs --modes N or --band FMIN:FMAX")
        wrong = given("--points", "--order")
        if wrong:
            raise NeweulError(f"{' and '.join(wrong)} {_verb(wrong)} to --method krylov only, "
                              "not --method modal (which takes --modes or --band)")
    else:
        wrong = given("--modes", "--band", "--shift") + (["--skip-rigid"] if args.skip_rigid
                                                         else [])
        if wrong:
            raise NeweulError(f"{' and '.join(wrong)} {_verb(wrong)} to --method modal only; "
                              "--method krylov takes --points and --order")
        if not args.points:
            raise NeweulError("--method krylov needs --points F1,F2,…")


def check_rigid_motion(fe, body, output: str, skip_rigid: bool, fixed_frame: bool) -> str:
    """Refuse a floating-frame body whose elastic coordinates repeat the reference frame's
    rigid motion (the body mass matrix of equations.md §2 would be singular); returns a
    note for the summary. Only the structural rigid fields count
    (:mod:`neweul_py.elastic.quality.rigid_motion`): λ = 0 air modes (constant pressure in a closed
    cavity) are no rigid motion, a supported FE model (the TM clamped at the annulus) has
    none, and a body on a fixed frame (``--fixed-frame``) needs no check."""
    from ..elastic.quality.rigid_motion import free_rigid_fields, repeated_rigid_fields

    if fixed_frame:
        return "fixed frame: no rigid-motion check"
    free = free_rigid_fields(fe)
    if not free.shape[1]:
        return "supported FE model (no rigid-body motion): no rigid-motion check needed"
    count = repeated_rigid_fields(fe, body.V)
    if count:
        advice = ("the λ = 0 modes were not recognized as rigid motion: choose --shift "
                  "closer to 0 or fewer modes" if skip_rigid else "reduce with --skip-rigid")
        raise NeweulError(
            f"{output}: the elastic coordinates repeat the rigid motion of the floating frame "
            f"({count} structural rigid fields lie in the reduced basis; the reference frame "
            f"already carries them, so the body mass matrix is singular); {advice}, or give "
            "--fixed-frame for a body whose frame does not move")
    return f"{free.shape[1]} free rigid motion(s) of the FE model, none in the basis"


def _with_static(body, fe, path: str):
    """The body with the static state of its working point (docs/equations-middle-ear.md
    §5): static coordinates of ``static_x``, node displacements, the static interface forces
    at the kept nodes among ``static_manubrium_node_id`` and the outputs ``C x_s``; ``q_s``
    is the projection of ``x_s`` on ``span V`` in the energy metric of the model
    (:func:`~neweul_py.elastic.parametric.global_basis.energy_metric`: displacements and pressures
    in
    one unit-consistent norm)."""
    from ..elastic.io.working_point import static_loads
    from ..elastic.parametric.global_basis import energy_metric
    from ..elastic.reductors.static_state import static_deflection

    loads = static_loads(path, {int(n) for n in body.nodes[:, 0]})
    every = static_loads(path)["node_force"]
    state = static_deflection(body, output_rows=fe.C(), metric=energy_metric([fe]), **loads)
    forces = loads["node_force"]
    _progress(f"static state of the working point: residual of V q_s {float(state.residual):.2e}"
              + (f"; interface forces at {len(forces)} of {len(every)} nodes (the others are not "
                 "kept)" if len(forces) < len(every) else ""))
    return body.with_(static=state)


def run(args: argparse.Namespace) -> int:
    """Read, reduce, write; print a summary (order, frequencies, stability)."""
    from ..elastic import read_fe_model, reduce_krylov, reduce_modal, stability
    from ..elastic.io.body_files import save_reduced_body
    from ..elastic.io.working_point import static_loads
    from ..elastic.quality.measures import right_half_plane_poles
    from ..elastic.reductors.eigen import frequencies_hz

    if args.points is not None:
        args.points = args.points.values()
    shared.check_files(args.output, (".npz",), "reduced bodies")
    shared.refuse_overwrite(args.output, {"MODEL": args.model})
    _check_options(args)
    if args.stiffening or args.interface_frame:
        args.invariants = True
    t0 = time.perf_counter()
    _progress(f"reading {args.model}")
    fe = read_fe_model(args.model)
    _progress(f"{fe.name}: {fe.n_dofs} DOFs, kind {fe.kind}")
    static = static_loads(args.model)
    common = dict(two_sided=args.two_sided, static_correction=args.static_correction,
                  keep_nodes=args.keep_nodes,
                  store_bases=args.store_bases or args.invariants or static is not None,
                  progress=_progress)
    if args.method == "craig-bampton":
        body = _reduce_craig_bampton(args, fe, common)
    elif args.method == "modal":
        body = reduce_modal(fe, modes=args.modes, band=args.band, shift=args.shift,
                            skip_rigid=args.skip_rigid, **common)
    else:
        points = [2j * math.pi * f for f in args.points]
        order = 4 if args.order is None else args.order
        wanted = order * len(points) * max(1, len(fe.inputs))
        if wanted > fe.n_dofs:
            raise NeweulError(f"--order {order} at {len(points)} point(s) and "
                              f"{max(1, len(fe.inputs))} input(s) asks for {wanted} Krylov "
                              f"vectors, more than the {fe.n_dofs} DOFs of {fe.name}")
        body = reduce_krylov(fe, points=points, order=order, **common)
    if static is not None:
        body = _with_static(body, fe, args.model)
    if args.invariants:
        _progress("computing the floating-frame invariants")
        body = _interface_invariants(args, body, fe)
        note = check_rigid_motion(fe, body, args.output, args.skip_rigid, args.fixed_frame)
        _progress(note)
    if not args.store_bases:
        body = body.with_(V=None, W=None, full_dof_kind=None)
    save_reduced_body(body, args.output)
    st = stability(body)
    side = "two-sided" if args.two_sided else "one-sided"
    print(f"{args.output}: {args.method} ({side}), order {body.order} from {fe.n_dofs} DOFs, "
          f"{'stable' if st.stable else 'UNSTABLE'} (max Re s = {st.max_real_part:.3g}), "
          f"{time.perf_counter() - t0:.2f} s")
    rhp = right_half_plane_poles(body.M, body.D, body.K)
    if rhp.size:
        shown = ", ".join(f"{z:.4g}" for z in rhp[:4]) + (" …" if rhp.size > 4 else "")
        print(f"{rhp.size} right-half-plane pole(s) s [1/s] of the reduced body: {shown}")
    if body.eigenvalues is not None and body.eigenvalues.size:
        f = frequencies_hz(body.eigenvalues)
        print(f"retained frequencies [Hz]: {f.min():.6g} … {f.max():.6g}")
    return 0
