"""The description of the middle-ear EMBS and the calibration of its stiffening chain.

The template ``templates/middle_ear.yaml`` (every value and its source in its comments and in
``docs/middle-ear-data.md``) couples the rigid ossicles with the parametric TM + air body at its
manubrium nodes. :func:`retarget` fits it to one build: the body file, one TM–manubrium bushing
per manubrium node of the sweep (:func:`tm_node_stiffness`), and the chain's stiffening factor
``φ(Δp)`` (docs/equations-middle-ear.md §7).

``φ`` makes the 3-D chain of the description as stiff, statically at the umbo along the TM
axis (TM removed, every other chain coordinate free), as the tangent ``k_t(Δp)`` of the chain
characteristic that carried the static load in the FE sweep (``chain_tangent_z_N_per_m`` of
``static.csv``): the elements the static load stretches (the anterior mallear ligament and the
incudomalleolar joint) stiffen by ``φ``; the posterior incudal and the annular ligament keep
their small-deflection values (Hüttenbrink 1988; docs/middle-ear-measurements.md §3).
:func:`factor_table` finds ``φ`` per working point with Brent's method on the chain-only
module (:func:`chain_description`), and :func:`factor_expression` writes it as a
piecewise-linear expression in ``dp`` into every ``piecewise(dp < …)`` of the template.
"""

from __future__ import annotations

import csv
import os
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import scipy.optimize as spo
import yaml

from ..analysis import load_generated
from ..analysis.linearize import linearize
from ..api import generate
from ..elastic.io.fe_files import read_fe_model
from ..errors import DataError

__all__ = [
    "PHI",
    "PROBE_MASS",
    "chain_description",
    "factor_expression",
    "factor_table",
    "model_path",
    "node_positions",
    "parameters_at",
    "retarget",
    "sweep_tangents",
    "template",
    "tm_node_stiffness",
    "umbo_stiffness",
    "with_factor",
]

#: Name of the calibration parameter that stands for ``φ`` in the chain-only module.
PHI = "phi_calibration"
#: Mass [kg] put on the free node translations of the chain-only model (and taken off again).
PROBE_MASS = 1e-9


def template(name: str = "middle_ear.yaml") -> str:
    """The text of a template shipped with the package (``middle_ear.yaml``, ``ossicles.yaml``)."""
    return resources.files(__package__).joinpath("templates", name).read_text(encoding="utf-8")


def model_path(fem: Path, dp: float) -> Path:
    """The working point's FE file in the sweep directory ``fem`` (the name the sweep gives it)."""
    return Path(fem) / f"model_dp{dp:+06.0f}.npz"


def parameters_at(mod: Any, dp: float) -> np.ndarray:
    """The module's default parameter vector with ``dp`` set."""
    p = np.array(mod.default_parameters(), dtype=float)
    p[list(mod.PARAMETERS).index("dp")] = dp
    return p


def node_positions(fem: Path) -> dict[int, tuple[float, float, float]]:
    """Reference positions of the FE nodes (the nodes of the description's bushings): the
    reference mesh, the same in every working point of the sweep in ``fem``."""
    files = sorted(Path(fem).glob("model_dp*.npz"))
    if not files:
        raise DataError("no working point of an FE sweep here", str(fem), "model_dp*.npz")
    fe = read_fe_model(files[0])
    return {int(r[0]): (float(r[1]), float(r[2]), float(r[3])) for r in fe.nodes}


def tm_node_stiffness(x_nodes: Sequence[float], r_axis: float, k_total: float) -> float:
    """Per-node TM–manubrium stiffness [N/m] whose rotation stiffness about the ossicular axis
    equals the 1-D attachment ``k_total`` at the umbo: ``k Σ (r − x_i)² = k_total r²``.

    LVATB1's TM–manubrium spring (36 933 N/m) couples the TM to the malleus in the umbo
    coordinate of the chain's rotation about the axis; nodes nearer the axis move less.
    """
    d = r_axis - np.asarray(x_nodes, dtype=float)
    return float(k_total * r_axis**2 / np.sum(d * d))


def chain_description(text: str, positions: Mapping[int, Sequence[float]]) -> str:
    """The chain of a middle-ear description alone: no TM body, its node frames ``tm.mK``
    replaced by frames ``nK`` at the node ``positions`` on free translations
    ``nK_x, nK_y, nK_z``, each with the point mass :data:`PROBE_MASS` (the mass matrix stays
    regular for the linearization; a translating point adds ``m I`` to its coordinates,
    which a caller takes off again exactly)."""
    data = yaml.safe_load(text)
    tm = data.pop("elastic_bodies")["tm"]
    data["name"] = "middle_ear_chain"
    data["inputs"] = {}
    for label, node in tm["nodes"].items():
        x, _y, z = positions[int(node)]
        name = f"n{node}"
        for a in "xyz":
            data["coordinates"][f"{name}_{a}"] = 0.0
        data["frames"][name] = {"translation": [f"{x!r} + {name}_x", f"{name}_y",
                                                f"{z!r} + {name}_z"]}
        data["bodies"][f"{name}_point"] = {"frame": name, "mass": PROBE_MASS}
        for force in data["forces"].values():
            if "between" in force:
                force["between"] = [name if f == f"tm.{label}" else f for f in force["between"]]
    return yaml.safe_dump(data, sort_keys=False)


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


