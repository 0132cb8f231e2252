"""``neweul frf FILE --input U --response Y --f 10:10000:400 [--log] [--plot bode.png]
[-o frf.csv|.npz]``."""

from __future__ import annotations

import argparse

from . import CAPS, range_type
from . import common as common


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``frf`` sub-command."""
    parser = subparsers.add_parser(
        "frf",
        help="frequency response of outputs to inputs (Bode data and plot)",
        description="H(jω) = C(−ω² M0 + jω P + Q)⁻¹ B + D of the linearized model for all "
        "frequencies at once; with loss factors C(−ω² M0 + jω (P − G/ω_ref) + Q + iG)⁻¹ B + D "
        "(--damping viscous: the time-domain equivalent). Outputs are model outputs, "
        "coordinates, d_<coordinate> or dd_<coordinate>.",
    )
    common.add_model_arguments(parser)
    common.add_signal_arguments(parser, required=False)
    parser.add_argument("--f", required=True, type=range_type("--f", minimum=0.0),
                        metavar="START:STOP:N", help="frequencies in Hz, e.g. 10:10000:400 (or "
                        f"a comma list; at most {CAPS['--f']})")
    parser.add_argument("--log", action="store_true", help="logarithmically spaced frequencies")
    parser.add_argument("--method", choices=("solve", "hessenberg", "eig"), default="solve",
                        help="evaluation method (default: batched second-order solve)")
    parser.add_argument("--damping", choices=("loss", "viscous"), default="loss",
                        help="loss: loss factors as hysteretic damping K + iG (default); "
                        "viscous: their time-domain equivalent G/ω_ref")
    parser.add_argument("--plot", metavar="FIG", help="Bode plot (.png/.pdf/.svg; matplotlib)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Compute, write and plot the frequency response."""
    import numpy as np

    from ..analysis.frf import SUFFIXES, frequency_response
    from ..analysis.linearize import linearize
    from ..analysis.plot import signal_units

    common.split_output(args)
    common.check_files(args.output, SUFFIXES, "frequency responses", args.plot)
    f = np.asarray(args.f.values(args.log))
    module = common.load_model(args)
    lin = linearize(module, **common.linearize_kwargs(module, args))
    fr = frequency_response(lin, f, args.input, args.response, method=args.method,
                            damping=args.damping)
    if not np.all(np.isfinite(fr.magnitude)):
        from ..errors import SolverError

        raise SolverError("the frequency response is not finite (the linearized model is "
                          "singular at some frequency, or its matrices are not finite)")
    if args.output:
        print(f"frequency response: {fr.save(args.output)}")
    if args.plot:
        units = signal_units(module)
        fr.plot(args.plot, log_frequency=args.log, output_units=units, input_units=units)
        print(f"Bode plot: {args.plot}")
    if not args.output and not args.plot:
        print(f"{'frequency_hz':>14}  {'magnitude':>14}  {'phase_deg':>10}  output/input")
        for k, freq in enumerate(fr.frequency_hz):
            for i, o in enumerate(fr.outputs):
                for j, u in enumerate(fr.inputs):
                    print(f"{freq:>14.6g}  {fr.magnitude[k, i, j]:>14.6g}  "
                          f"{fr.phase_deg[k, i, j]:>10.2f}  {o}/{u}")
    return 0
