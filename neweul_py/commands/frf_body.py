"""``neweul frf-body BODY.npz [--at NAME=VALUE] --input I --response O [--response O2 …]
--f START:STOP:N [--log] [-o frf.csv] [--plot fig.png]``: frequency response of a reduced or
parametric body alone, ``H(j2πf) = C_r (K_r + jωD_r − ω²M_r)⁻¹ B_r`` from its own FE inputs
and outputs — no FE model is read or solved; a body with loss factors (a hysteretic matrix
``G_r``) in the form ``K_r + iG_r + jω(D_r − G_r/ω_ref) − ω²M_r`` unless ``--damping
viscous``."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any

from ..atomic import atomic_write
from ..errors import DataError, NeweulError
from . import assignment
from . import common as common
from .compare_frf import add_body_frf_arguments, frequency_grid

if TYPE_CHECKING:
    import numpy as np

    from ..elastic.bodies.parametric import ParametricBody
    from ..elastic.bodies.reduced import ReducedBody


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``frf-body`` sub-command."""
    parser = subparsers.add_parser(
        "frf-body",
        help="frequency response of a reduced or parametric elastic body alone",
        description="Frequency response H(j2πf) = C (K + jωD − ω²M)⁻¹ B of a reduced body, or "
        "of a parametric body at a parameter value (--at NAME=VALUE), between its own FE "
        "inputs and outputs (no FE model is solved); magnitude and phase per output.",
    )
    parser.add_argument("body", metavar="BODY", help="reduced or parametric body file (.npz)")
    parser.add_argument("--at", type=lambda t: assignment(t, "--at"), metavar="NAME=VALUE",
                        help="parameter value of a parametric body (e.g. dp=-2000)")
    add_body_frf_arguments(parser, "Bode plot (.png/.pdf)")
    parser.set_defaults(func=run)


def load_body(path: str, at: tuple[str, float] | None) -> ReducedBody:
    """A reduced body, or a parametric body evaluated at ``at`` (refused without it)."""
    from ..elastic.io.body_files import (
        is_parametric_body_file,
        load_parametric_body,
        load_reduced_body,
    )

    if is_parametric_body_file(path):
        return body_at(load_parametric_body(path), path, at)
    if at is not None:
        raise NeweulError(f"{path}: --at applies to parametric bodies; this is a reduced body")
    return load_reduced_body(path)


def body_at(pb: ParametricBody, path: str, at: tuple[str, float] | None) -> ReducedBody:
    """The parametric body ``pb`` (read from ``path``) at ``at = (name, value)``; one error
    naming the file without ``at``, for another parameter or outside the sampled range."""
    lo, hi = pb.range
    if at is None:
        raise NeweulError(f"{path}: a parametric body of {pb.parameter!r}: give --at "
                          f"{pb.parameter}=VALUE in [{lo:g}, {hi:g}]")
    if at[0] != pb.parameter:
        raise NeweulError(f"{path}: --at names {at[0]!r}, the body's parameter is "
                          f"{pb.parameter!r}")
    try:
        return pb.at(at[1])
    except DataError as exc:
        raise DataError(exc.message, path, exc.item) from None


def _table(f: np.ndarray, H: np.ndarray, outputs: list[str], in_band: np.ndarray | None
           ) -> tuple[str, np.ndarray]:
    import numpy as np

    cols, names = [f], ["frequency_hz"]
    for j, o in enumerate(outputs):
        h = H[:, j]
        cols += [h.real, h.imag, np.abs(h), np.degrees(np.unwrap(np.angle(h)))]
        names += [f"{o}_real", f"{o}_imag", f"{o}_magnitude", f"{o}_phase_deg"]
    if in_band is not None:
        cols.append(in_band.astype(float))
        names.append("in_band")
    return ",".join(names), np.column_stack(cols)


def body_frf_figure(f: np.ndarray, H: np.ndarray, outputs: list[str], inp: str,
                    log: bool) -> Any:
    """The Bode plot of a body's FRF (Agg canvas, not saved): one magnitude axis per response
    — the FE outputs of a body may be displacements, pressures, volumes (m, Pa, m³) and the
    body file does not record which, so no two share an axis — and one phase axis [deg] for
    all; a constrained layout keeps every label inside the figure."""
    import numpy as np

    from ..analysis.plot import new_figure

    fig = new_figure(figsize=(7.5, 1.9 * (len(outputs) + 1) + 0.6), layout="constrained")
    axes = fig.subplots(len(outputs) + 1, 1, sharex=True, squeeze=False)[:, 0]
    for j, (ax, o) in enumerate(zip(axes, outputs, strict=False)):
        ax.plot(f, np.abs(H[:, j]), color=f"C{j}")
        ax.set_yscale("log")
        ax.set_ylabel(f"|{o}/{inp}|\n(SI units of the FE data)", fontsize="small")
        axes[-1].plot(f, np.degrees(np.unwrap(np.angle(H[:, j]))), color=f"C{j}", label=o)
    axes[-1].set_ylabel("phase [deg]")
    axes[-1].set_xlabel("frequency f [Hz]")
    if len(outputs) > 1:
        axes[-1].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
        if log:
            ax.set_xscale("log")
    return fig


def run(args: argparse.Namespace) -> int:
    """Evaluate the body and report (the CSV: frequency_hz and per response real, imag,
    magnitude, phase_deg, and in_band when the body records its retained band)."""
    import numpy as np

    from ..elastic.quality.measures import frf_reduced, retained_band_hz

    common.split_output(args)
    if not args.response or len(args.input) != 1:
        raise NeweulError("frf-body takes one --input and at least one --response")
    args.input = args.input[0]
    common.check_files(args.output, (".csv",), "frequency responses", args.plot)
    f = frequency_grid(args.grid, args.log)
    body = load_body(args.body, args.at)
    H = frf_reduced(body, f, args.input, args.response, args.damping)[:, :, 0]
    band = retained_band_hz(body)
    in_band = None if band is None else f <= band
    where = "" if args.at is None else f" at {args.at[0]} = {args.at[1]:g}"
    print(f"{args.body}{where}: order {body.order}, {f.size} frequencies "
          f"{f[0]:g}–{f[-1]:g} Hz, input {args.input}")
    for j, o in enumerate(args.response):
        k = int(np.argmax(np.abs(H[:, j])))
        print(f"  {o}: max |H| {np.abs(H[k, j]):.4g} at {f[k]:g} Hz")
    if in_band is not None and not in_band.all():
        print(f"  {(~in_band).sum()} frequencies lie above the retained band ({band:.6g} Hz): "
              "the reduced model is not meant to be accurate there (in_band = 0)")
    if args.output:
        header, table = _table(f, H, args.response, in_band)

        def write(fh) -> None:
            np.savetxt(fh, table, delimiter=",", header=header, comments="", fmt="%.17g")

        atomic_write(args.output, write)
        print(f"table: {args.output}")
    if args.plot:
        from ..analysis.plot import save_figure

        save_figure(body_frf_figure(f, H, args.response, args.input, args.log), args.plot)
        print(f"plot: {args.plot}")
    return 0
