"""``neweul body-info BODY.npz [--at NAME=VALUE]``: what a reduced or parametric body file
holds — order, kept nodes, inputs, outputs, samples — and the static state it is linearized
about (docs/equations-middle-ear.md §5): per working point the residual of the static
coordinates, the static displacement of every node frame, the static interface forces and
the static outputs. A user attaching parts to the body's node frames needs exactly these:
where the nodes are in the deflected state, which forces the attached parts must carry
there, and how well the basis holds the state."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from ..errors import NeweulError
from . import assignment

if TYPE_CHECKING:
    import numpy as np

#: Node lines shown per state: every node with an interface force, then others up to this.
SHOWN = 12


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``body-info`` sub-command."""
    parser = subparsers.add_parser(
        "body-info",
        help="what a reduced or parametric body holds, and its static state",
        description="Order, kept nodes, inputs, outputs and samples of a reduced or parametric "
        "body file, and the static state of each working point (static coordinates' residual, "
        "node displacements, interface forces, outputs); --at NAME=VALUE shows a parametric "
        "body's state at one value (mixed by its interpolation weights).",
    )
    parser.add_argument("body", metavar="BODY", help="reduced or parametric body file (.npz)")
    parser.add_argument("--at", type=lambda t: assignment(t, "--at"), metavar="NAME=VALUE",
                        help="parameter value of a parametric body (e.g. dp=-2500)")
    parser.set_defaults(func=run)


def _state(label: str, nodes: np.ndarray, st, outputs: tuple[str, ...]) -> list[str]:
    import numpy as np

    lines = [f"{label}: residual of V q_s {float(st.residual):.2e}, |q_s| "
             f"{float(np.linalg.norm(st.q)):.4g}"]
    loaded = np.any(st.node_force != 0, axis=1)
    show = loaded | (np.cumsum(~loaded) <= max(0, SHOWN - int(loaded.sum())))
    for node, u, f in zip(nodes[show, 0].astype(int), st.node_u[show], st.node_force[show],
                          strict=True):
        lines.append(f"    node {node:>6}: u_s = [{u[0]:+.4e} {u[1]:+.4e} {u[2]:+.4e}] m, "
                     f"f_s = [{f[0]:+.4e} {f[1]:+.4e} {f[2]:+.4e}] N")
    if not show.all():
        lines.append(f"    … {int((~show).sum())} more kept nodes without interface force")
    total = st.node_force.sum(axis=0)
    lines.append(f"    sum of the interface forces [{total[0]:+.4e} {total[1]:+.4e} "
                 f"{total[2]:+.4e}] N")
    lines += [f"    output {name}: {v:+.6e}" for name, v in zip(outputs, st.outputs,
                                                                    strict=True)]
    return lines


def run(args: argparse.Namespace) -> int:
    """Print the summary (one block per working point with a static state)."""
    import numpy as np

    from ..elastic.io.body_files import (
        is_parametric_body_file,
        load_parametric_body,
        load_reduced_body,
    )
    from .frf_body import body_at

    parametric = is_parametric_body_file(args.body)
    pb = load_parametric_body(args.body) if parametric else None     # the file read once
    if pb is None and args.at is not None:
        raise NeweulError(f"{args.body}: --at applies to parametric bodies; this is a "
                          "reduced body")
    body = (load_reduced_body(args.body) if pb is None
            else body_at(pb, args.body, args.at) if args.at is not None else None)
    shape = pb if body is None else body                 # order, nodes and names of both
    lines = [f"{args.body}: {'parametric' if parametric else 'reduced'} body of order "
             f"{shape.order}, {shape.nodes.shape[0]} kept nodes "
             f"({', '.join(str(int(n)) for n in shape.nodes[:SHOWN, 0])}"
             f"{' …' if shape.nodes.shape[0] > SHOWN else ''})",
             f"  inputs: {', '.join(shape.input_names) or '-'}",
             f"  outputs: {', '.join(shape.output_names) or '-'}"]
    if pb is not None:
        lines.append(f"  {pb.n_samples} samples of {pb.parameter} in [{pb.range[0]:g}, "
                     f"{pb.range[1]:g}] ({pb.interpolation} weights"
                     + (f" in {pb.coordinate_name}, {pb.coordinate.shape[1]} knots"
                        if pb.coordinate is not None else "") + "): "
                     + ", ".join(f"{s:g}" for s in pb.samples))
    if args.at is not None:
        states = [(f"  at {args.at[0]} = {args.at[1]:g}", body.static)]
    elif pb is not None:
        states = [(f"  {pb.parameter} = {s:g}", None if pb.static is None else
                   pb.static.mixed(np.eye(pb.n_samples)[i]))
                  for i, s in enumerate(pb.samples)]
    else:
        states = [("  static state", body.static)]
    if all(st is None for _, st in states):
        lines.append("  no static state (the body is linearized about its reference "
                     "configuration)")
    for label, st in states:
        if st is not None:
            lines += _state(label, shape.nodes, st, shape.output_names)
    print("\n".join(lines))
    return 0
