"""Where the EMBS error between working points comes from: the basis or the interpolation.

Run from the repository root after ``neweul middle-ear build --dir DATA``::

    python examples/middle_ear/midpoint_error.py --dir DATA [--pressures -3500,-1500,500,2500]

For each Δp between the samples, the same chain (the build's description without the TM body,
linearized at Δp) is attached to four TM + air models and the umbo and stapes velocity per
probe pressure compared with the first (max relative error below 2 kHz and 2–5 kHz):

* ``full`` — the unreduced FE model linearized at Δp (the reference of ``validate_embs.py``);
* ``projected`` — that FE model projected on the body's basis ``V`` (``Vᵀ X V``), no
  interpolation: the error of the basis alone;
* ``interpolated`` — the parametric body at Δp (what the EMBS uses): basis + interpolation;
* ``nearest`` — the nearest sample's body (no interpolation, wrong working point).

The chain is attached to the reduced models exactly as to the FE model
(:func:`neweul_py.middle_ear.coupled.coupled_frf`), through the node rows ``Φ_n`` of the basis;
the generated module equals this hand assembly to 4e-9 (``validate_embs.py``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from neweul_py.analysis.linearize import linearize
from neweul_py.elastic import read_fe_model
from neweul_py.elastic.io.body_files import load_parametric_body
from neweul_py.middle_ear import validation
from neweul_py.middle_ear.embs import PROBE_MASS, parameters_at
from neweul_py.middle_ear.study import build_record, transfer


def chain_matrices(chain_mod, dp: float) -> tuple[dict[str, np.ndarray], list[str], list[str]]:
    """The chain's M, D, K in the order ``[own; node translations]``, with the probe mass off."""
    lin = linearize(chain_mod, p=parameters_at(chain_mod, dp))
    names = list(lin.coordinates)
    node = [n for n in names if n.startswith("n") and n[1:].split("_")[0].isdigit()]
    own = [n for n in names if n not in node]
    order = [names.index(n) for n in (*own, *node)]
    chain = {k: getattr(lin, a)[np.ix_(order, order)] for k, a in
             (("M", "M0"), ("D", "P"), ("K", "Q"))}
    k = np.arange(len(own), len(names))
    chain["M"][k, k] -= PROBE_MASS
    return chain, own, node


def reduced_coupled(M, D, K, b, rows: dict[str, np.ndarray], phi_n: np.ndarray,
                    chain: dict[str, np.ndarray], own: list[str], f: np.ndarray
                    ) -> dict[str, np.ndarray]:
    """``coupled_frf`` for a reduced model ``x = V q``: ``u_n = Φ_n q`` (Galerkin, ``W = V``)."""
    r, nc = M.shape[0], len(own)
    m = chain["K"].shape[0]
    P = np.zeros((m, r + nc))
    P[:nc, r:] = np.eye(nc)
    P[nc:, :r] = phi_n

    def total(X, key):
        A = np.zeros((r + nc, r + nc))
        A[:r, :r] = X
        return A + P.T @ chain[key] @ P

    Mt, Dt, Kt = total(M, "M"), total(D, "D"), total(K, "K")
    rhs = np.r_[b, np.zeros(nc)].astype(complex)
    w = 2 * np.pi * f
    xs = np.array([np.linalg.solve(Kt + 1j * wi * Dt - wi * wi * Mt, rhs) for wi in w])
    out = {name: xs[:, :r] @ c for name, c in rows.items()}
    out["stapes_velocity"] = 1j * w * xs[:, r + own.index("s_z")]
    out["umbo_velocity_z"] = 1j * w * xs[:, r + own.index("m_z")]
    return out


def node_rows(fe, node: list[str]) -> np.ndarray:
    return np.array([fe.inputs[f"manubrium.{n[1:].split('_')[0]}.u{n[-1]}"][0][0] for n in node])


def projected(fe, V: np.ndarray, node: list[str]):
    """``Vᵀ X V`` of the FE model, its input and output rows, node rows."""
    mats = [V.T @ (X @ V) if X is not None else np.zeros((V.shape[1],) * 2)
            for X in (fe.M, fe.D, fe.K)]
    b = V.T @ fe.B("canal_volume_acceleration")[:, 0]
    rows = {}
    for name in ("probe_pressure", "umbo_uz"):
        c = np.zeros(fe.n_dofs)
        for i, w in fe.outputs[name]:
            c[i] += w
        rows[name] = c @ V
    return (*mats, b, rows, V[node_rows(fe, node)])


def body_parts(body, node: list[str]):
    """The reduced body's M, D, K, input, outputs and node rows ``Φ_n``."""
    b = body.B[:, list(body.input_names).index("canal_volume_acceleration")]
    rows = {name: body.C[list(body.output_names).index(name)]
            for name in ("probe_pressure", "umbo_uz")}
    idx = []
    for n in node:
        nid, a = int(n[1:].split("_")[0]), "u" + n[-1]
        idx.append(int(np.flatnonzero((body.dof_node == nid) & (body.dof_kind == a))[0]))
    return body.M, body.D, body.K, b, rows, body.V_kept[idx]


def as_transfer(h: dict[str, np.ndarray], f: np.ndarray) -> dict[str, np.ndarray]:
    return transfer({"umbo_uz": h["umbo_uz"], "p_probe": h["probe_pressure"],
                     "stapes_velocity": h["stapes_velocity"],
                     "umbo_velocity_z": h["umbo_velocity_z"]}, f)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pressures", default="-3500,-1500,500,2500")
    ap.add_argument("--nf", type=int, default=40)
    ap.add_argument("--dir", type=Path, required=True, help="a build of neweul middle-ear build")
    args = ap.parse_args()
    pressures = [float(v) for v in args.pressures.split(",")]
    record = build_record(args.dir, *pressures)
    f = np.geomspace(100.0, 5000.0, args.nf)
    low = f < 2000
    chain_mod = validation.chain_module(args.dir / "middle_ear.yaml", args.dir / "fem",
                                        args.dir / "validation")
    pb = load_parametric_body(args.dir / record["body"])
    V = pb.R
    print("max relative error against the unreduced FE model + chain, umbo / stapes "
          "velocity per probe pressure")
    print(f"{'dp [Pa]':>8} {'model':>13} {'umbo <2k':>9} {'umbo 2-5k':>9} {'stap <2k':>9} "
          f"{'stap 2-5k':>9}")
    for dp in pressures:
        chain, own, node = chain_matrices(chain_mod, dp)
        path = validation.fe_model_at(dp, args.dir, int(record["refine"]))
        fe = read_fe_model(path)
        ref = transfer(validation.reference_frf(chain_mod, path, dp, f, "viscous"),
                       f)   # the body's viscous D
        near = pb.samples[int(np.argmin(np.abs(pb.samples - dp)))]
        models = {"projected": projected(fe, V, node),
                  "interpolated": body_parts(pb.at(dp), node),
                  f"nearest {near:+.0f}": body_parts(pb.at(near), node)}
        for label, parts in models.items():
            got = as_transfer(reduced_coupled(*parts, chain, own, f), f)
            e = {k: np.abs(got[k] - ref[k]) / np.abs(ref[k]) for k in got}
            print(f"{dp:>+8.0f} {label:>13} {e['umbo'][low].max():>9.2e} "
                  f"{e['umbo'][~low].max():>9.2e} {e['stapes'][low].max():>9.2e} "
                  f"{e['stapes'][~low].max():>9.2e}", flush=True)


if __name__ == "__main__":
    main()
