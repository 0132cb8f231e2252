#!/usr/bin/env python3
"""Write the description of an N-link pendulum chain (uniform rods, gravity along −z).

Planar (``--planar``, default): one rotation about y per joint (coordinates ``q1 … qN``, each
relative to the previous link). Spatial (``--spatial``): two rotations per joint, about x then
about the new y (coordinates ``a1, b1 … aN, bN``).

Usage::

    python examples/make_chain.py 10 --planar -o examples/chain10_planar.yaml
    python examples/make_chain.py 3 --spatial            # to stdout

All links share the parameters ``m`` (mass), ``l`` (length) and, for the spatial chain, ``r``
(rod radius, for the axial moment of inertia). The text is deterministic.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def chain_description(n: int, spatial: bool = False) -> str:
    """The YAML text of an ``n``-link chain."""
    if n < 1:
        raise ValueError("a chain needs at least one link")
    kind = "spatial" if spatial else "planar"
    name = f"chain{n}_{kind}"
    joint = ("two rotations per joint (about x, then the new y)" if spatial
             else "one rotation about y per joint")
    lines = [
        f"name: {name}",
        "description: >",
        f"  {n}-link {kind} pendulum chain of uniform rods, {joint}; joint angles relative",
        "  to the previous link. Written by examples/make_chain.py.",
        "gravity: [0, 0, -g]",
        "parameters:",
        "  m: 1.0      # kg, mass of each rod",
        "  l: 0.5      # m, length of each rod",
    ]
    if spatial:
        lines.append("  r: 0.02     # m, radius of each rod")
    lines += ["  g: 9.81     # m/s^2", "coordinates:"]
    for i in range(1, n + 1):
        if spatial:
            lines.append(f"  a{i}: {{initial: {0.4 if i == 1 else 0.0}, velocity: 0.0}}")
            lines.append(f"  b{i}: {{initial: {0.3 if i == 1 else 0.0}, velocity: "
                         f"{0.5 if i == 1 else 0.0}}}")
        else:
            lines.append(f"  q{i}: {{initial: {0.5 if i == 1 else 0.0}, velocity: 0.0}}")
    lines.append("frames:")
    for i in range(1, n + 1):
        lines.append(f"  link{i}:")
        lines.append(f"    parent: {'ISYS' if i == 1 else f'link{i - 1}'}")
        if i > 1:
            lines.append("    translation: [0, 0, -l]")
        rot = f"[[x, a{i}], [y, b{i}]]" if spatial else f"[[y, q{i}]]"
        lines.append(f"    rotation: {rot}")
    lines.append("bodies:")
    axial = "m*r**2/2" if spatial else "0"
    for i in range(1, n + 1):
        lines += [
            f"  rod{i}:",
            f"    frame: link{i}",
            "    mass: m",
            "    center_of_mass: [0, 0, -l/2]",
            f"    inertia: {{diag: [m*l**2/12, m*l**2/12, {axial}]}}",
        ]
    lines += [
        "outputs:",
        f"  tip_x: {{position: link{n}, point: [0, 0, -l], component: x}}",
    ]
    if spatial:
        lines.append(f"  tip_y: {{position: link{n}, point: [0, 0, -l], component: y}}")
    lines.append(f"  tip_z: {{position: link{n}, point: [0, 0, -l], component: z}}")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("n", type=int, help="number of links (≥ 1)")
    kind = parser.add_mutually_exclusive_group()
    kind.add_argument("--planar", action="store_true", help="one rotation per joint (default)")
    kind.add_argument("--spatial", action="store_true", help="two rotations per joint")
    parser.add_argument("-o", "--output", help="file to write (default: stdout)")
    args = parser.parse_args(argv)
    if args.n < 1:
        parser.error("n must be at least 1")
    text = chain_description(args.n, spatial=args.spatial)
    if args.output:
        Path(args.output).write_text(text, encoding="utf-8")
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
