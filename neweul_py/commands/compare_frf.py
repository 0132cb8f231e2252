"""``neweul compare-frf MODEL BODY --input I --output O --f FMIN:FMAX:N [--log]
[--plot fig.png] [-o cmp.csv]``."""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np

from ..elastic import ReducedBody, read_fe_model
from ..elastic.quality import FRFComparison, check_source, compare_frf
from ..errors import NeweulError


def _grid(text: str) -> tuple[float, float, int]:
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
    parser.add_argument("--f", dest="grid", type=_grid, default=(10.0, 20000.0, 200),
                        metavar="FMIN:FMAX:N", help="frequency grid [Hz] (default 10:20000:200)")
    parser.add_argument("--log", action="store_true", help="logarithmic frequency spacing")
    parser.add_argument("--plot", metavar="FIG", help="magnitude and error plot (.png/.pdf)")
    parser.add_argument("-o", "--out", metavar="CSV",
                        help="write frequency_hz,full_magnitude,reduced_magnitude,"
                        "relative_error")
    parser.set_defaults(func=run)


def _progress(msg: str) -> None:
    print(f"  {msg}", file=sys.stderr, flush=True)


def frequency_grid(lo: float, hi: float, n: int, log: bool) -> np.ndarray:
    """Linear or logarithmic grid (a log grid needs FMIN > 0)."""
    if log:
        if lo <= 0:
            raise NeweulError("--log needs FMIN > 0")
        return np.geomspace(lo, hi, n)
    return np.linspace(lo, hi, n)


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


def run(args: argparse.Namespace) -> int:
    """Compare and report."""
    if args.plot:  # before any computation: matplotlib installed, a format it writes
        from ..analysis.plot import check_plot_path

        check_plot_path(args.plot)
    f = frequency_grid(*args.grid, args.log)
    fe = read_fe_model(args.model)
    body = ReducedBody.load(args.body)
    check_source(fe, body, args.body)  # a body reduced from another model: refuse
    _progress(f"full FRF of {fe.name} ({fe.n_dofs} DOFs) at {f.size} frequencies")
    cmp = compare_frf(fe, body, f, args.input, args.output, progress=_progress, check=False)
    err = cmp.relative_error
    i = int(np.argmax(err))
    print(f"{args.output} / {args.input}: max relative error {err[i]:.3e} at {f[i]:g} Hz "
          f"(order {body.order} vs {fe.n_dofs} DOFs)")
    if args.out:
        cmp.to_csv(args.out)
        print(f"table: {args.out}")
    if args.plot:
        plot(cmp, args.plot, log_frequency=args.log, unit=frf_unit(fe, args.output, args.input))
        print(f"plot: {args.plot}")
    return 0
