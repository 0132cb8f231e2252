"""``neweul simulate FILE --t-end T [--method M] [--step H] [--rho-inf R] [--rtol R]
[--atol A] [--n-out N] [--independent NAME ...] [-o results.csv|.npz] [--plot fig.png]
[--animate movie.gif|.mp4 [--fps F] [--speed S] [--scale auto|FACTOR] [--frames N]
[--body-shape box|ellipsoid]]``."""

from __future__ import annotations

import argparse
import functools
from typing import Any

from ..progress import QUIET_HELP, Tracker
from . import BACKENDS, CAPS, FORMS, SIMULATE_METHODS, count, number
from . import common as common
from .signals import input_assignment, input_function

#: ``--body-shape`` choices (= ``analysis.scene.SHAPES``; not imported: the CLI starts fast).
BODY_SHAPES = ("box", "ellipsoid")

#: Largest number of integrator steps a run may need (``--max-steps``, docs/limits.md).
DEFAULT_MAX_STEPS = 1_000_000


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``simulate`` sub-command."""
    parser = subparsers.add_parser(
        "simulate",
        help="generate (cached) and integrate a model; write results and a plot",
        description="Integrate a description file (its module is generated into the cache, "
        "or reused when the description is unchanged) or an already generated module (.py) "
        "with scipy.integrate.solve_ivp. Closed loops start from a consistent state that keeps "
        "the independent coordinates (default: the first ones the constraints leave free) at "
        "their given positions and velocities.",
    )
    parser.add_argument("file", metavar="FILE", help="YAML description or generated module .py")
    parser.add_argument("--t-end", type=functools.partial(number, option="--t-end",
                                                          positive=True),
                        required=True, metavar="T", help="final time [s]")
    parser.add_argument("--method", choices=SIMULATE_METHODS, default="RK45",
                        help="integrator (Radau, BDF, LSODA use the analytic Jacobian; "
                        "generalized-alpha: fixed steps --step, for stiff elastic bodies)")
    parser.add_argument("--step", type=functools.partial(number, option="--step",
                                                         positive=True),
                        metavar="H", help="step of --method generalized-alpha [s]")
    parser.add_argument("--rho-inf", type=functools.partial(number, option="--rho-inf",
                                                            minimum=0.0, maximum=1.0),
                        default=0.9, metavar="R", help="generalized-alpha: spectral radius at "
                        "infinite frequency, 0 … 1 (default 0.9)")
    parser.add_argument("--rtol", type=functools.partial(number, option="--rtol", positive=True,
                                                         maximum=1.0),
                        default=1e-6, help="relative tolerance")
    parser.add_argument("--atol", type=functools.partial(number, option="--atol", positive=True),
                        default=1e-9, help="absolute tolerance")
    parser.add_argument("--n-out", type=count("--n-out", minimum=2), default=501, metavar="N",
                        help=f"number of equally spaced output times (default 501, at most "
                        f"{CAPS['--n-out']})")
    parser.add_argument("--max-steps", type=count("--max-steps"), default=DEFAULT_MAX_STEPS,
                        metavar="N", help="refuse a run of more than N steps: the fixed "
                        "steps of generalized-alpha, or the explicit steps its fastest time "
                        f"scale needs (default {DEFAULT_MAX_STEPS:.0e}; stiff models: --method "
                        "Radau or BDF)")
    common.add_parameter_argument(parser)
    parser.add_argument("-u", "--set-input", type=input_assignment, action="append", default=[],
                        metavar="NAME=EXPR", help="drive an input by an expression of t and the "
                        "parameters, e.g. -u 'F=2*sin(3*t)' (repeatable)")
    parser.add_argument("--form", choices=FORMS, default="auto",
                        help="closed-form or recursive equations (default: auto)")
    parser.add_argument("--backend", choices=BACKENDS, default="numpy",
                        help="module of a description: NumPy or compiled C (cffi)")
    common.add_independent_argument(
        parser, "constrained models: coordinates whose initial positions and velocities are "
        "kept exactly (default: the first ones in COORDINATES order the constraints leave free)")
    common.add_output_argument(parser, "FILE", "write results as .csv (with a units line) or "
                               ".npz")
    parser.add_argument("--plot", metavar="FIG",
                        help="plot coordinates and outputs (.png/.pdf/.svg; matplotlib)")
    parser.add_argument("--animate", metavar="MOVIE",
                        help="animate the model in 3-D: frames, bodies, node clouds (.gif, or "
                        ".mp4 with ffmpeg; matplotlib)")
    parser.add_argument("--fps", type=functools.partial(number, option="--fps", positive=True,
                                                        maximum=240.0),
                        default=20.0, help="pictures per second of the animation (default 20)")
    parser.add_argument("--speed", type=functools.partial(number, option="--speed",
                                                          positive=True),
                        default=1.0, metavar="S", help="simulated seconds per second of the "
                        "animation (default 1, real time; 0.01: a 50 ms run lasts 5 s)")
    parser.add_argument("--scale", type=deformation_scale_type, default="auto",
                        metavar="auto|FACTOR", help="deformation scale of elastic bodies: auto "
                        "(default: the largest displacement drawn a tenth of the body) or a "
                        "factor (1: true size)")
    parser.add_argument("--frames", type=count("--frames"), default=150, metavar="N",
                        help="at most N pictures (default 150; longer runs play faster than "
                        "--speed)")
    parser.add_argument("--body-shape", choices=BODY_SHAPES, default="box",
                        help="rigid bodies as the box or ellipsoid of their mass and inertia")
    parser.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    parser.set_defaults(func=run)


def deformation_scale_type(text: str) -> str | float:
    """``--scale``: ``auto`` or a positive number (an argparse type)."""
    if text.strip().lower() == "auto":
        return "auto"
    return number(text, "--scale", positive=True)


def run(args: argparse.Namespace) -> int:
    """Simulate, write the requested files and print a one-line summary per file."""
    from ..analysis.results import SUFFIXES
    from ..analysis.simulate import simulate

    common.check_files(args.output, SUFFIXES, "results", args.plot)
    if args.animate:
        from ..analysis.animate import check_animation_path

        check_animation_path(args.animate)
    module = common.load_model(args)
    check_step_count(module, args)
    p = dict(args.param) or None
    u = input_function(module, args.set_input, p)
    with Tracker("simulate", unit="s", quiet=args.quiet) as track:  # a bar on a terminal
        result = simulate(module, args.t_end, method=args.method, rtol=args.rtol,
                          atol=args.atol, n_out=args.n_out, p=p, u=u,
                          independent=args.independent, progress=track, h=args.step,
                          rho_inf=args.rho_inf, max_steps=args.max_steps)
    print(f"{result.model_name}: t = {result.t[0]:g} … {result.t[-1]:g} s with {result.method}, "
          f"{result.nfev} right-hand-side evaluations")
    if args.output:
        print(f"results: {result.save(args.output)}")
    if args.plot:
        from ..analysis.plot import plot_result

        print(f"plot: {plot_result(result, args.plot)}")
    if args.animate:
        from ..analysis.animate import animate

        with Tracker("animate", unit="picture", quiet=args.quiet) as track:
            movie = animate(result, module, args.animate, fps=args.fps, frames=args.frames,
                            shape=args.body_shape, speed=args.speed, scale=args.scale, u=u,
                            progress=track)
        print(f"animation: {movie}")
    if not args.output and not args.plot and not args.animate:
        final = ", ".join(f"{n} = {v:.6g}" for n, v in zip(result.names[1:],
                                                           result.table[-1, 1:], strict=True))
        print(f"final state: {final}")
    return 0


def check_step_count(module: Any, args: argparse.Namespace) -> None:
    """Refuse an integration that would need more than ``--max-steps`` steps: the fixed steps
    ``ceil(T / H)`` of ``--method generalized-alpha --step H``, or an explicit method's.

    An explicit Runge–Kutta method is stable only for ``h |λ| ≲ 3`` (Hairer & Wanner, *Solving
    ODEs II*, §IV.2), so a run over ``T`` seconds needs at least ``T |λ_max| / 3`` steps, where
    ``λ_max`` is the eigenvalue of largest magnitude of ``∂f/∂x`` at the initial state (a spring
    of ``-p k=1e12`` makes it huge). Such a run would not end in any useful time; the error
    says so at once and names the stiff integrators.
    """
    import numpy as np

    from ..analysis.protocol import resolve_inputs, resolve_parameters
    from ..errors import NeweulError

    if args.method == "generalized-alpha" and args.step is not None:
        steps = args.t_end / args.step
        if not steps * (1 - 1e-12) <= args.max_steps:
            raise NeweulError(
                f"generalized-alpha with --step {args.step:g} takes {steps:.4g} steps for "
                f"{args.t_end:g} s, more than --max-steps {args.max_steps} (docs/limits.md): "
                "use a larger --step (or raise --max-steps)")
        return
    if args.method in ("Radau", "BDF", "LSODA", "generalized-alpha") or getattr(
            module, "CONSTRAINTS", None):
        return
    p = resolve_parameters(module, dict(args.param) or None)
    x0 = np.asarray(module.INITIAL_STATE, dtype=float)
    if x0.size == 0 or x0.size > 2000:
        return
    u0 = resolve_inputs(module, 0.0, p, None)
    with np.errstate(all="ignore"):
        try:
            if getattr(module, "BACKEND", "numpy") == "c":
                # central differences of the compiled rhs (2n calls of ~µs): the analytic
                # Jacobian would build the module's derivative library first (~1 s of cc)
                jac = _difference_jacobian(module, x0, p, u0)
            else:
                jac = np.asarray(module.rhs_jacobian(0.0, x0, p, u0), dtype=float)
            rate = float(np.max(np.abs(np.linalg.eigvals(jac)))) if np.all(
                np.isfinite(jac)) else np.inf
        except (ArithmeticError, ValueError, np.linalg.LinAlgError):
            return  # the integrator reports what is wrong
    steps = rate * args.t_end / 3.0
    if not steps <= args.max_steps:
        raise NeweulError(
            f"{args.method} would need about {steps:.2g} steps for {args.t_end:g} s (fastest "
            f"time scale 1/{rate:.3g} s at the initial state), more than --max-steps "
            f"{args.max_steps}: the model is stiff at these parameters; use --method Radau or "
            "BDF, or a shorter --t-end"
        )


def _difference_jacobian(module: Any, x0: Any, p: Any, u0: Any) -> Any:
    """``∂rhs/∂x`` at ``(0, x0)`` by central differences (step ``1e-6 (1 + |x_j|)``): enough
    for the magnitude of the fastest eigenvalue that :func:`check_step_count` needs."""
    import numpy as np

    steps = 1e-6 * (1.0 + np.abs(x0))
    cols = [(np.asarray(module.rhs(0.0, x0 + e, p, u0), dtype=float)
             - np.asarray(module.rhs(0.0, x0 - e, p, u0), dtype=float)) / (2 * e[j])
            for j, e in enumerate(np.diag(steps))]
    return np.column_stack(cols)
