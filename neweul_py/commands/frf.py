"""``neweul frf FILE --input U --output Y --f 10:10000:400 [--log] [--plot bode.png]
[-o frf.csv|.npz]``."""

from __future__ import annotations

import argparse

from ..analysis.frf import SUFFIXES, frequency_response, frequency_vector
from ..analysis.linearize import linearize
from ..analysis.plot import signal_units
from . import _analysis_common as common


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``frf`` sub-command."""
    parser = subparsers.add_parser(
        "frf",
        help="frequency response of outputs to inputs (Bode data and plot)",
        description="H(jω) = C(−ω² M0 + jω P + Q)⁻¹ B + D of the linearized model for all "
        "frequencies at once. Outputs are model outputs, coordinates, d_<coordinate> or "
        "dd_<coordinate>.",
    )
    common.add_model_arguments(parser)
    parser.add_argument("--input", action="append", metavar="U",
                        help="input name (repeatable; default: all inputs; the rates of a "
                        "kinematic excitation are folded into their input)")
    parser.add_argument("--output", action="append", metavar="Y",
                        help="output name (repeatable; default: all outputs)")
    parser.add_argument("--f", required=True, metavar="START:STOP:COUNT",
                        help="frequencies in Hz, e.g. 10:10000:400 (or a comma list)")
    parser.add_argument("--log", action="store_true", help="logarithmically spaced frequencies")
    parser.add_argument("--method", choices=("solve", "hessenberg", "eig"), default="solve",
                        help="evaluation method (default: batched second-order solve)")
    parser.add_argument("--plot", metavar="FIG", help="Bode plot (.png/.pdf/.svg; matplotlib)")
    parser.add_argument("-o", "--out", metavar="FILE",
                        help=".csv with frequency_hz, magnitude, phase_deg, or .npz (complex H)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Compute, write and plot the frequency response."""
    common.check_files(args.out, SUFFIXES, "frequency responses", args.plot)
    f = frequency_vector(args.f, args.log)
    module = common.load_model(args)
    lin = linearize(module, **common.linearize_kwargs(module, args))
    fr = frequency_response(lin, f, args.input, args.output, method=args.method)
    if args.out:
        print(f"frequency response: {fr.save(args.out)}")
    if args.plot:
        fr.plot(args.plot, log_frequency=args.log, output_units=signal_units(module))
        print(f"Bode plot: {args.plot}")
    if not args.out and not args.plot:
        print(f"{'frequency_hz':>14}  {'magnitude':>14}  {'phase_deg':>10}  output/input")
        for k, freq in enumerate(fr.frequency_hz):
            for i, o in enumerate(fr.outputs):
                for j, u in enumerate(fr.inputs):
                    print(f"{freq:>14.6g}  {fr.magnitude[k, i, j]:>14.6g}  "
                          f"{fr.phase_deg[k, i, j]:>10.2f}  {o}/{u}")
    return 0
