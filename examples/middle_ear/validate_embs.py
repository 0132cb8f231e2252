"""Validation of the middle-ear EMBS against the unreduced FE model with the same chain.

Run from the repository root after ``build_embs.py`` (README.md, "Validation")::

    python examples/middle_ear/validate_embs.py [--pressures -4000,0,2000,2500] [--nf 40]
        [--damping loss|viscous]

For each Δp: the generated module of ``middle_ear.yaml`` (parametric TM + air body scheduled
at Δp, ossicles, one TM–manubrium bushing per manubrium node), linearized, against the full
FE model of that working point (``neweul fem middle-ear``; between samples, e.g. 2500 Pa,
the FE model linearized *there*) coupled directly with the **same** chain: the description
with the TM body removed and each node frame ``tm.mK`` replaced by a frame on three free
translations, generated and linearized, its matrices attached to the FE DOFs of the manubrium nodes
(:func:`neweul_py.middle_ear.coupled.coupled_frf`). Both use the loss factors as ``K + iG``
(the body's ``Le``, the FE model's ``G``, the chain's ``loss_factor``: docs/equations.md
§1.1; ``--damping viscous``: both the viscous equivalent ``D``).
Printed: max relative error of the umbo velocity (TM node 1) and of the stapes velocity per
probe pressure, below 2 kHz and 2–5 kHz.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import yaml

from neweul_py.analysis import load_generated
from neweul_py.analysis.linearize import linearize
from neweul_py.api import generate
from neweul_py.elastic import read_fe_model
from neweul_py.elastic.quality.frf_sweep import frequency_form
from neweul_py.middle_ear.coupled import coupled_frf

HERE = Path(__file__).resolve().parent
DESCRIPTION = HERE / "middle_ear.yaml"
#: Mass [kg] put on the free node translations of the chain-only model (and taken off again).
PROBE_MASS = 1e-9


def chain_description(text: str, data_dir: Path = HERE / "data") -> str:
    """The chain of ``middle_ear.yaml`` alone: no TM body, its node frames ``tm.mK`` replaced
    by frames ``nK`` at the node positions on free translations ``nK_x, nK_y, nK_z``."""
    data = yaml.safe_load(text)
    tm = data.pop("elastic_bodies")["tm"]
    data["name"] = "middle_ear_chain"
    data["inputs"] = {}
    positions = chain_node_positions(data_dir)
    for label, node in tm["nodes"].items():
        x, _y, z = positions[int(node)]
        name = f"n{node}"
        for a in "xyz":
            data["coordinates"][f"{name}_{a}"] = 0.0
        data["frames"][name] = {"translation": [f"{x!r} + {name}_x", f"{name}_y",
                                                f"{z!r} + {name}_z"]}
        # a point mass makes the mass matrix regular for linearize; removed again exactly
        # (a translating point adds m I to its three coordinates) in reference_frf
        data["bodies"][f"{name}_point"] = {"frame": name, "mass": PROBE_MASS}
        for force in data["forces"].values():
            if "between" in force:
                force["between"] = [name if f == f"tm.{label}" else f for f in force["between"]]
    return yaml.safe_dump(data, sort_keys=False)


def chain_node_positions(data: Path = HERE / "data") -> dict[int, tuple[float, float, float]]:
    """Reference positions of the FE nodes (those of the description's bushings)."""
    fe = read_fe_model(model_path(data / "fem", 0.0))
    return {int(r[0]): (float(r[1]), float(r[2]), float(r[3])) for r in fe.nodes}


def retarget_description(text: str, manubrium: list[int], data: Path, body: str) -> str:
    """``middle_ear.yaml`` for another mesh (e.g. refine 0 in the tests): the TM body file
    ``body``, node frames and one TM–manubrium bushing per node of ``manubrium``."""
    d = yaml.safe_load(text)
    pos = chain_node_positions(data)
    tm = d["elastic_bodies"]["tm"]
    tm["data"] = body
    tm["nodes"] = {f"m{i}": i for i in manubrium}
    d["forces"] = {k: v for k, v in d["forces"].items() if not k.startswith("tm_manubrium_")}
    d["parameters"]["k_tm_node"] = d["parameters"]["k_tm_manubrium"] / len(manubrium)
    umbo = pos[manubrium[0]]
    for i in manubrium:
        off = [pos[i][a] - umbo[a] for a in range(3)]
        d["forces"][f"tm_manubrium_{i}"] = {"type": "bushing", "between": [f"tm.m{i}", "malleus"],
                                           "points": [[0, 0, 0], off], "stiffness": "k_tm_node"}
    return yaml.safe_dump(d, sort_keys=False)


def require_build(data: Path, *dps: float) -> None:
    """Stop with one line unless ``data`` holds a build of ``build_embs.py`` whose sweep
    covers every Δp in ``dps`` (the body refuses extrapolation)."""
    sweep, body = data / "fem" / "sweep.json", data / "embs" / "tm_air.npz"
    if not sweep.is_file() or not body.is_file():
        raise SystemExit(f"{data}: no middle-ear build here (run examples/middle_ear/"
                         f"build_embs.py --dir {data} first)")
    pts = [float(w["dp_Pa"]) for w in json.loads(sweep.read_text())["working_points"]]
    bad = [dp for dp in dps if not min(pts) <= dp <= max(pts)]
    if bad:
        raise SystemExit(f"{data}: Δp = {bad[0]:g} Pa is outside the sweep "
                         f"[{min(pts):g}, {max(pts):g}] Pa (no extrapolation)")


def model_path(fem: Path, dp: float) -> Path:
    return fem / f"model_dp{int(dp):+06d}.npz"


def fe_model_at(dp: float, data: Path) -> Path:
    """The FE model of a working point: from the sweep, or built alone (between samples)."""
    path = model_path(data / "fem", dp)
    if path.exists():
        return path
    extra = data / f"fem_dp{int(dp):+06d}"
    path = model_path(extra, dp)
    if not path.exists():
        refine = json.loads((data / "fem" / "sweep.json").read_text())["refine"]
        subprocess.run([sys.executable, "-m", "neweul_py.cli", "fem", "middle-ear",
                        "--pressures", f"{dp:g}:{dp:g}:1", "--refine", str(refine), "-o",
                        str(extra)], check=True)
    return path


def parameters_at(mod, dp: float) -> np.ndarray:
    p = np.array(mod.default_parameters(), dtype=float)
    p[list(mod.PARAMETERS).index("dp")] = dp
    return p


def embs_frf(mod, dp: float, f: np.ndarray, damping: str = "loss") -> dict[str, np.ndarray]:
    """p_probe, umbo_uz, stapes_velocity per unit Q of the linearized EMBS (``damping``:
    ``"loss"``, the loss factors as ``K + iG``, or ``"viscous"``, docs/equations.md §1.1)."""
    lin = linearize(mod, p=parameters_at(mod, dp))
    j = list(lin.inputs).index("Q")
    m = lin.M0.shape[0]
    out = {}
    z = lin.dynamic_stiffness(2 * np.pi * np.asarray(f, dtype=float), damping)
    xs = np.linalg.solve(z, np.broadcast_to(lin.B[:, j], (len(f), m))[..., None])[..., 0]
    w = 2 * np.pi * f
    for name in ("p_probe", "umbo_uz", "stapes_velocity", "umbo_velocity_z"):
        c = lin.C[list(lin.outputs).index(name)]
        out[name] = xs @ c[:m] + (1j * w * xs.T).T @ c[m:]
    return out


def reference_frf(chain_mod, fe_path: Path, dp: float, f: np.ndarray,
                  damping: str = "loss", p: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The same outputs of the FE model + the chain assembled directly (``damping`` as in
    :func:`embs_frf`: the FE model's ``K + iG`` and the chain's loss factors, or both
    viscous; ``p`` the chain's parameter vector, default its defaults with ``dp``)."""
    lin = linearize(chain_mod, p=parameters_at(chain_mod, dp) if p is None else p)
    names = list(lin.coordinates)
    fe = frequency_form(read_fe_model(fe_path), damping)
    node = [n for n in names if n.startswith("n") and n[1:].split("_")[0].isdigit()]
    own = [n for n in names if n not in node]
    order = [names.index(n) for n in (*own, *node)]
    P, Q = lin.P, lin.Q
    if damping == "loss" and lin.has_loss:      # K + iG, D − G/ω_ref of the chain as well
        P = P - lin.G / (2 * np.pi * lin.loss_reference_frequency)
        Q = Q + 1j * lin.G
    chain = {k: a[np.ix_(order, order)] for k, a in (("M", lin.M0), ("D", P), ("K", Q))}
    k = np.arange(len(own), len(names))
    chain["M"][k, k] -= PROBE_MASS
    dofs = [fe.inputs[f"manubrium.{n[1:].split('_')[0]}.u{n[-1]}"][0][0] for n in node]
    res = coupled_frf(fe, chain, dofs, f, "canal_volume_acceleration",
                      ["probe_pressure", "umbo_uz"], [own.index("s_z"), own.index("m_z")])
    return {"p_probe": res["probe_pressure"], "umbo_uz": res["umbo_uz"],
            "stapes_velocity": res[f"chain{own.index('s_z')}"],
            "umbo_velocity_z": res[f"chain{own.index('m_z')}"]}


def transfer(h: dict[str, np.ndarray], f: np.ndarray) -> dict[str, np.ndarray]:
    """Umbo (TM node 1) and stapes velocity per probe pressure [m/s/Pa]."""
    w = 2 * np.pi * f
    return {"umbo": 1j * w * h["umbo_uz"] / h["p_probe"],
            "stapes": h["stapes_velocity"] / h["p_probe"]}


def modules(data: Path, description: Path | None = None):
    """The generated EMBS and chain-only modules (cached under ``data/embs``); the description
    defaults to the one ``build_embs.py`` wrote for this build (``DATA/embs/middle_ear.yaml``),
    else ``middle_ear.yaml``."""
    if description is None:
        built = data / "embs" / "middle_ear.yaml"
        description = built if built.exists() else DESCRIPTION
    gen = data / "embs" / "generated"
    mod = load_generated(generate(description, gen))
    chain_file = data / "embs" / "middle_ear_chain.yaml"
    chain_file.write_text(chain_description(description.read_text(), data))
    return mod, load_generated(generate(chain_file, gen))


def errors(mod, chain_mod, dp: float, f: np.ndarray, data: Path,
           damping: str = "loss") -> dict[str, np.ndarray]:
    """Relative error per frequency of the EMBS transfer functions against the reference."""
    got = transfer(embs_frf(mod, dp, f, damping), f)
    ref = transfer(reference_frf(chain_mod, fe_model_at(dp, data), dp, f, damping), f)
    return {k: np.abs(got[k] - ref[k]) / np.abs(ref[k]) for k in got} | {
        f"ref_{k}": v for k, v in ref.items()} | {f"got_{k}": v for k, v in got.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pressures", default="-4000,0,2000,2500")
    ap.add_argument("--nf", type=int, default=40)
    ap.add_argument("--dir", type=Path, default=HERE / "data")
    ap.add_argument("--damping", choices=("loss", "viscous"), default="loss",
                    help="loss factors as K + iG (default) or their viscous equivalent")
    args = ap.parse_args()
    f = np.geomspace(100.0, 5000.0, args.nf)
    mod, chain_mod = modules(args.dir)
    print("relative error of the EMBS against the unreduced FE model + the same chain "
          f"({f.size} log frequencies 100 Hz-5 kHz)")
    print(f"{'dp [Pa]':>8} {'umbo <2k':>10} {'umbo 2-5k':>10} {'stapes <2k':>11} "
          f"{'stapes 2-5k':>11}")
    low = f < 2000
    for dp in (float(v) for v in args.pressures.split(",")):
        e = errors(mod, chain_mod, dp, f, args.dir, args.damping)
        print(f"{dp:>+8.0f} {e['umbo'][low].max():>10.2e} {e['umbo'][~low].max():>10.2e} "
              f"{e['stapes'][low].max():>11.2e} {e['stapes'][~low].max():>11.2e}")


if __name__ == "__main__":
    main()
