"""``neweul compare-frf MODEL BODY --input I --output O --f FMIN:FMAX:N [--log]
[--plot fig.png] [-o cmp.csv]``."""

from __future__ import annotations

import argparse

import numpy as np

from ..elastic import ReducedBody, read_fe_model
from ..elastic.quality import FRF_METHODS, FRFComparison, check_source, compare_frf
from ..errors import NeweulError
from ..progress import QUIET_HELP, Tracker


def frf_grid(text: str) -> tuple[float, float, int]:
    """Argument type ``FMIN:FMAX:N`` of a frequency grid [Hz]."""
    parts = text.split(":")
    try:
        if len(parts) != 3:
            raise ValueError
        lo, hi, n = float(parts[0]), float(parts[1]), int(parts[2])
        if not (0 <= lo <= hi and n >= 1):
            raise ValueError
        return lo, hi, n
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected FMIN:FMAX:N with 0 ≤ FMIN ≤ FMAX, N ≥ 1, got {text!r}") from None


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
    parser.add_argument("--input", required=True, metavar="I", help="input name")
    parser.add_argument("--output", required=True, metavar="O", help="output name")
    parser.add_argument("--f", dest="grid", type=frf_grid, default=(10.0, 20000.0, 200),
                        metavar="FMIN:FMAX:N", help="frequency grid [Hz] (default 10:20000:200)")
    parser.add_argument("--log", action="store_true", help="logarithmic frequency spacing")
    parser.add_argument("--plot", metavar="FIG", help="magnitude and error plot (.png/.pdf)")
    parser.add_argument("-o", "--out", metavar="CSV",
                        help="write frequency_hz,full_magnitude,reduced_magnitude,"
                        "relative_error,in_band")
    parser.add_argument("--full-method", choices=FRF_METHODS, default="auto",
                        help="full FE model: sweep = adaptive interpolation checked by full "
                        "solves (fast), direct = one sparse LU per frequency (default auto: "
                        "sweep for more than 5 frequencies)")
    parser.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    parser.set_defaults(func=run)


def frequency_grid(lo: float, hi: float, n: int, log: bool) -> np.ndarray:
    """Linear or logarithmic grid (a log grid needs FMIN > 0)."""
    if log:
        if lo <= 0:
            raise NeweulError("--log needs FMIN > 0")
        return np.geomspace(lo, hi, n)
    return np.linspace(lo, hi, n)


def plot(cmp: FRFComparison, path: str) -> None:
    """Magnitudes (full, reduced) and relative error over frequency, saved to ``path``."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise NeweulError("plotting needs matplotlib: pip install 'neweul-py[plot]'") from None
    fig = Figure(figsize=(7, 6))
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    f = cmp.frequencies_hz
    ax1.semilogy(f, np.abs(cmp.full), label="full FE model")
    ax1.semilogy(f, np.abs(cmp.reduced), "--", label="reduced body")
    ax1.set_ylabel(f"|H| ({cmp.output} / {cmp.input})")
    ax1.legend()
    ax2.semilogy(f, np.maximum(cmp.relative_error, 1e-17))
    ax2.set_ylabel("relative error")
    ax2.set_xlabel("frequency [Hz]")
    fig.tight_layout()
    fig.savefig(path)


def summary(cmp: FRFComparison, what: str) -> list[str]:
    """The printed result: the error inside the retained band, the frequencies above it."""
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
        lines.append(f"full FRF by the checked sweep: relative error ≤ "
                     f"{cmp.full_checked_error:.1e} at the held-out full solves "
                     "(--full-method direct: one LU per frequency)")
    return lines


def run(args: argparse.Namespace) -> int:
    """Compare and report."""
    if args.plot:  # before any computation: matplotlib installed, a format it writes
        from ..analysis.plot import check_plot_path

        check_plot_path(args.plot)
    f = frequency_grid(*args.grid, args.log)
    fe = read_fe_model(args.model)
    body = ReducedBody.load(args.body)
    check_source(fe, body, args.body)  # a body reduced from another model: refuse
    with Tracker("full FRF", unit="freq", quiet=args.quiet) as track:  # a bar on a terminal
        track.say(f"full FRF of {fe.name} ({fe.n_dofs} DOFs) at {f.size} frequencies")
        cmp = compare_frf(fe, body, f, args.input, args.output, progress=track, check=False,
                          method=args.full_method)
    for line in summary(cmp, f"order {body.order} vs {fe.n_dofs} DOFs"):
        print(line)
    if args.out:
        cmp.to_csv(args.out)
        print(f"table: {args.out}")
    if args.plot:
        plot(cmp, args.plot)
        print(f"plot: {args.plot}")
    return 0
