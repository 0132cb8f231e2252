"""Benchmark: reduction of a ≥ 100 000-DOF u–p coupled model.

Model: a rigid-walled air-filled tube (3-D, trilinear hexahedra on a structured grid, written
exactly as Kronecker sums of 1-D linear-element matrices) closed at x = 0 by a tensioned
membrane (bilinear elements, edges clamped) — an ear-canal-like acousto-structural model in
the pressure-based u–p form of Eq. (2) (``docs/equations.md`` §3), unsymmetric, with
stiffness-proportional damping in both fields. Default grid 1000 × 10 × 10 pressure nodes
(100 000 p DOFs) + 64 membrane DOFs.

Each measurement runs in a fresh subprocess so that its peak resident memory
(``resource.getrusage(RUSAGE_SELF).ru_maxrss``, model build included) is its own:

1. ``reduce_modal(fe, modes=50, static_correction=True)`` (two-sided, u–p left vectors,
   + 2 attachment vectors of the membrane force and the pressure output) — time, memory;
2. ``reduce_krylov(fe, points, order=1)`` (two-sided second-order moment matching, i.e.
   Hermite interpolation, at 8 real points 2π·(200 … 8000 Hz), r = 8) and pyMOR's
   ``SOBHIReductor`` (bitangential Hermite interpolation of second-order systems) with the
   same points, r = 8 — the comparable pyMOR method; and ours with 6 moments per point
   and side (r = 48) for accuracy (pyMOR has no
   second-order two-sided *modal* truncation; its ``MTReductor`` works on first-order models
   with dominant poles). pyMOR is not a dependency: it is imported if present, else the script
   says how to install it (``pip install pymor``);
3. FRF at 1000 frequencies: reduced (batched dense solves) vs. full (one sparse complex LU per
   frequency). The full model is solved at ``--full-points`` of the 1000 frequencies (default
   8, evenly picked: each complex LU costs ~20 s) and its time per frequency is extrapolated
   to 1000; errors are evaluated at those frequencies. ``--full-points 1000`` does all of them.

Run: ``python benchmarks/bench_reduction.py`` (add ``--grid NX NY NZ`` for another size).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sps

C_AIR, RHO_AIR = 343.0, 1.2
LENGTH, WIDTH = 1.0, 0.01  # tube length and square cross-section side [m]
TENSION, AREAL_MASS = 60.0, 0.075  # membrane tension [N/m] and mass per area [kg/m²]
BETA_FLUID, BETA_MEMBRANE = 2e-7, 2e-6  # stiffness-proportional damping [s]
F_MAX = 8000.0  # FRF band [Hz]
N_FREQ = 1000


def line(n: int, length: float) -> tuple[sps.csr_matrix, sps.csr_matrix]:
    """1-D linear elements on n nodes: consistent mass and stiffness."""
    h = length / (n - 1)
    d = np.full(n, 2.0)
    d[[0, -1]] = 1.0
    off = np.ones(n - 1)
    M = sps.diags([d * h / 3, off * h / 6, off * h / 6], [0, 1, -1], format="csr")
    K = sps.diags([d / h, -off / h, -off / h], [0, 1, -1], format="csr")
    return M, K


def build_model(nx: int, ny: int, nz: int):
    """The u–p model; pressure index ``p = (ix·ny + iy)·nz + iz``."""
    from neweul_py.elastic import FEModel

    Mx, Kx = line(nx, LENGTH)
    My, Ky = line(ny, WIDTH)
    Mz, Kz = line(nz, WIDTH)

    def kron3(a, b, c):
        return sps.kron(a, sps.kron(b, c, format="csr"), format="csr")

    Kf = kron3(Kx, My, Mz) + kron3(Mx, Ky, Mz) + kron3(Mx, My, Kz)
    Mf = kron3(Mx, My, Mz) / C_AIR**2
    # membrane on the face x = 0 (ix = 0): nodes (iy, iz), interior ones free
    Myz = sps.kron(My, Mz, format="csr")
    Kyz = sps.kron(Ky, Mz, format="csr") + sps.kron(My, Kz, format="csr")
    iy, iz = np.meshgrid(np.arange(ny), np.arange(nz), indexing="ij")
    face = (iy * nz + iz).ravel()
    interior = np.flatnonzero(((iy > 0) & (iy < ny - 1) & (iz > 0) & (iz < nz - 1)).ravel())
    Ks = TENSION * Kyz[interior][:, interior]
    Ms = AREAL_MASS * Myz[interior][:, interior]
    # C = ∫ N_uᵀ n N_p dΓ with n = −x (out of the fluid, into the membrane); p at ix = 0
    nu, npr = interior.size, nx * ny * nz
    Cc = -(Myz[interior] @ sps.csr_matrix((np.ones(face.size), (np.arange(face.size), face)),
                                           shape=(face.size, npr)))
    M = sps.bmat([[Ms, None], [RHO_AIR * Cc.T, Mf]], format="csr")
    K = sps.bmat([[Ks, -Cc], [None, Kf]], format="csr")
    D = sps.bmat([[BETA_MEMBRANE * Ks, None], [None, BETA_FLUID * Kf]], format="csr")
    gx, gy, gz = np.meshgrid(np.linspace(0, LENGTH, nx), np.linspace(0, WIDTH, ny),
                             np.linspace(0, WIDTH, nz), indexing="ij")
    p_nodes = np.column_stack([np.arange(npr) + 1, gx.ravel(), gy.ravel(), gz.ravel()])
    m_ids = npr + 1 + np.arange(nu)  # membrane nodes: own ids at the face positions
    m_nodes = np.column_stack([m_ids, np.zeros(nu), gy[0].ravel()[interior],
                               gz[0].ravel()[interior]])
    centre = interior[np.argmin(np.abs(gy[0].ravel()[interior] - WIDTH / 2)
                                + np.abs(gz[0].ravel()[interior] - WIDTH / 2))]
    j_centre = int(np.flatnonzero(interior == centre)[0])
    p_end = nu + (nx - 1) * ny * nz + (ny // 2) * nz + nz // 2  # far end, centre
    return FEModel(
        M=M, K=K, D=D, nodes=np.vstack([p_nodes, m_nodes]),
        dof_node=np.concatenate([m_ids, np.arange(npr) + 1]),
        dof_kind=np.array(["ux"] * nu + ["p"] * npr),
        inputs={"f_membrane": ((j_centre, 1.0),)},
        outputs={"p_end": ((p_end, 1.0),)},
        kind="up-coupled", density=RHO_AIR, name=f"tube-{nx}x{ny}x{nz}",
    )


def krylov_points(count: int = 8) -> np.ndarray:
    """Real expansion points s0 = 2π f, f log-spaced across the band.

    Real points keep every factorization real: a complex LU of this model takes ~20 s
    (real 2n×2n form) against ~3 s for a real one, which would dominate both reductors.
    """
    return 2 * np.pi * np.geomspace(200.0, F_MAX, count)


def peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: kB


# ---------------------------------------------------------------------- workers
def work_ours(grid, method: str, out: Path) -> dict:
    from neweul_py.elastic import reduce_krylov, reduce_modal, save_reduced_body

    t0 = time.perf_counter()
    fe = build_model(*grid)
    t_build = time.perf_counter() - t0
    t0 = time.perf_counter()
    if method == "modal":
        body = reduce_modal(fe, modes=50, static_correction=True)
    elif method == "krylov":
        body = reduce_krylov(fe, points=krylov_points(), order=1)
    else:  # "krylov6": same points, 6 moments each side (r = 48)
        body = reduce_krylov(fe, points=krylov_points(), order=6)
    t_red = time.perf_counter() - t0
    save_reduced_body(body, out)
    return {"n_dofs": fe.n_dofs, "order": body.order, "build_s": t_build, "reduce_s": t_red,
            "peak_mb": peak_mb()}


def work_pymor(grid, out: Path) -> dict:
    try:
        from pymor.models.iosys import SecondOrderModel
        from pymor.reductors.interpolation import SOBHIReductor
    except ImportError:
        return {"missing": True}
    t0 = time.perf_counter()
    fe = build_model(*grid)
    t_build = time.perf_counter() - t0
    t0 = time.perf_counter()
    fom = SecondOrderModel.from_matrices(fe.M.tocsc(), fe.D.tocsc(), fe.K.tocsc(), fe.B(),
                                         fe.C())
    sigma = krylov_points()
    r = sigma.size
    rom = SOBHIReductor(fom).reduce(sigma, np.ones((r, 1)), np.ones((r, 1)))
    t_red = time.perf_counter() - t0
    f = np.linspace(F_MAX / N_FREQ, F_MAX, N_FREQ)
    Mr, Er, Kr = (getattr(rom, k).matrix for k in ("M", "E", "K"))
    Br, Cr = rom.B.matrix, rom.Cp.matrix
    np.savez(out, M=Mr, D=Er, K=Kr, B=Br, C=Cr, f=f)
    return {"n_dofs": fe.n_dofs, "order": rom.order, "build_s": t_build, "reduce_s": t_red,
            "peak_mb": peak_mb()}


def work_frf(grid, bodies: list[str], full_points: int) -> dict:
    from neweul_py.elastic import frf_full, frf_reduced, relative_error
    from neweul_py.elastic.io.body_files import load_reduced_body

    fe = build_model(*grid)
    f = np.linspace(F_MAX / N_FREQ, F_MAX, N_FREQ)
    res: dict = {}
    for path in bodies:
        if path.endswith(".pymor.npz"):
            z = np.load(path)
            w = 2 * np.pi * f[:, None, None]
            t0 = time.perf_counter()
            A = z["K"][None] + 1j * w * z["D"][None] - w**2 * z["M"][None]
            H = z["C"] @ np.linalg.solve(A, np.broadcast_to(z["B"], (f.size, *z["B"].shape)))
        else:
            body = load_reduced_body(path)
            t0 = time.perf_counter()
            H = frf_reduced(body, f)
        res[path] = {"time_s": time.perf_counter() - t0, "H": H}
    idx = np.unique(np.linspace(0, N_FREQ - 1, full_points).round().astype(int))
    t0 = time.perf_counter()
    H_full = frf_full(fe, f[idx])
    t_full = time.perf_counter() - t0
    out = {"full_points": int(idx.size), "full_s_per_freq": t_full / idx.size,
           "full_s_1000_extrapolated": t_full / idx.size * N_FREQ, "reduced": {}}
    for path, r in res.items():
        err = relative_error(H_full, r["H"][idx])
        out["reduced"][path] = {"time_s_1000": r["time_s"], "max_rel_error": float(err.max()),
                                "median_rel_error": float(np.median(err)),
                                "max_rel_error_below_2kHz": float(err[f[idx] <= 2000].max())}
    return out


# ---------------------------------------------------------------------- driver
def _run_worker(python: str, args: list[str]) -> dict:
    cmd = [python, str(Path(__file__).resolve()), *args]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        print(proc.stderr[-3000:], file=sys.stderr)
        raise SystemExit(f"worker failed: {' '.join(args)}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", type=int, nargs=3, default=(1000, 10, 10),
                    metavar=("NX", "NY", "NZ"))
    ap.add_argument("--full-points", type=int, default=8,
                    help="frequencies of the 1000 at which the full model is solved")
    ap.add_argument("--pymor-python", default=sys.executable,
                    help="interpreter with pymor installed (default: this one)")
    ap.add_argument("--workdir", default="benchmarks/_out")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("--out", help=argparse.SUPPRESS)
    ap.add_argument("--bodies", nargs="*", default=[], help=argparse.SUPPRESS)
    args = ap.parse_args()
    grid = tuple(args.grid)
    if args.worker:
        if args.worker in ("modal", "krylov", "krylov6"):
            res = work_ours(grid, args.worker, Path(args.out))
        elif args.worker == "pymor":
            res = work_pymor(grid, Path(args.out))
        else:
            res = work_frf(grid, args.bodies, args.full_points)
        print(json.dumps(res))
        return

    work = Path(args.workdir)
    work.mkdir(parents=True, exist_ok=True)
    g = [str(x) for x in grid]
    print(f"model: u–p tube {grid[0]}×{grid[1]}×{grid[2]} + membrane, "
          f"{os.cpu_count()} cores", flush=True)
    modal = _run_worker(sys.executable, ["--worker", "modal", "--grid", *g,
                                         "--out", str(work / "modal.npz")])
    print(f"reduce_modal (two-sided, 50 modes + static correction) of {modal['n_dofs']} DOFs: "
          f"{modal['reduce_s']:.1f} s (model build {modal['build_s']:.1f} s), "
          f"peak RSS {modal['peak_mb']:.0f} MB  [target < 120 s, < 4096 MB]", flush=True)
    kry = _run_worker(sys.executable, ["--worker", "krylov", "--grid", *g,
                                       "--out", str(work / "krylov.npz")])
    print(f"reduce_krylov (two-sided, 8 real points, order 1, r = {kry['order']}): "
          f"{kry['reduce_s']:.1f} s, peak RSS {kry['peak_mb']:.0f} MB", flush=True)
    kry6 = _run_worker(sys.executable, ["--worker", "krylov6", "--grid", *g,
                                        "--out", str(work / "krylov6.npz")])
    print(f"reduce_krylov (two-sided, 8 real points, order 6, r = {kry6['order']}): "
          f"{kry6['reduce_s']:.1f} s, peak RSS {kry6['peak_mb']:.0f} MB", flush=True)
    bodies = [str(work / "modal.npz"), str(work / "krylov.npz"), str(work / "krylov6.npz")]
    pym = _run_worker(args.pymor_python, ["--worker", "pymor", "--grid", *g,
                                          "--out", str(work / "sobhi.pymor.npz")])
    if pym.get("missing"):
        print("pyMOR not installed: `pip install pymor` (or --pymor-python PATH) to compare "
              "with its SOBHIReductor")
    else:
        bodies.append(str(work / "sobhi.pymor.npz"))
        print(f"pyMOR SOBHIReductor (same points, r = {pym['order']}): "
              f"{pym['reduce_s']:.1f} s, peak RSS {pym['peak_mb']:.0f} MB", flush=True)
        print(f"ratio time pyMOR / ours (Krylov): {pym['reduce_s'] / kry['reduce_s']:.2f}; "
              f"peak RSS ratio: {pym['peak_mb'] / kry['peak_mb']:.2f}")
    frf = _run_worker(sys.executable, ["--worker", "frf", "--grid", *g, "--full-points",
                                       str(args.full_points), "--bodies", *bodies])
    print(f"full FRF: {frf['full_s_per_freq']:.2f} s per frequency ({frf['full_points']} "
          f"solved), ≈ {frf['full_s_1000_extrapolated']:.0f} s for {N_FREQ} (extrapolated)")
    for path, r in frf["reduced"].items():
        name = Path(path).name
        print(f"  {name:18s} reduced FRF at {N_FREQ} frequencies: {r['time_s_1000'] * 1e3:.1f} "
              f"ms, speed-up ×{frf['full_s_1000_extrapolated'] / r['time_s_1000']:.0f}; "
              f"relative error max {r['max_rel_error']:.2e} (≤ 2 kHz: "
              f"{r['max_rel_error_below_2kHz']:.2e}), median {r['median_rel_error']:.2e}")


if __name__ == "__main__":
    main()
