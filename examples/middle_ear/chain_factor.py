"""The Δp-dependent stiffening of the 3-D ossicular chain of ``middle_ear.yaml``.

Run from the repository root after ``build_embs.py`` (README.md, "The 3-D chain")::

    python examples/middle_ear/chain_factor.py --dir /work/data/me_r1 [--write]

The FE sweep solves the static TM under Δp against the chain characteristic
``F(s) = −sign(s) k₀ s± ln(1 − |s|/s±)`` at the malleus (README, "Values and sources"); its
tangent ``k_t(Δp)`` is the sweep's ``chain_tangent_z_N_per_m`` (``fem/static.csv``). The 3-D
chain of the description must have the same static stiffness at the umbo along the TM axis
(TM removed, force at the malleus's umbo point, every other chain coordinate free), so that the
linear chain about the static state is the tangent of the chain that carried the static load.
The elements that stiffen are the ones the static load stretches or compresses: the malleus
ligaments (anterior mallear ligament bushing, translation and rotation) and the
incudomalleolar joint, both by one factor ``φ(Δp)`` (the tangent of a progressive tissue
characteristic scales all its stiffnesses). The posterior incudal ligament and the annular
ligament stay at their small-deflection values: the joints glide, so the incus and stapes do
not follow the static malleus displacement (Hüttenbrink 1988; docs/middle-ear-measurements.md
§3); stiffening them instead makes the stapes lose *more* than the umbo, against Murakami et
al. 1997 (README, "Which elements stiffen").

``φ`` at the 9 working points (brentq on the chain-only module's static stiffness) becomes a
piecewise-linear expression in ``dp``; ``--write`` puts it into every ``piecewise(dp < …)`` of
``middle_ear.yaml`` (stiffnesses and dampings of the stiffening elements).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import scipy.optimize as spo
import yaml

from neweul_py.analysis import load_generated
from neweul_py.analysis.linearize import linearize
from neweul_py.api import generate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from validate_embs import DESCRIPTION, chain_description, chain_node_positions, parameters_at

#: Name of the calibration parameter that stands for φ in the chain-only module.
PHI = "phi_calibration"
#: Distance umbo – ossicular axis [m] (``parameters.r_axis`` of middle_ear.yaml).
R_AXIS = 0.0044


def tm_node_stiffness(x_nodes: Sequence[float], r_axis: float, k_total: float) -> float:
    """Per-node TM–manubrium stiffness [N/m] whose rotation stiffness about the ossicular axis
    equals the 1-D attachment ``k_total`` at the umbo: ``k Σ (r − x_i)² = k_total r²``.

    LVATB1's TM–manubrium spring (36 933 N/m) couples the TM to the malleus in the umbo
    coordinate of the chain's rotation about the axis; nodes nearer the axis move less."""
    d = r_axis - np.asarray(x_nodes, dtype=float)
    return float(k_total * r_axis**2 / np.sum(d * d))


def find_piecewise(text: str) -> list[tuple[int, int]]:
    """Spans ``(start, end)`` of every ``piecewise(dp < …)`` call (balanced parentheses)."""
    spans, i = [], 0
    while (i := text.find("piecewise(dp < ", i)) >= 0:
        depth, end = 0, len(text)
        for j in range(i + len("piecewise"), len(text)):
            depth += {"(": 1, ")": -1}.get(text[j], 0)
            if depth == 0:
                end = j + 1
                break
        spans.append((i, end))
        i = end
    return spans


def with_factor(text: str, expr: str) -> str:
    """``text`` with every ``piecewise(dp < …)`` replaced by ``expr``."""
    out, last = [], 0
    for a, b in find_piecewise(text):
        out += [text[last:a], expr]
        last = b
    return "".join([*out, text[last:]])


def factor_expression(dp: Sequence[float], phi: Sequence[float]) -> str:
    """Piecewise-linear interpolation of ``phi`` over the sorted samples ``dp`` (the last
    segment continues beyond the samples; the schedule refuses Δp outside the sweep)."""
    dp, phi = np.asarray(dp, float), np.asarray(phi, float)
    parts = []
    for k in range(dp.size - 1):
        slope = (phi[k + 1] - phi[k]) / (dp[k + 1] - dp[k])
        seg = (f"{phi[k]:.6f} {'+' if slope >= 0 else '-'} {abs(slope):.9g}"
               f"*(dp {'-' if dp[k] >= 0 else '+'} {abs(dp[k]):g})")
        parts.append(seg if k == dp.size - 2 else f"dp < {dp[k + 1]:g}, {seg}")
    return "piecewise(" + ", ".join(parts) + ")"


def sweep_tangents(data: Path) -> dict[float, float]:
    """The chain tangent along the TM axis at each working point (``fem/static.csv``)."""
    with open(data / "fem" / "static.csv", newline="") as fh:
        return {float(r["dp_Pa"]): float(r["chain_tangent_z_N_per_m"]) for r in csv.DictReader(fh)}


