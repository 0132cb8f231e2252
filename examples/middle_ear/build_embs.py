"""Build the parametric TM + air body of the middle-ear EMBS (``middle_ear.yaml``).

Run from the repository root (README.md, "The assembled EMBS")::

    python examples/middle_ear/build_embs.py [--refine 1] [--rtol 1e-8] [--order N]

1. the FE sweep ``neweul fem middle-ear --pressures -4000:4000:9`` into
   ``examples/middle_ear/data/fem`` (skipped when it is there with the same refinement);
2. a snapshot global basis (:mod:`neweul_py.elastic.snapshot_basis`): full FE responses of
   every working point at 20 Hz and 10 frequencies 100 Hz–8 kHz to the canal sound source and to the
   six rigid motions of the malleus seen through the TM–manubrium springs (36 933 N/m in
   all, equal per manubrium node), and the adjoint responses of the probe pressure, the umbo
   and the six malleus loads (same factorizations), POD-compressed per u/p block in the
   energy norms;
3. every working point's FE model projected on it (fixed-frame invariants: the body is on
   ISYS, gravity 0) → ``examples/middle_ear/data/embs/tm_air.npz`` (a parametric body,
   cubic weights in ``dp``), and the node ids and chain factors the description uses
   (``data/embs/build.json``), and the static state in the body's coordinates
   (``data/embs/static.npz``, docs/equations-middle-ear.md §7).

``data/`` is not committed (``.gitignore``); this script rebuilds it in about a minute.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sps

from neweul_py.elastic import read_fe_model
from neweul_py.elastic.global_basis import energy_metric
from neweul_py.elastic.interpolation import save_parametric_body
from neweul_py.elastic.snapshot_basis import basis_parametric_body, snapshot_basis
from neweul_py.fem.ear_transfer import LumpedChain
from neweul_py.fem.middle_ear import MiddleEarParameters
from neweul_py.fem.working_point_file import read_static

HERE = Path(__file__).resolve().parent
PRESSURES = np.arange(-4000.0, 4001.0, 1000.0)
SNAPSHOT_HZ = np.r_[20.0, np.geomspace(100.0, 8000.0, 10)]


def model_file(fem: Path, dp: float) -> Path:
    return fem / f"model_dp{int(dp):+06d}.npz"


def ensure_sweep(fem: Path, refine: int) -> dict:
    """The FE sweep in ``fem`` (built when missing or of another refinement)."""
    sweep = fem / "sweep.json"
    if sweep.exists() and json.loads(sweep.read_text()).get("refine") == refine and all(
            model_file(fem, p).exists() for p in PRESSURES):
        return json.loads(sweep.read_text())
    print(f"FE sweep (refine {refine}) into {fem}", file=sys.stderr)
    subprocess.run([sys.executable, "-m", "neweul_py.cli", "fem", "middle-ear", "--pressures",
                    "-4000:4000:9", "--refine", str(refine), "-o", str(fem)], check=True)
    return json.loads(sweep.read_text())


def rigid_map(fe, names: list[str], umbo: int) -> np.ndarray:
    """(3m, 6) rigid malleus map ``u = t + θ × (x − x_umbo)`` in the row order of ``names``
    (``manubrium.<id>.u?``; the FE inputs are ordered as strings, "20" before "8")."""
    xyz = {int(r[0]): r[1:4] for r in fe.nodes}
    T = np.zeros((len(names), 6))
    e = np.eye(3)
    for row, name in enumerate(names):
        _, node, kind = name.split(".")
        a = "xyz".index(kind[1])
        r = xyz[int(node)] - xyz[umbo]
        T[row, a] = 1.0
        T[row, 3:] = [np.cross(e[b], r)[a] for b in range(3)]
    return T


def interface_loads(fe, umbo: int, k_attach: float
                    ) -> tuple[sps.csr_matrix, np.ndarray, np.ndarray]:
    """``K_x`` (the TM–manubrium springs to ground), the loads ``[b_canal, K_x T]`` and the
    output rows (transposed) ``[c_probe, c_umbo, K_x T]`` of the adjoint snapshots."""
    man = [name for name in fe.inputs if name.startswith("manubrium.")]
    dofs = np.array([fe.inputs[name][0][0] for name in man])
    k = k_attach / (dofs.size // 3)
    n = fe.n_dofs
    Kx = sps.csr_matrix((np.full(dofs.size, k), (dofs, dofs)), shape=(n, n))
    F = np.zeros((n, 7))
    F[:, 0] = fe.B("canal_volume_acceleration")[:, 0]
    F[dofs, 1:] = k * rigid_map(fe, man, umbo)
    Cadj = np.zeros((n, 8))
    for j, name in enumerate(("probe_pressure", "umbo_uz")):
        for i, w in fe.outputs[name]:
            Cadj[i, j] += w
    Cadj[:, 2:] = F[:, 1:]
    return Kx, F, Cadj


def write_static(fes, V: np.ndarray, fem: Path, path: Path) -> None:
    """The static state in the body's coordinates (docs/equations-middle-ear.md §7): per
    working point ``q_s = Vᵀ Ḡ x_s`` (``V`` is Ḡ-orthonormal), the residual
    ``‖x_s − V q_s‖_Ḡ / ‖x_s‖_Ḡ``, the static malleus forces on the manubrium nodes [N] and
    the malleus's static coordinates."""
    G = energy_metric(fes)
    qs, res, force, mal = [], [], [], []
    for p in PRESSURES:
        st = read_static(model_file(fem, p))
        x = np.asarray(st["x"], dtype=float)
        q = V.T @ (G @ x)
        r = x - V @ q
        nx = float(np.sqrt(x @ (G @ x)))
        qs.append(q)
        res.append(float(np.sqrt(r @ (G @ r))) / nx if nx > 0 else 0.0)
        force.append(st["manubrium_force"])
        mal.append(st["malleus_q"])
    np.savez(path, dp_Pa=PRESSURES, q_static=np.array(qs), residual=np.array(res),
             manubrium_node_id=read_static(model_file(fem, 0.0))["manubrium_node_id"],
             manubrium_force_N=np.array(force), malleus_q=np.array(mal))
    print("static state in the body's coordinates: relative residual "
          + ", ".join(f"{p:+.0f} Pa {r:.1e}" for p, r in zip(PRESSURES, res, strict=True)),
          file=sys.stderr)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--refine", type=int, default=1)
    ap.add_argument("--rtol", type=float, default=1e-8,
                    help="relative POD energy cut of the snapshot basis (default 1e-8)")
    ap.add_argument("--order", type=int, default=None, help="cap the number of directions")
    ap.add_argument("--dir", type=Path, default=HERE / "data")
    args = ap.parse_args()
    t0 = time.perf_counter()
    fem, out = args.dir / "fem", args.dir / "embs"
    sweep = ensure_sweep(fem, args.refine)
    params = MiddleEarParameters(**sweep["parameters"])
    fes = [read_fe_model(model_file(fem, p)) for p in PRESSURES]
    Kx, F, Cadj = interface_loads(fes[0], int(sweep["interface_nodes"]["umbo"]),
                                  params.k_tm_manubrium)
    out.mkdir(parents=True, exist_ok=True)
    cache = out / f"basis3_r{args.refine}_{args.rtol:g}.npz"   # the snapshots take minutes
    done, prior = np.zeros(0), None
    if cache.exists():
        with np.load(cache) as z:
            V, energy = z["V"], z["energy"]
            done = z["freqs"]
        prior = V
    todo = np.array([f for f in SNAPSHOT_HZ if not np.any(np.isclose(f, done))])
    if todo.size:       # a cached basis is extended by the missing frequencies only
        V, energy = snapshot_basis(fes, [F] * len(fes), todo, Kx, rtol=args.rtol,
                                   progress=lambda m: print(m, file=sys.stderr), prior=prior,
                                   adjoint=[Cadj] * len(fes))
        np.savez(cache, V=V, energy=energy, freqs=np.union1d(done, todo))
    V, energy = V[:, :args.order], energy[:args.order]   # columns by decreasing energy
    manubrium = [int(i) for i in sweep["interface_nodes"]["manubrium"]]
    body = basis_parametric_body(fes, V, PRESSURES, parameter="dp", keep_nodes=manubrium,
                                 energy=energy)
    save_parametric_body(body, out / "tm_air.npz")
    write_static(fes, V, fem, out / "static.npz")
    chain = LumpedChain()
    tangent = [float(read_static(model_file(fem, p))["chain_tangent"][2, 2]) for p in PRESSURES]
    info = {"refine": args.refine, "order": int(V.shape[1]), "rtol": args.rtol,
            "pressures_Pa": PRESSURES.tolist(), "snapshot_Hz": SNAPSHOT_HZ.tolist(),
            "manubrium": manubrium, "umbo": int(sweep["interface_nodes"]["umbo"]),
            "chain_tangent_N_per_m": tangent,
            "ligament_factor": [chain.ligament_factor(k) for k in tangent]}
    (out / "build.json").write_text(json.dumps(info, indent=1) + "\n")
    print(f"wrote {out / 'tm_air.npz'}: order {V.shape[1]} "
          f"({int(np.count_nonzero(np.any(V[fes[0].dof_kind == 'p'] != 0, axis=0)))} pressure "
          f"directions), {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
