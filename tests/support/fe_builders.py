"""Small FE models for the elastic tests, built from vectorized 1-D linear elements.

* :func:`duct` – closed–closed 1-D acoustic duct (pressure DOFs), resonances ``n c / 2L``;
* :func:`piston_duct` – a spring–mass piston closing one end of a duct, u–p coupled after
  Eq. (2) of ``docs/equations.md`` §3 (unsymmetric);
* :func:`membrane_cavity` – a light string "membrane" closing a rigid 2-D air cavity, u–p
  coupled after Eq. (2), SI units (a middle-ear-like mix of magnitudes);
* :func:`random_up` – a random sparse u–p model with the block structure of Eq. (2);
* :func:`spring_chain` – a fixed–free chain of springs and masses (structural, symmetric).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.optimize as so
import scipy.sparse as sps

from neweul_py.elastic import FEModel


def line_matrices(n_el: int, length: float) -> tuple[sps.csr_matrix, sps.csr_matrix]:
    """Consistent mass ``∫NᵀN`` and stiffness ``∫N'ᵀN'`` of linear elements on [0, L]."""
    h = length / n_el
    me = h / 6 * np.array([[2.0, 1.0], [1.0, 2.0]])
    ke = 1 / h * np.array([[1.0, -1.0], [-1.0, 1.0]])
    conn = np.stack([np.arange(n_el), np.arange(1, n_el + 1)], axis=1)  # (ne, 2)
    rows = np.repeat(conn, 2, axis=1).ravel()
    cols = np.tile(conn, (1, 2)).ravel()
    n = n_el + 1
    M = sps.csr_matrix((np.tile(me.ravel(), n_el), (rows, cols)), shape=(n, n))
    K = sps.csr_matrix((np.tile(ke.ravel(), n_el), (rows, cols)), shape=(n, n))
    return M, K


def duct(n_el: int = 200, length: float = 1.0, c: float = 343.0) -> FEModel:
    """Closed–closed acoustic duct: ``Mf = ∫NᵀN/c²``, ``Kf = ∫N'ᵀN'`` (unit area)."""
    Mf, Kf = line_matrices(n_el, length)
    n = n_el + 1
    x = np.linspace(0.0, length, n)
    nodes = np.column_stack([np.arange(1, n + 1), x, np.zeros(n), np.zeros(n)])
    return FEModel(M=Mf / c**2, K=Kf, D=None, nodes=nodes, dof_node=np.arange(1, n + 1),
                   dof_kind=np.full(n, "p"), inputs={"q0": ((0, 1.0),)},
                   outputs={"p_end": ((n - 1, 1.0),)}, kind="acoustic",
                   symmetric={"M": True, "K": True}, name="duct")


def piston_duct(n_el: int = 200, length: float = 1.0, c: float = 343.0, rho: float = 1.2,
                mass: float = 0.05, stiffness: float = 2.0e5, damping: float = 0.0,
                area: float = 1.0) -> FEModel:
    """Spring–mass piston (DOF 0, ``ux``) closing the duct at x = 0, rigid end at x = L.

    Eq. (2): ``[m 0; ρCᵀ Mf] ẍ + [k −C; 0 Kf] x = f`` with ``C = −A e₀`` (the interface
    normal points out of the fluid, i.e. along −x, into the piston).
    """
    Mf, Kf = line_matrices(n_el, length)
    Mf, Kf = area * Mf / c**2, area * Kf
    npr = n_el + 1
    Cc = sps.csr_matrix(([-area], ([0], [0])), shape=(1, npr))
    M = sps.bmat([[sps.csr_matrix([[mass]]), None], [rho * Cc.T, Mf]], format="csr")
    K = sps.bmat([[sps.csr_matrix([[stiffness]]), -Cc], [None, Kf]], format="csr")
    D = None
    if damping:
        D = sps.csr_matrix(([damping], ([0], [0])), shape=(npr + 1, npr + 1))
    x = np.linspace(0.0, length, npr)
    nodes = np.column_stack([np.arange(1, npr + 1), x, np.zeros(npr), np.zeros(npr)])
    dof_node = np.concatenate([[1], np.arange(1, npr + 1)])
    dof_kind = np.array(["ux"] + ["p"] * npr)
    return FEModel(M=M, K=K, D=D, nodes=nodes, dof_node=dof_node, dof_kind=dof_kind,
                   inputs={"force": ((0, 1.0),)},
                   outputs={"p_end": ((npr, 1.0),), "x_piston": ((0, 1.0),)},
                   kind="up-coupled", density=rho, name="piston-duct")


def membrane_cavity(tension: float, n_x: int = 24, n_z: int = 16, width: float = 8e-3,
                    thickness: float = 7.5e-3, depth: float = 0.025, mass: float = 1.5e-5,
                    c: float = 343.0, rho: float = 1.2, damping: float = 2e-5) -> FEModel:
    """A pre-tensioned string (``uz`` DOFs, fixed ends) along the edge ``z = 0`` of a
    rigid-walled 2-D air cavity ``width × depth`` (out-of-plane ``thickness``), SI units.

    Structure: ``T ∫N'ᵀN'`` and ``μ ∫NᵀN`` (tension ``T`` in N, ``μ = mass / width``) on
    the ``n_x − 1`` interior nodes; fluid: bilinear (tensor-product) ``Mf = t ∫NᵀN / c²``,
    ``Kf = t ∫∇Nᵀ∇N``; coupling ``C = −t ∫ N_sᵀ N_f`` along the shared edge, Eq. (2)
    ``[Ms 0; ρCᵀ Mf] ẍ + [Ks −C; 0 Kf] x = f``. Stiffness-proportional structural damping
    ``damping · Ks``. Every string mode radiates into the cavity, so in unit-norm mode
    shapes the displacements are ~1e-6 of the pressures (Pa vs m), as in the middle ear.
    Input ``force`` and output ``umbo`` at the string node at a third of the width, output
    ``probe`` (pressure) at the far wall.
    """
    Mx, Kx = line_matrices(n_x, width)
    Mz, Kz = line_matrices(n_z, depth)
    inner = slice(1, n_x)
    n_s, nxp, nzp = n_x - 1, n_x + 1, n_z + 1
    Ms = (mass / width * Mx)[inner][:, inner]
    Ks = (tension * Kx)[inner][:, inner]
    Mf = thickness * sps.kron(Mx, Mz) / c**2
    Kf = thickness * (sps.kron(Kx, Mz) + sps.kron(Mx, Kz))
    npr = nxp * nzp                                  # fluid node (i, j) → i·nzp + j
    edge = (thickness * Mx)[inner].tocoo()
    Cc = sps.csr_matrix((-edge.data, (edge.row, edge.col * nzp)), shape=(n_s, npr))
    M = sps.bmat([[Ms, None], [rho * Cc.T, Mf]], format="csr")
    K = sps.bmat([[Ks, -Cc], [None, Kf]], format="csr")
    D = sps.bmat([[damping * Ks, None], [None, sps.csr_matrix((npr, npr))]], format="csr")
    n = n_s + npr
    xg, zg = np.linspace(0, width, nxp), np.linspace(0, depth, nzp)
    X, Z = np.meshgrid(xg, zg, indexing="ij")
    nodes = np.column_stack([np.arange(1, n + 1), np.concatenate([xg[1:-1], X.ravel()]),
                             np.zeros(n), np.concatenate([np.zeros(n_s), Z.ravel()])])
    umbo, probe = n_s // 3, n_s + (nxp // 3) * nzp + n_z
    return FEModel(M=M, K=K, D=D, nodes=nodes, dof_node=np.arange(1, n + 1),
                   dof_kind=np.array(["uz"] * n_s + ["p"] * npr),
                   inputs={"force": ((umbo, 1.0),)},
                   outputs={"umbo": ((umbo, 1.0),), "probe": ((probe, 1.0),)},
                   kind="up-coupled", density=rho, name="membrane-cavity")


def piston_duct_frequencies(count: int, length: float = 1.0, c: float = 343.0,
                            rho: float = 1.2, mass: float = 0.05, stiffness: float = 2.0e5,
                            area: float = 1.0) -> np.ndarray:
    """Closed-form coupled frequencies (Hz): roots of the transcendental equation

    ``k sin(kL) (k_s − m ω²) + ρ A ω² cos(kL) = 0``, ``k = ω / c``,

    from ``p = P cos k(L − x)`` (rigid end), ``∂p/∂x(0) = ρ ω² U`` (momentum at the piston)
    and ``(k_s − mω²) U + A p(0) = 0`` (piston). The trivial root ω = 0 is excluded.
    """
    def g(w: float) -> float:
        k = w / c
        return k * np.sin(k * length) * (stiffness - mass * w**2) + rho * area * w**2 * np.cos(
            k * length)

    w = np.linspace(1e-3, 2 * np.pi * c / length * (count + 2), 200_000)
    v = g(w)
    idx = np.flatnonzero(np.sign(v[:-1]) * np.sign(v[1:]) < 0)
    roots = [so.brentq(g, w[i], w[i + 1], xtol=1e-14, rtol=1e-15) for i in idx[:count]]
    return np.asarray(roots) / (2 * np.pi)


def _spd(n: int, density: float, rng: np.random.Generator) -> sps.csr_matrix:
    R = sps.random(n, n, density=density, random_state=rng, format="csr")
    return sps.csr_matrix(R @ R.T + sps.diags(1.0 + rng.random(n)))


def random_up(nu: int = 60, npr: int = 80, rho: float = 2.5, seed: int = 0,
              damping: float = 0.0) -> FEModel:
    """A random sparse u–p model with the block structure of Eq. (2).

    ``Ks, Ms, Kf, Mf`` symmetric positive definite (random sparse ``R Rᵀ + diag``), random
    sparse coupling ``C``; ``M = [Ms 0; ρCᵀ Mf]``, ``K = [Ks −C; 0 Kf]``. The u and p DOFs
    are interleaved by a random permutation, so the code must use the DOF map.
    """
    rng = np.random.default_rng(seed)
    Ks, Ms = _spd(nu, 0.05, rng), _spd(nu, 0.05, rng)
    Kf, Mf = _spd(npr, 0.05, rng), _spd(npr, 0.05, rng)
    Cc = sps.random(nu, npr, density=0.05, random_state=rng, format="csr")
    M = sps.bmat([[Ms, None], [rho * Cc.T, Mf]], format="csr")
    K = sps.bmat([[Ks, -Cc], [None, Kf]], format="csr")
    D = None
    if damping:
        D = sps.bmat([[damping * Ks, None], [None, damping * Kf]], format="csr")
    n = nu + npr
    perm = rng.permutation(n)
    M, K = M[perm][:, perm], K[perm][:, perm]
    D = D[perm][:, perm] if D is not None else None
    kind = np.array(["uz"] * nu + ["p"] * npr)[perm]
    node = np.arange(1, n + 1)
    nodes = np.column_stack([node, rng.random((n, 3))])
    iu = int(np.flatnonzero(kind == "uz")[0])
    ip = int(np.flatnonzero(kind == "p")[-1])
    return FEModel(M=M, K=K, D=D, nodes=nodes, dof_node=node, dof_kind=kind,
                   inputs={"f": ((iu, 1.0),)}, outputs={"p": ((ip, 1.0),)},
                   kind="up-coupled", density=rho, name=f"random-up-{seed}")


def spring_chain(n: int = 100, k: float = 1.0e4, m: float = 0.1, damping: float = 0.0
                 ) -> FEModel:
    """Fixed–free chain of n equal masses and springs (``ux`` DOFs), force and output at the tip."""
    main = np.full(n, 2 * k)
    main[-1] = k
    K = sps.diags([main, -k * np.ones(n - 1), -k * np.ones(n - 1)], [0, 1, -1], format="csr")
    M = sps.diags(np.full(n, m), format="csr")
    D = damping * K if damping else None
    nodes = np.column_stack([np.arange(1, n + 1), np.arange(1, n + 1.0), np.zeros(n),
                             np.zeros(n)])
    return FEModel(M=M, K=K, D=D, nodes=nodes, dof_node=np.arange(1, n + 1),
                   dof_kind=np.full(n, "ux"), inputs={"tip": ((n - 1, 1.0),)},
                   outputs={"tip": ((n - 1, 1.0),), "mid": ((n // 2, 1.0),)},
                   symmetric={"M": True, "K": True}, name="chain")


def twin(fe: FEModel, seed: int = 1) -> FEModel:
    """Two identical, uncoupled copies of ``fe`` with their DOFs interleaved at random.

    Every eigenvalue of ``fe`` is a double one of the twin (exactly, up to the round-off of
    the factorization), so the reductors meet degenerate clusters of an unsymmetric pencil:
    two-fold pairs, and for a closed cavity a two-fold ``λ = 0``. Inputs and outputs are
    those of the first copy.
    """
    n = fe.n_dofs
    rng = np.random.default_rng(seed)
    perm = rng.permutation(2 * n)
    where = np.argsort(perm)                    # old index → new index

    def double(A):
        return None if A is None else sps.block_diag([A, A], format="csr")[perm][:, perm]

    nid = fe.nodes[:, 0].astype(np.int64)
    off = int(nid.max())
    nodes = np.vstack([fe.nodes, np.column_stack([nid + off, fe.nodes[:, 1:] + 10.0])])
    dof_node = np.concatenate([fe.dof_node, fe.dof_node + off])[perm]
    dof_kind = np.concatenate([fe.dof_kind, fe.dof_kind])[perm]

    def moved(table):
        return {k: tuple((int(where[i]), w) for i, w in v) for k, v in table.items()}

    return FEModel(M=double(fe.M), K=double(fe.K), D=double(fe.D), nodes=nodes,
                   dof_node=dof_node, dof_kind=dof_kind, inputs=moved(fe.inputs),
                   outputs=moved(fe.outputs), kind=fe.kind, density=fe.density,
                   name=f"twin-{fe.name}")


def piston_duct_bodies(speeds: tuple[float, ...], n_el: int, modes: int) -> list:
    """Two-sided modal u–p piston ducts (``modes`` modes, the piston node kept, with bases and
    invariants) at the sound speeds ``speeds``: the samples of a parametric duct body."""
    from neweul_py.elastic import reduce_modal
    from neweul_py.elastic.reductors.invariants import attach_invariants

    bodies = []
    for c in speeds:
        fe = piston_duct(n_el=n_el, c=c)
        body = reduce_modal(fe, modes=modes, two_sided=True, keep_nodes=[1], store_bases=True)
        bodies.append(attach_invariants(body, fe, nodes=[1]))
    return bodies


def quintic_in_c_squared(hb):
    """A duct body with sample slopes made quintic: curvatures as differences of its slopes,
    weights in ``ξ = c²`` tabulated on 31 knots and the samples (equations.md §4.2)."""
    curv = {key: np.gradient(hb.slopes[key], hb.samples, axis=0, edge_order=1)
            for key in hb.slope_keys()}
    speeds = np.asarray(hb.samples, dtype=float)
    knots = np.unique(np.concatenate([np.linspace(speeds[0], speeds[-1], 31), speeds]))
    return hb.with_(interpolation="quintic-hermite", curvatures=curv,
                    coordinate=np.vstack([knots, knots**2]), coordinate_name="c_squared")


def parametric_ducts(out: Path, speeds: tuple[float, ...] = (300.0, 343.0, 390.0)) -> None:
    """Two-sided u–p piston ducts at the sound speeds ``speeds`` (6 modes), interpolated with
    cubic weights (``out/duct.npz``), with sample slopes and cubic Hermite weights
    (``duct_h.npz``) and with slopes and curvatures, quintic Hermite weights in ``ξ = c²``
    (``duct_q.npz``): parametric body files of every weight form; and the body of the
    samples' global basis (``duct_g.npz``, cubic weights), whose node rows do not depend on
    the sound speed."""
    from neweul_py.elastic.io.body_files import save_parametric_body
    from neweul_py.elastic.parametric.global_basis import global_parametric_body
    from neweul_py.elastic.parametric.local_interpolation import interpolate

    bodies = piston_duct_bodies(speeds, n_el=40, modes=6)
    save_parametric_body(global_parametric_body([piston_duct(n_el=40, c=c) for c in speeds],
                                                bodies, speeds, parameter="c"),
                         out / "duct_g.npz")
    pb = interpolate(bodies, list(speeds), parameter="c")
    save_parametric_body(pb, out / "duct.npz")
    slopes = {key: np.gradient(pb.stack(key), pb.samples, axis=0, edge_order=1)
              * (0.0 if key.endswith("residual") else 1.0) for key in pb.slope_keys()}
    hb = pb.with_(interpolation="hermite", slopes=slopes)
    save_parametric_body(hb, out / "duct_h.npz")
    save_parametric_body(quintic_in_c_squared(hb), out / "duct_q.npz")