def sweep_tangents(fem: Path) -> dict[float, float]:
    """The chain tangent along the TM axis at each working point of a sweep (``static.csv``)."""
    path = Path(fem) / "static.csv"
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            return {float(r["dp_Pa"]): float(r["chain_tangent_z_N_per_m"])
                    for r in csv.DictReader(fh)}
    except (OSError, KeyError, ValueError) as exc:
        raise DataError(f"no chain tangents ({exc})", str(path), "chain_tangent_z_N_per_m"
                        ) from None


def calibration_module(text: str, positions: Mapping[int, Sequence[float]], gen: Path) -> Any:
    """The chain alone (no TM) with ``φ`` as the parameter :data:`PHI`, generated in ``gen``."""
    d = yaml.safe_load(with_factor(text, PHI))
    d["parameters"] = {PHI: 1.0, **d["parameters"]}
    gen.mkdir(parents=True, exist_ok=True)
    path = gen / "middle_ear_chain_factor.yaml"
    path.write_text(chain_description(yaml.safe_dump(d, sort_keys=False), positions),
                    encoding="utf-8")
    return load_generated(generate(path, gen))


def umbo_stiffness(mod: Any, p: np.ndarray) -> dict[str, float]:
    """Static stiffness of the chain at the malleus's umbo point along z [N/m] (every other
    coordinate free, the TM's node translations included) and the static stapes/umbo ratio."""
    lin = linearize(mod, p=p)
    names = list(lin.coordinates)
    f = np.zeros(len(names))
    f[names.index("m_z")] = 1.0
    x = np.linalg.solve(lin.Q, f)
    return {"k": 1.0 / x[names.index("m_z")],
            "stapes_ratio": x[names.index("s_z")] / x[names.index("m_z")]}


def factor_table(mod: Any, tangents: Mapping[float, float]) -> dict[float, float]:
    """``φ(Δp)`` with the chain's static stiffness at the umbo equal to the tangent."""
    out = {}
    i = list(mod.PARAMETERS).index(PHI)
    for dp, k_t in sorted(tangents.items()):
        p = parameters_at(mod, dp)

        def gap(phi: float, p: np.ndarray = p, k_t: float = k_t) -> float:
            p[i] = phi
            return umbo_stiffness(mod, p)["k"] - k_t

        out[dp] = float(spo.brentq(gap, 1e-2, 1e4, xtol=1e-10, rtol=1e-10))
    return out


def retarget(text: str, fem: Path, manubrium: Sequence[int], body: Path, gen: Path,
             where: Path | None = None) -> str:
    """A middle-ear description for one build: its body file, one TM–manubrium bushing per
    node of ``manubrium`` (per-node stiffness :func:`tm_node_stiffness`) and the factor
    table of the sweep in ``fem`` (the chain-only calibration module is generated in
    ``gen``). ``where``: the directory the text will be written to; the body's path is then
    relative to it (the build can be moved as a whole), else absolute."""
    pos = node_positions(fem)
    d = yaml.safe_load(text)
    tm = d["elastic_bodies"]["tm"]
    body = Path(body).resolve()
    tm["data"] = str(body) if where is None else os.path.relpath(body, Path(where).resolve())
    tm["nodes"] = {f"m{i}": int(i) for i in manubrium}
    template_force = next(v for k, v in d["forces"].items() if k.startswith("tm_manubrium_"))
    forces = {k: v for k, v in d["forces"].items() if not k.startswith("tm_manubrium_")}
    umbo = pos[int(manubrium[0])]
    new = {}
    for i in manubrium:
        off = [pos[int(i)][a] - umbo[a] for a in range(3)]
        new[f"tm_manubrium_{i}"] = {**template_force, "between": [f"tm.m{i}", "malleus"],
                                    "points": [[0, 0, 0], off]}
    d["forces"] = {**new, **forces}
    d["parameters"]["k_tm_node"] = tm_node_stiffness(
        [pos[int(i)][0] - umbo[0] for i in manubrium], float(d["parameters"]["r_axis"]),
        float(d["parameters"]["k_tm_manubrium"]))
    out = yaml.safe_dump(d, sort_keys=False, width=120)
    table = factor_table(calibration_module(out, pos, gen), sweep_tangents(fem))
    return with_factor(out, factor_expression(list(table), list(table.values())))
