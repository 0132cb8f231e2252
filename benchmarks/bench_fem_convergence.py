"""Mesh convergence of the FE elements of ``neweul_py.fem`` against closed-form results.

Run::

    python benchmarks/bench_fem_convergence.py            # all studies (≈ 3–4 min)
    python benchmarks/bench_fem_convergence.py --quick    # coarser levels only

Each study prints the result per mesh level, the relative error to the closed form and the
observed order of convergence ``log2(e_{k-1} / e_k)`` (mesh size halves per level). Studies:
rigid box and closed duct resonances, clamped plate frequencies and centre deflection, Hencky's
membrane deflection, piston closing a tube, middle ear. The
middle-ear study prints the static volume displacement at ±4 kPa and the first coupled TM
frequency per refinement level (no closed form: self-convergence).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla
from scipy.optimize import brentq

from neweul_py.fem.acoustic import acoustic_matrices
from neweul_py.fem.coupling import assemble_up, coupling_matrix
from neweul_py.fem.mesh import box_tets, cone_membrane, extrude_tets
from neweul_py.fem.nonlinear import NewtonOptions, load_path
from neweul_py.fem.shell import ShellMaterial, ShellStructure
from neweul_py.middle_ear.model import build_middle_ear
from neweul_py.middle_ear.static import solve_static, static_summary
from neweul_py.middle_ear.working_point import working_point_model

C_AIR, RHO = 343.0, 1.2


def _table(title: str, rows: list[tuple[str, float, float]], unit: str = "") -> None:
    print(f"\n{title}")
    print(f"  {'mesh':>22s} {'value':>14s} {'rel. error':>11s} {'order':>6s}")
    prev = None
    for label, value, ref in rows:
        err = abs(value - ref) / abs(ref)
        order = f"{math.log2(prev / err):6.2f}" if prev and err > 0 else "     -"
        print(f"  {label:>22s} {value:14.6g} {err:11.3e} {order}  {unit}")
        prev = err


def box(levels: list[int]) -> None:
    lx, ly, lz = 0.5, 0.3, 0.2
    ref = C_AIR / 2 * math.sqrt((1 / lx) ** 2 + (1 / ly) ** 2)  # mode (1,1,0)
    ref1 = C_AIR / (2 * lx)
    rows, rows1 = [], []
    for k in levels:
        n = 2**k
        mf, kf = acoustic_matrices(box_tets((lx, ly, lz), (5 * n, 3 * n, 2 * n)), C_AIR)
        w = np.sort(spla.eigsh(kf, M=mf, k=6, sigma=-1.0, which="LM")[0])
        f = np.sqrt(np.abs(w)) / (2 * math.pi)
        rows1.append((f"{5 * n}x{3 * n}x{2 * n}", f[1], ref1))
        rows.append((f"{5 * n}x{3 * n}x{2 * n}", f[np.argmin(np.abs(f - ref))], ref))
    _table("rigid box 0.5x0.3x0.2 m, mode (1,0,0) = c/(2Lx) [Hz]", rows1, "Hz")
    _table("rigid box, mode (1,1,0) [Hz]", rows, "Hz")


def duct(levels: list[int]) -> None:
    """Rigid closed–closed cylindrical duct meshed like the ear canal (a disc triangulation
    extruded into prism layers split into tetrahedra): f_n = n c / (2 L)."""
    length, radius = 0.025, 0.00375  # the ear canal of the middle-ear model
    rows = {1: [], 2: [], 3: []}
    for k in levels:
        rings, nz = 2 * 2**k, 10 * 2**k
        disc = cone_membrane(radius, 0.0, rings)

        def morph(p, s):
            return p + np.array([0.0, 0.0, -s * length])

        mesh, _, _ = extrude_tets(disc.points, disc.triangles, nz, morph)
        mf, kf = acoustic_matrices(mesh, C_AIR)
        w = np.sort(spla.eigsh(kf, M=mf, k=4, sigma=-1.0, which="LM")[0])
        f = np.sqrt(np.abs(w)) / (2 * math.pi)
        for n in rows:
            rows[n].append((f"{rings} rings x {nz} layers", f[n], n * C_AIR / (2 * length)))
    for n, r in rows.items():
        _table(f"closed duct L = 25 mm, r = 3.75 mm, mode {n}: n c/(2L) [Hz]", r, "Hz")


def _plate(a: float, mat: ShellMaterial, rings: int):
    mesh = cone_membrane(a, 0.0, rings)
    shell = ShellStructure.create(mesh.points, mesh.triangles, mat)
    free = np.ones(shell.n_dof, bool)
    free[(3 * mesh.boundary[:, None] + np.arange(3)).ravel()] = False
    fi = np.flatnonzero(free)

    def residual(uf, load):
        u = np.zeros(shell.n_dof)
        u[fi] = uf
        _, f, k = shell.membrane(u)
        _, g, kp = shell.pressure(u, load)
        r = (f + shell.bending @ u - g)[fi]
        return r, (k + shell.bending + kp)[fi][:, fi], np.linalg.norm(g)

    return shell, fi, residual


def plate(levels: list[int]) -> None:
    a = 0.1
    mat = ShellMaterial(E=70e9, nu=0.3, t=0.002, rho=2700)
    d = mat.bending_stiffness
    rows_f, rows_f2, rows_w = [], [], []
    for k in levels:
        rings = 4 * 2**k
        shell, fi, residual = _plate(a, mat, rings)
        kk = (shell.membrane(np.zeros(shell.n_dof))[2] + shell.bending)[fi][:, fi]
        m = shell.mass()[fi][:, fi]
        z = fi % 3 == 2
        w = np.sort(spla.eigsh(kk[z][:, z], M=m[z][:, z], k=3, sigma=0, which="LM")[0])
        lam2 = np.sqrt(w) * a**2 / math.sqrt(d / (mat.rho * mat.t))
        rows_f.append((f"{rings} rings", lam2[0], 10.2158))
        rows_f2.append((f"{rings} rings", lam2[1], 21.260))
        p = 10.0
        (st,) = load_path(residual, fi.size, [p], NewtonOptions(first_step=p))
        w0 = st.u[np.flatnonzero((fi // 3 == 0) & (fi % 3 == 2))[0]]
        rows_w.append((f"{rings} rings", w0, p * a**4 / (64 * d)))
    _table("clamped circular plate, λ² of mode 1 (Leissa: 10.2158)", rows_f)
    _table("clamped circular plate, λ² of mode 2 (Leissa: 21.260)", rows_f2)
    _table("clamped plate, centre deflection vs p a⁴/(64 D)", rows_w, "m")


def hencky(levels: list[int]) -> None:
    a, p = 0.1, 100.0
    mat = ShellMaterial(E=1e7, nu=0.3, t=1e-4, rho=1000)
    ref = 0.662 * a * (p * a / (mat.E * mat.t)) ** (1 / 3)
    rows = []
    for k in levels:
        rings = 4 * 2**k
        _, fi, residual = _plate(a, mat, rings)
        opts = NewtonOptions(first_step=1.0, max_step=100.0, min_step=1e-3)
        (st,) = load_path(residual, fi.size, [p], opts)
        w0 = st.u[np.flatnonzero((fi // 3 == 0) & (fi % 3 == 2))[0]]
        rows.append((f"{rings} rings", w0, ref))
    _table(
        "large deflection, membrane regime: w0 vs Hencky 0.662 a (pa/Et)^(1/3) "
        "(Hencky's series; error floor ≈ bending + finite-rotation effects)",
        rows,
        "m",
    )


def piston(levels: list[int]) -> None:
    length, width, mass, stiffness = 0.1, 0.01, 1e-3, 2e3
    s = width**2

    def char(w):
        kk = w / C_AIR
        return (stiffness - mass * w**2) * kk * math.sin(kk * length) + RHO * s * w**2 * math.cos(
            kk * length
        )

    grid = np.linspace(1.0, 2.2 * math.pi * C_AIR / length, 3000)
    vals = [char(w) for w in grid]
    roots = [
        brentq(char, a, b)
        for a, b, fa, fb in zip(grid[:-1], grid[1:], vals[:-1], vals[1:], strict=True)
        if np.sign(fa) != np.sign(fb)
    ]
    ref = np.array(roots[:2]) / (2 * math.pi)
    rows0, rows1 = [], []
    for k in levels:
        nz = 10 * 2**k
        mesh = box_tets((width, width, length), (1, 1, nz))
        mf, kf = acoustic_matrices(mesh, C_AIR)
        face = np.flatnonzero(np.abs(mesh.points[:, 2]) < 1e-12)
        loc = -np.ones(mesh.points.shape[0], dtype=int)
        loc[face] = np.arange(face.size)
        tri = []
        for f in ([0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]):
            t = mesh.tets[:, f]
            tri.append(t[np.all(loc[t] >= 0, axis=1)])
        tri = loc[np.vstack(tri)]
        xs = mesh.points[face]
        nrm = np.cross(xs[tri[:, 1]] - xs[tri[:, 0]], xs[tri[:, 2]] - xs[tri[:, 0]])
        tri[nrm[:, 2] < 0] = tri[nrm[:, 2] < 0][:, [0, 2, 1]]
        cn = coupling_matrix(xs, tri, np.arange(face.size), face, face.size, mf.shape[0], -1.0)
        t = sps.csr_matrix(
            (np.ones(face.size), (3 * np.arange(face.size) + 2, np.zeros(face.size))),
            shape=(3 * face.size, 1),
        )
        m, _, kk = assemble_up(
            sps.csr_matrix([[mass]]), sps.csr_matrix([[stiffness]]), mf, kf, (t.T @ cn), RHO
        )
        lam = np.sort(np.linalg.eigvals(np.linalg.solve(m.toarray(), kk.toarray())).real)
        f = np.sqrt(lam[1:3]) / (2 * math.pi)
        rows0.append((f"nz = {nz}", f[0], ref[0]))
        rows1.append((f"nz = {nz}", f[1], ref[1]))
    _table("piston (m, k) closing a rigid tube: coupled mode 1 [Hz]", rows0, "Hz")
    _table("piston closing a rigid tube: coupled mode 2 [Hz]", rows1, "Hz")


def middle_ear(levels: list[int]) -> None:
    print(
        "\nmiddle ear (self-convergence): refine, DOFs, ΔV(−4 kPa), ΔV(+4 kPa) [mm³], "
        "umbo u_z(+4 kPa) [µm], first coupled TM frequency at 0 / +4 kPa [Hz], time [s]"
    )
    for level in levels:
        t0 = time.perf_counter()
        me = build_middle_ear(refine=level)
        states = solve_static(me, [-4000.0, 0.0, 4000.0])
        rows = [static_summary(me, s) for s in states]
        freqs = []
        for s in states[1:]:
            fe = working_point_model(me, s)
            sigma = -((2 * math.pi * 100.0) ** 2)
            lu = spla.splu((fe.K - sigma * fe.M).tocsc())
            op = spla.LinearOperator(fe.K.shape, matvec=lambda x, lu=lu, fe=fe: lu.solve(fe.M @ x))
            mu = spla.eigs(op, k=6, which="LM", return_eigenvectors=False)
            lam = np.sort((sigma + 1.0 / mu).real)
            freqs.append(math.sqrt(lam[2]) / (2 * math.pi))
        print(
            f"  L={level}  {me.dof_counts()['total']:7d}"
            f"  {rows[0]['volume_displacement_m3'] * 1e9:8.4f}"
            f"  {rows[2]['volume_displacement_m3'] * 1e9:8.4f}  {rows[2]['umbo_uz_m'] * 1e6:8.3f}"
            f"  {freqs[0]:8.1f} / {freqs[1]:8.1f}  {time.perf_counter() - t0:6.1f}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="coarser levels only")
    args = parser.parse_args()
    levels = [0, 1, 2] if args.quick else [0, 1, 2, 3]
    box(levels[:3])
    duct(levels)
    plate(levels)
    hencky(levels[:3])
    piston([*levels, 4])
    middle_ear([0, 1] if args.quick else [0, 1, 2])


if __name__ == "__main__":
    main()