def calibration_module(text: str, data: Path, gen: Path):
    """The chain alone (no TM) with ``φ`` as the parameter :data:`PHI`."""
    d = yaml.safe_load(with_factor(text, PHI))
    d["parameters"] = {PHI: 1.0, **d["parameters"]}
    path = gen / "middle_ear_chain_factor.yaml"
    gen.mkdir(parents=True, exist_ok=True)
    path.write_text(chain_description(yaml.safe_dump(d, sort_keys=False), data))
    return load_generated(generate(path, gen))


def umbo_stiffness(mod, p: np.ndarray) -> dict[str, float]:
    """Static stiffness of the chain at the malleus's umbo point along z [N/m] (every other
    coordinate free, the TM's node translations included) and the static stapes/umbo ratio."""
    lin = linearize(mod, p=p)
    names = list(lin.coordinates)
    f = np.zeros(len(names))
    f[names.index("m_z")] = 1.0
    x = np.linalg.solve(lin.Q, f)
    return {"k": 1.0 / x[names.index("m_z")],
            "stapes_ratio": x[names.index("s_z")] / x[names.index("m_z")]}


def factor_table(mod, tangents: Mapping[float, float]) -> dict[float, float]:
    """``φ(Δp)`` with the chain's static stiffness at the umbo equal to the tangent."""
    out = {}
    for dp, k_t in sorted(tangents.items()):
        p = parameters_at(mod, dp)
        i = list(mod.PARAMETERS).index(PHI)

        def gap(phi, p=p, i=i, k_t=k_t):
            p[i] = phi
            return umbo_stiffness(mod, p)["k"] - k_t

        out[dp] = float(spo.brentq(gap, 1e-2, 1e4, xtol=1e-10, rtol=1e-10))
    return out


def retarget(text: str, data: Path, gen: Path, where: Path | None = None) -> str:
    """``middle_ear.yaml`` text for the sweep in ``data``: its manubrium nodes (per-node
    stiffness by :func:`tm_node_stiffness`) and its factor table. ``where``: the directory
    the text will be written to; the body's path is then relative to it (so that the build
    can be moved as a whole), else absolute."""
    man = [int(i) for i in
           json.loads((data / "fem" / "sweep.json").read_text())["interface_nodes"]["manubrium"]]
    pos = chain_node_positions(data)
    d = yaml.safe_load(text)
    tm = d["elastic_bodies"]["tm"]
    body = (data / "embs" / "tm_air.npz").resolve()
    tm["data"] = str(body) if where is None else os.path.relpath(body, Path(where).resolve())
    tm["nodes"] = {f"m{i}": i for i in man}
    template = next(v for k, v in d["forces"].items() if k.startswith("tm_manubrium_"))
    forces = {k: v for k, v in d["forces"].items() if not k.startswith("tm_manubrium_")}
    umbo = pos[man[0]]
    new = {}
    for i in man:
        off = [pos[i][a] - umbo[a] for a in range(3)]
        new[f"tm_manubrium_{i}"] = {**template, "between": [f"tm.m{i}", "malleus"],
                                    "points": [[0, 0, 0], off]}
    d["forces"] = {**new, **forces}
    d["parameters"]["k_tm_node"] = tm_node_stiffness(
        [pos[i][0] - umbo[0] for i in man], float(d["parameters"]["r_axis"]),
        float(d["parameters"]["k_tm_manubrium"]))
    out = yaml.safe_dump(d, sort_keys=False, width=120)
    table = factor_table(calibration_module(out, data, gen), sweep_tangents(data))
    return with_factor(out, factor_expression(list(table), list(table.values())))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", type=Path, required=True, help="sweep + body (build_embs.py)")
    ap.add_argument("--gen", type=Path, default=None, help="generated modules (default /tmp)")
    ap.add_argument("--write", action="store_true", help="rewrite middle_ear.yaml's factor")
    args = ap.parse_args()
    gen = args.gen or Path("/tmp") / "neweul_chain_factor"
    text = DESCRIPTION.read_text()
    mod = calibration_module(text, args.dir, gen)
    table = factor_table(mod, sweep_tangents(args.dir))
    print("dp [Pa]  tangent [N/m]  phi    stapes/umbo (static)")
    tang = sweep_tangents(args.dir)
    for dp, phi in table.items():
        p = parameters_at(mod, dp)
        p[list(mod.PARAMETERS).index(PHI)] = phi
        r = umbo_stiffness(mod, p)["stapes_ratio"]
        print(f"{dp:+7.0f}  {tang[dp]:12.1f}  {phi:6.3f}  {r:.3f}")
    if args.write:
        DESCRIPTION.write_text(with_factor(text, factor_expression(list(table),
                                                                    list(table.values()))))
        print(f"wrote the factor into {DESCRIPTION}")


if __name__ == "__main__":
    main()
