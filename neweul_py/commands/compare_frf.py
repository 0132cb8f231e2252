"""``neweul compare-frf MODEL BODY --input I --response O --f FMIN:FMAX:N [--log]
[--plot fig.png] [-o cmp.csv]``."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any

from ..errors import NeweulError
from ..progress import QUIET_HELP, Tracker
from . import Range, range_type
from . import common as common

#: ``--full-method`` choices; the same as :data:`neweul_py.elastic.quality.measures.FRF_METHODS`
#: (kept
#: here so that building the parser imports no elastic code; a test checks they agree).
FRF_METHODS: tuple[str, ...] = ("auto", "sweep", "direct")

if TYPE_CHECKING:
    import numpy as np

    from ..elastic.quality.measures import FRFComparison


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``compare-frf`` sub-command."""
    parser = subparsers.add_parser(
        "compare-frf",
        help="frequency response of an FE model vs. its reduced body",
        description="Compute H(j2πf) = C (K + jωD − ω²M)⁻¹ B of the full FE model (sparse "
        "direct solves) and of the reduced body for one input/output pair; print the maximum "
        "relative error; optionally write a CSV and a plot.",
    )
    parser.add_argument("model", metavar="MODEL", help="FE model: manifest .json or .npz")
    parser.add_argument("body", metavar="BODY", help="reduced-body file (.npz)")
    add_body_frf_arguments(parser, "magnitude and error plot (.png/.pdf)")
    parser.add_argument("--full-method", choices=FRF_METHODS, default="auto",
                        help="full FE model: sweep = adaptive interpolation checked by full "
                        "solves (fast), direct = one sparse LU per frequency (default auto: "
                        "sweep for more than 5 frequencies)")
    parser.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    parser.set_defaults(func=run)


def add_body_frf_arguments(parser: argparse.ArgumentParser, plot_help: str) -> None:
    """``--input``, ``--response``, ``--f``, ``--log``, ``--plot`` of the FE/body frequency
    responses (compare-frf, frf-body)."""
    common.add_signal_arguments(parser, required=True)
    parser.add_argument("--f", dest="grid", type=range_type("--f", minimum=0.0),
                        default=Range(10.0, 20000.0, 200, None, "--f"), metavar="START:STOP:N",
                        help="frequencies [Hz]: START:STOP:N or a comma list (default "
                        "10:20000:200)")
    parser.add_argument("--log", action="store_true", help="logarithmic frequency spacing")
    parser.add_argument("--plot", metavar="FIG", help=plot_help)
    parser.add_argument("--damping", choices=("loss", "viscous"), default="loss",
                        help="loss: the loss factors as K + iG where the data hold G "
                        "(default); viscous: the time-domain equivalent D")


def frequency_grid(grid: Range, log: bool) -> np.ndarray:
    """Linear or logarithmic grid (a log grid needs a positive start)."""
    import numpy as np  # here: building the parser of every command needs no NumPy

    return np.asarray(grid.values(log))


_DOF_UNITS = {"ux": ("m", "N"), "uy": ("m", "N"), "uz": ("m", "N"), "rx": ("rad", "N·m"),
              "ry": ("rad", "N·m"), "rz": ("rad", "N·m"), "p": ("Pa", "")}


def frf_unit(fe: Any, output: str, input: str) -> str:
    """Unit of ``|H|`` from the DOF kinds the output reads and the input loads (SI units of the
    FE data: m, rad, Pa; N, N·m); empty where the kinds are mixed or unknown."""
    def kind_unit(rows: Any, index: int) -> str:
        kinds = {str(fe.dof_kind[d]) for d, _ in rows}
        units = {_DOF_UNITS.get(k, ("", ""))[index] for k in kinds}
        return units.pop() if len(units) == 1 else ""

    out, inp = kind_unit(fe.outputs[output], 0), kind_unit(fe.inputs[input], 1)
    if not out:
        return ""
    return f"{out}/{inp}" if inp else out


def plot(cmp: FRFComparison, path: str, *, log_frequency: bool = False, unit: str = "") -> None:
    """Magnitudes (full, reduced) and relative error over frequency, saved to ``path``."""
    from ..analysis.plot import plot_frf_comparison

    plot_frf_comparison(cmp.frequencies_hz, cmp.full, cmp.reduced, cmp.relative_error, path,
                        output=cmp.output, input=cmp.input, unit=unit,
                        log_frequency=log_frequency)


def summary(cmp: FRFComparison, what: str) -> list[str]:
    """The printed result: the error inside the retained band, the frequencies above it."""
    import numpy as np

    err, f, inside = cmp.relative_error, cmp.frequencies_hz, cmp.in_band
    name = f"{cmp.output} / {cmp.input}"
    lines = []
    if inside.any():
        i = int(np.flatnonzero(inside)[np.argmax(err[inside])])
        where = "" if inside.all() else f" inside the retained band (≤ {cmp.band_hz:.6g} Hz)"
        lines.append(f"{name}: max relative error {err[i]:.3e} at {f[i]:g} Hz{where} ({what})")
    if not inside.all():
        j = int(np.flatnonzero(~inside)[np.argmax(err[~inside])])
        lines.append(f"{(~inside).sum()} of {f.size} frequencies lie above the body's retained "
                     f"band ({cmp.band_hz:.6g} Hz), where the reduced model is not meant to be "
                     f"accurate: max relative error there {err[j]:.3e} at {f[j]:g} Hz "
                     "(in_band = 0 in the table)")
    if cmp.full_checked_error is not None:
        lines.append(f"full FRF by the checked sweep: relative error against direct solves "
                     f"≤ {cmp.full_checked_error:.1e} at the held-out frequencies "
                     "(--full-method direct: one LU per frequency)")
    return lines


def run(args: argparse.Namespace) -> int:
    """Compare and report."""
    from ..elastic import read_fe_model
    from ..elastic.io.body_files import load_reduced_body
    from ..elastic.quality.measures import check_source, compare_frf

    common.split_output(args)
    if not args.response or len(args.response) != 1 or len(args.input) != 1:
        raise NeweulError("compare-frf takes one --input and one --response")
    args.response, args.input = args.response[0], args.input[0]
    # before any computation: the suffix, matplotlib installed, a format it writes
    common.check_files(args.output, (".csv",), "comparisons", args.plot)
    f = frequency_grid(args.grid, args.log)
    fe = read_fe_model(args.model)
    body = load_reduced_body(args.body)
    check_source(fe, body, args.body)  # a body reduced from another model: refuse
    with Tracker("full FRF", unit="freq", quiet=args.quiet) as track:  # a bar on a terminal
        track.say(f"full FRF of {fe.name} ({fe.n_dofs} DOFs) at {f.size} frequencies")
        cmp = compare_frf(fe, body, f, args.input, args.response, progress=track,
                          check=False, method=args.full_method, damping=args.damping)
    for line in summary(cmp, f"order {body.order} vs {fe.n_dofs} DOFs"):
        print(line)
    if args.output:
        cmp.to_csv(args.output)
        print(f"table: {args.output}")
    if args.plot:
        plot(cmp, args.plot, log_frequency=args.log,
             unit=frf_unit(fe, args.response, args.input))
        print(f"plot: {args.plot}")
    return 0
