"""``neweul body-info BODY.npz [--at NAME=VALUE]``: what a reduced or parametric body file
holds — order, projection, kept nodes, inputs, outputs, samples, the bytes of each part — and
the static state it is linearized about (docs/equations-middle-ear.md §5): per working point
the residual of the static coordinates, the static displacement of every node frame, the
static interface forces and the static outputs. A user attaching parts to the body's node
frames needs exactly these: where the nodes are in the deflected state, which forces the
attached parts must carry there, and how well the basis holds the state.

The projection is stated from the data, not only from what the file claims: one-sided
(Galerkin, ``W = V``) when the node rows of the left and right bases are equal, two-sided
(Petrov–Galerkin) otherwise, with the method that made the basis (modal, Krylov,
Craig–Bampton, snapshot, interpolated)."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from ..errors import NeweulError
from . import assignment

if TYPE_CHECKING:
    import numpy as np

#: Node lines shown per state: every node with an interface force, then others up to this.
SHOWN = 12
#: Parts of a body file by the prefix or name of its arrays (the first that matches).
PARTS = (("slopes", ("slope/",)), ("curvatures", ("curvature/",)),
         ("invariants", ("invariants/",)), ("static state", ("static/",)),
         ("matrices M, D, K, G", ("M", "D", "K", "G")), ("inputs and outputs B, C", ("B", "C")),
         ("node rows V_kept, W_kept", ("V_kept", "W_kept")),
         ("bases R, V, W, T, L", ("R", "V", "W", "T", "L")))


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


def _parts(path: str) -> list[str]:
    """Bytes of the body file by part (:data:`PARTS`), as stored, and the compact layout's
    counts (docs/reduced-body-format.md)."""
    import json
    import zipfile

    import numpy as np

    sizes: dict[str, int] = {}
    with zipfile.ZipFile(path) as z:
        members = {i.filename[:-4]: i.file_size for i in z.infolist()
                   if i.filename.endswith(".npy")}
        single = 0
        for member in members:
            with z.open(member + ".npy") as fh:
                read = (np.lib.format.read_array_header_1_0
                        if np.lib.format.read_magic(fh) == (1, 0)
                        else np.lib.format.read_array_header_2_0)
                single += read(fh)[2] == np.float32
        meta = json.loads(np.load(path, allow_pickle=False)["meta"].tobytes())
    for member, size in members.items():
        key = member.split("@", 1)[0]      # a varying stack's index and values: its part
        part = next((name for name, keys in PARTS
                     if any(key.startswith(k) if k.endswith("/") else key == k for k in keys)),
                    "other")
        sizes[part] = sizes.get(part, 0) + size
    layout = meta.get("layout") or {}
    total = sum(members.values())
    lines = [f"  file: {total / 1e6:.2f} MB in {len(members)} arrays (version "
             f"{meta.get('version')}"
             + (f"; not stored: {len(layout.get('zero', {}))} zero, "
                f"{len(layout.get('same', {}))} repeated; {len(layout.get('constant', []))} "
                "constant over the samples stored once"
                + (f"; {len(layout['varying'])} stored as their varying entries"
                   if layout.get("varying") else "")
                + (f"; {len(layout['scaled'])} as a factor of another"
                   if layout.get("scaled") else "")
                + (f"; {len(layout['sparse'])} as their nonzeros"
                   if layout.get("sparse") else "")
                + (f"; {single} in single precision" if single else "")
                if layout else "") + ")"]
    lines += [f"    {name}: {size / 1e6:.2f} MB" for name, size in
              sorted(sizes.items(), key=lambda kv: -kv[1]) if size]
    return lines


def _projection(body) -> str:
    """One-sided or two-sided, from the node rows of the bases, and the method."""
    import numpy as np

    one = bool(np.array_equal(body.V_kept, body.W_kept))
    kind = ("one-sided (Galerkin, W = V)" if one else
            "two-sided (Petrov-Galerkin, W != V)")
    claim = "" if one != bool(body.two_sided) else (
        " — the file claims " + ("two" if body.two_sided else "one") + "-sided")
    methods = getattr(body, "sample_methods", None) or (body.method,)
    return f"  projection: {kind}; basis: {', '.join(sorted(set(methods))) or '-'}{claim}"


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
             _projection(shape),
             f"  inputs: {', '.join(shape.input_names) or '-'}",
             f"  outputs: {', '.join(shape.output_names) or '-'}",
             *_parts(args.body)]
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
