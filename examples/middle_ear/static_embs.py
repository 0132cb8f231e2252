"""The static state of the EMBS under Δp against the FE static solution.

Run from the repository root after ``build_embs.py`` (README.md, "Static state of the body")::

    python examples/middle_ear/static_embs.py --dir DATA [--pressures -3600,-1400,600,2600]

For each working point of the body and each extra Δp (whose FE static solution is built by
``neweul fem middle-ear`` as in ``validate_embs.py``): the body at Δp carries its static state
(node displacements and interface forces at the manubrium, static outputs, mixed by the
body's weights between samples); the malleus is tied to the manubrium nodes by the
TM–manubrium springs and held by the chain's static characteristic; the static problem
(:func:`neweul_py.elastic.quality.static_equilibrium.tied_static_equilibrium`,
docs/equations-middle-ear.md §5) is solved and its umbo displacement and swept volume are
compared with the FE static solution (``static.csv``). Two characteristics: the closed form
``F(s)`` of the FE static solution (§2) and the ``chain_stiffening`` table of
``ossicles.yaml`` (natural cubic spline, as the description interpolates it).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import yaml
from scipy.interpolate import CubicSpline

sys.path.insert(0, str(Path(__file__).resolve().parent))
import validate_embs as ve

from neweul_py.elastic.io.body_files import load_parametric_body
from neweul_py.elastic.io.working_point import read_static
from neweul_py.elastic.quality.static_equilibrium import tied_static_equilibrium
from neweul_py.middle_ear.parameters import MiddleEarParameters

HERE = Path(__file__).resolve().parent


def chain_restoring(table: bool, kc0: np.ndarray) -> Callable:
    """``y → (F_c, K_c)``: the chain at the malleus as the FE static solution has it (§2), the
    tangent at Δp = 0 ``kc0`` in every direction plus, along z, the excess of the stiffening
    characteristic — the closed form ``F(s) − k₀ s`` or the ``ossicles.yaml`` table."""
    p = MiddleEarParameters()
    k0, sp, sm = p.k_chain, p.chain_limit_medial, p.chain_limit_lateral
    forces = yaml.safe_load((HERE / "ossicles.yaml").read_text())["forces"]
    tab = np.array(forces["chain_stiffening"]["stiffness"]["table"])
    g = CubicSpline(tab[:, 0], tab[:, 1], bc_type="natural")

    def restoring(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        F, K = kc0 @ y, kc0.copy()
        z = y[2]
        if table:
            F[2] += g(z)
            K[2, 2] += g(z, 1)
        else:
            s = sp if z >= 0 else sm
            F[2] = -np.sign(z) * k0 * s * np.log(1 - abs(z) / s)
            K[2, 2] = k0 / (1 - abs(z) / s)
        return F, K
    return restoring


def static_errors(data: Path, extra: list[float]) -> list[tuple[float, bool, str, float, float]]:
    """``(dp, is_sample, characteristic, umbo error, volume error)`` (relative) per Δp."""
    pb = load_parametric_body(data / "embs" / "tm_air.npz")
    info = json.loads((data / "embs" / "build.json").read_text())
    man = np.array(info["manubrium"])
    k = MiddleEarParameters().k_tm_manubrium / man.size
    kc0 = read_static(data / "fem" / "model_dp+00000.npz")["chain_tangent"]
    umbo = pb.nodes[pb.nodes[:, 0] == info["umbo"]][0, 1:4]
    out = list(pb.output_names)
    ref: dict[float, np.ndarray] = {}
    for d in {data / "fem", data / "fem_refine"}:
        if (d / "static.csv").exists():
            for r in np.atleast_1d(np.genfromtxt(d / "static.csv", delimiter=",", names=True)):
                ref[float(r["dp_Pa"])] = r
    for dp in extra:
        ref[dp] = np.atleast_1d(np.genfromtxt(ve.fe_model_at(dp, data).parent / "static.csv",
                                              delimiter=",", names=True))[0]
    rows = []
    for dp in sorted(p for p in ref if p != 0.0 and (p in pb.samples or p in extra)):
        for table in (False, True):
            sol = tied_static_equilibrium(pb.at(dp), man, k, chain_restoring(table, kc0), umbo)
            e = [sol["outputs"][out.index(name)] / float(ref[dp][col]) - 1 for name, col in
                 (("umbo_uz", "umbo_uz_m"), ("tm_volume_displacement",
                                             "volume_displacement_m3"))]
            rows.append((dp, dp in pb.samples, "table" if table else "F(s)", *e))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", type=Path, default=HERE / "data")
    ap.add_argument("--pressures", default="-3600,-1400,600,2600",
                    help="Δp between samples, their FE static solution built alone")
    args = ap.parse_args()
    extra = [float(v) for v in args.pressures.split(",")] if args.pressures else []
    print("relative error of the body + chain static state against the FE static solution")
    print(f"{'dp [Pa]':>8} {'':>7} {'F_c':>6} {'umbo u_z':>10} {'volume':>10}")
    for dp, sample, kind, eu, ev in static_errors(args.dir, extra):
        print(f"{dp:>+8.0f} {'sample' if sample else 'between':>7} {kind:>6} {eu:>+10.2e} "
              f"{ev:>+10.2e}")


if __name__ == "__main__":
    main()
