"""The equations of one elastic body in the floating frame of reference (equations.md §2).

In the components of the reference frame K, with ``a``, ``α``, ``ω`` its acceleration,
angular acceleration and angular velocity and ``q`` the elastic coordinates::

    M_b(q) [a; α; q̈] + h_ω(q, q̇, ω) + [0; 0; Ke q + De q̇ + kσ] = h_applied

    M_b(q) = [ m I    m̃dᵀ   md¹  ]      h_ω = [ ω̃ω̃ md + 2 ω̃ md¹ q̇                 ]
             [ m̃d     J(q)  Crvᵀ ]            [ ω̃ J(q) ω + Σ_k Gr_k(q) q̇_k ω       ]
             [ Ct     Cr    Me   ]            [ Oe(q) ω_q + Σ_k Ge_k q̇_k ω          ]

with ``md(q) = md⁰ + md¹ q``, ``X(q) = X⁰ + X¹ q`` for ``Ct``, ``Cr``, ``Crv``, ``Oe`` and the
**second-order inertia** of §2.1 (``C2 = J.m2``)::

    J(q)    = J⁰ + J¹ q + Σ_kl q_k q_l C2[k, l]
    Gr_k(q) = Gr⁰_k + 2 Σ_l q_l C2[l, k]

With ``C2`` every term is the exact Newton–Euler sum over the FE mass points (for a mass
matrix whose translational node blocks are isotropic — solids, membranes, lumped masses),
so an undamped, undriven body conserves the energy ``½ zᵀ M_b z + ½ qᵀ Ke q`` exactly
(``z = [v; ω; q̇]``). Without it (``C2 = None``: SID data, or ``inertia: sid``) this is the SID
truncation (``J`` linear, ``Gr`` constant), whose missing terms make a flexible pendulum gain
energy and blow up with enough modes.

These functions are plain NumPy on arrays and are the **only** implementation of the body
equations: :mod:`neweul_py.elastic.bodies.invariants` evaluates bodies with them and the generated
modules embed their source verbatim (:mod:`neweul_py.codegen.elastic`). They accept complex
arrays (the generated Jacobians use the complex step). Names start with ``ffrf_`` because the
embedded copies share the generated module's namespace.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "KERNEL_FUNCTIONS",
    "ffrf_body_loads",
    "ffrf_body_mass",
    "ffrf_elastic_forces",
    "ffrf_first_moment",
    "ffrf_gyroscopic",
    "ffrf_kinetic_energy",
    "ffrf_linear_stack",
    "ffrf_loss_matrix",
    "ffrf_mass_blocks",
    "ffrf_omega_products",
    "ffrf_prepare",
    "ffrf_quadratic_map",
    "ffrf_rigid_map",
    "ffrf_skew",
    "ffrf_strain_energy",
    "ffrf_velocity_map",
    "ffrf_velocity_terms",
]


def ffrf_skew(v):
    """``ṽ`` with ``ṽ b = v × b`` for one 3-vector (real or complex)."""
    return np.array([[0.0 * v[0], -v[2], v[1]], [v[2], 0.0 * v[0], -v[0]],
                     [-v[1], v[0], 0.0 * v[0]]])


def ffrf_omega_products(w, head=None):
    """``ω_q = [ωx², ωy², ωz², ωxωy, ωyωz, ωxωz]`` (the column order of ``Oe``); the six
    products of Python scalars (``tolist``: real, complex or the objects of an object array),
    not of NumPy scalars. With ``head`` (a vector): ``[head; ω_q]`` as one array."""
    x, y, z = w.tolist()
    first = [] if head is None else head.tolist()
    return np.array([*first, x * x, y * y, z * z, x * y, y * z, x * z])


def ffrf_prepare(flat, inertia="consistent", fixed=False):
    """The kernel's working form of one body from its flat invariants (schema.py keys).

    Everything affine in ``q`` — ``md``, ``J⁰ + J¹ q``, ``[Ct Cr Oe]``, ``Crvᵀ`` and
    ``Σ_l q_l C2[l]`` — is stacked into one matrix ``T1`` (:func:`ffrf_linear_stack`) so
    that all of it follows from one product ``T0 + T1 q``; the rigid rows ``[Mrr | H]`` of
    ``M_b [acc; 0] + h_ω`` are one product ``P0 + P z`` (:func:`ffrf_rigid_map`) and the
    terms in ``q̇ ⊗ ω`` one of ``G`` (:func:`ffrf_velocity_map`): a call costs a few BLAS
    products, not one NumPy operation per block.

    Parameters
    ----------
    flat
        ``key → array`` (at least the required keys of :data:`neweul_py.ffrf.schema.SCHEMA`;
        missing order-1 parts are zero).
    inertia
        ``"consistent"`` (use ``J.m2`` when present) or ``"sid"`` (ignore it).
    fixed
        The body's frame never moves and it has no stiffening (``FIXED_ARRAYS`` suffice):
        only the elastic rows are kept (equations.md §2.2).

    Returns
    -------
    dict
        ``mass``, ``nq``, ``md0`` (3,), ``md1`` (3, nq), ``T0``, ``T1``, ``where`` (key →
        slice and shape in the stack; ``c2w`` only with second-order inertia), ``P0``,
        ``P`` (:func:`ffrf_rigid_map`), ``Me``, ``Gr``, ``Ge``, ``G``
        (:func:`ffrf_velocity_map`), ``ks`` (nq,), ``Ke``, ``De``, ``damped`` and
        ``prestressed`` (``De``, ``ks`` not all zero; not set for a fixed frame: true),
        and ``Le`` (the hysteretic matrix of ``K + iG``, equations.md §1.1) when the data
        hold ``Le.m0``.
    """
    nq = int(np.shape(flat["Me.m0"])[0])
    if fixed:
        md1 = flat.get("md.m1")
        return {"fixed": True, "mass": float(np.asarray(flat["m"])), "nq": nq,
                "consistent_stiffening": False,
                "md0": np.asarray(flat["md.m0"], dtype=np.float64)[:, 0],
                "md1": np.zeros((3, nq)) if md1 is None else
                np.asarray(md1, dtype=np.float64)[:, :, 0],
                "Ct0": np.asarray(flat["Ct.m0"], dtype=np.float64),
                "Me": np.asarray(flat["Me.m0"], dtype=np.float64),
                "Ke": np.asarray(flat["Ke.m0"], dtype=np.float64),
                "De": np.asarray(flat["De.m0"], dtype=np.float64),
                "ks": np.asarray(flat["ksigma.m0"], dtype=np.float64)[:, 0],
                **({"Le": np.asarray(flat["Le.m0"], dtype=np.float64)}
                   if "Le.m0" in flat else {})}
    md1 = flat.get("md.m1")
    md1 = np.zeros((3, nq)) if md1 is None else np.asarray(md1, dtype=np.float64)[:, :, 0]
    c2 = flat.get("J.m2") if inertia == "consistent" else None
    ct1 = flat.get("Ct.m1")
    stiff = (c2 is not None and ct1 is not None and np.any(ct1)
             and not bool(np.asarray(flat.get("two_sided", False))))
    T0, T1, where = ffrf_linear_stack(flat, nq, md1, c2)
    b = {
        "mass": float(np.asarray(flat["m"])),
        "nq": nq,
        "md0": np.asarray(flat["md.m0"], dtype=np.float64)[:, 0],
        "md1": md1,
        "T0": T0,
        "T1": T1,
        "where": where,
        "P0": np.kron(np.diag([1.0, 0.0]), np.eye(3, 6)).ravel() * float(np.asarray(flat["m"])),
        "P": ffrf_rigid_map(c2 is not None, bool(stiff)),
        "consistent_stiffening": bool(stiff),
        "Ct0": np.asarray(flat["Ct.m0"], dtype=np.float64),
        "Me": np.asarray(flat["Me.m0"], dtype=np.float64),
        "G": ffrf_velocity_map(md1, flat["Gr.m0"], flat["Ge.m0"]),
        "ks": np.asarray(flat["ksigma.m0"], dtype=np.float64)[:, 0],
        "Ke": np.asarray(flat["Ke.m0"], dtype=np.float64),
        "De": np.asarray(flat["De.m0"], dtype=np.float64),
    }
    if "Le.m0" in flat:
        b["Le"] = np.asarray(flat["Le.m0"], dtype=np.float64)
    b.update(damped=bool(np.any(b["De"])), prestressed=bool(np.any(b["ks"])))
    if inertia == "consistent" and "quad.A" in flat:
        # the second-order displacement field (equations.md §2.3): the body of the extended
        # basis [Φ, Y] in z = [q; y(q)], which carries the stiffening instead of Ct¹, Oe¹ …
        inner = {k[5:]: v for k, v in flat.items() if k.startswith("quad.") and k != "quad.A"}
        nz = int(np.shape(inner["Me.m0"])[0])
        inner.update({"m": flat["m"], "two_sided": False, "ksigma.m0": np.zeros((nz, 1)),
                      "Ke.m0": np.zeros((nz, nz)), "De.m0": np.zeros((nz, nz))})
        A = np.asarray(flat["quad.A"], dtype=np.float64)
        b.update(quad=ffrf_prepare(inner), consistent_stiffening=False,
                 A=np.ascontiguousarray(A.reshape(A.shape[0] * nq, nq)), ny=A.shape[0])
    return b


def ffrf_linear_stack(flat, nq, md1, c2):
    """``(T0, T1, where)``: the affine-in-``q`` quantities of a body as one stack,
    ``X = T0 + T1 q``, with ``where`` (key → start, stop, shape) for its blocks ``md`` (3,),
    ``J`` (3, 3, without the second-order part), ``E12`` (nq, 12) = ``[Ct Cr Oe]`` (row-major,
    so ``Mer`` and the elastic-row loads are views of one block), ``CrvT`` (3, nq) and, with
    ``c2`` (``J.m2``, (nq, nq, 3, 3)), ``c2w`` (3, nq, 3) with
    ``c2w[a, k, b] = 2 Σ_l q_l C2[l, k, a, b]`` (equations.md §2.1): ``q c2w = 2 J²(q)``
    and ``c2w (q̇ ⊗ ω) = 2 Σ_kl q̇_k q_l C2[l, k] ω``, the second-order part of ``Σ_k Gr_k q̇_k ω``."""

    def part(key, shape0):
        m0 = np.asarray(flat[key + ".m0"], dtype=np.float64).reshape(shape0)
        m1 = flat.get(key + ".m1")
        m1 = (np.zeros((*shape0, nq)) if m1 is None else        # m1[i, l, j] of m0[i, j]
              np.asarray(m1, dtype=np.float64).transpose(0, 2, 1).reshape(*shape0, nq))
        return m0, m1

    J0, J1 = part("J", (3, 3))
    e0, e1 = zip(*(part(k, (nq, c)) for k, c in (("Ct", 3), ("Cr", 3), ("Oe", 6))),
                 strict=True)
    v0, v1 = part("Crv", (nq, 3))
    blocks = [("md", np.asarray(flat["md.m0"], dtype=np.float64)[:, 0], md1),
              ("J", J0, J1), ("E12", np.hstack(e0), np.concatenate(e1, axis=1)),
              ("CrvT", v0.T, v1.transpose(1, 0, 2))]
    if c2 is not None:
        C2 = 2.0 * np.asarray(c2, dtype=np.float64).reshape(nq, nq, 3, 3).transpose(2, 1, 3, 0)
        blocks.append(("c2w", np.zeros((3, nq, 3)), C2))
    where, start, zeros, firsts = {}, 0, [], []
    for key, m0, m1 in blocks:
        where[key] = (start, start + m0.size, m0.shape)
        start += m0.size
        zeros.append(m0.ravel())
        firsts.append(m1.reshape(m0.size, nq))
    return np.concatenate(zeros), np.ascontiguousarray(np.vstack(firsts)), where


def ffrf_rigid_map(second, stiff):
    """``P`` (72, 12 + 9 + 3): the rigid rows of the body as ``K = [Mrr | H] = P0 + P z``
    (6×12 row-major), ``z = [md; J⁰ + J¹q; 2 J²(q) (with ``second``); s (with ``stiff``)]``,
    so that ``M_b [acc; 0] + h_ω`` has the rigid rows ``K [acc; ω_q] + …``:

    * ``Mrr[3:, :3] = m̃d (+ ½ s̃)``, ``Mrr[:3, 3:] = −m̃d``, ``Mrr[3:, 3:] = J`` (``P0``: the
      mass on the translational diagonal; ``s`` the prestress of :func:`ffrf_prestress`);
    * ``H ω_q = [ω̃ ω̃ md; ω̃ J ω]``, the quadratic velocity terms on the products ``ω_q``
      (:func:`ffrf_omega_products`), found by polarization of the unit vectors.

    All entries are 0, ±1 or ±½: each product is exact, and a row sums at most four of them."""
    skew = np.zeros((3, 3, 3))                # ṽ[i, j] = skew[i, j, k] v[k]
    skew[0, 1, 2], skew[0, 2, 1] = -1.0, 1.0
    skew[1, 0, 2], skew[1, 2, 0] = 1.0, -1.0
    skew[2, 0, 1], skew[2, 1, 0] = -1.0, 1.0
    P = np.zeros((6, 12, 24))
    P[3:, :3, 0:3] = skew
    P[:3, 3:6, 0:3] = -skew
    P[3:, 3:6, 3:12] = np.eye(9).reshape(3, 3, 9)
    P[3:, 3:6, 12:21] = 0.5 * np.eye(9).reshape(3, 3, 9)
    P[3:, :3, 21:24] = 0.5 * skew
    eye = np.eye(3)
    for j in range(12):                       # H for md = e_j, then J = E_j
        md, J = np.eye(12)[j, :3], np.eye(12)[j, 3:].reshape(3, 3)
        for c, (a, b) in enumerate(((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))):
            h = ffrf_gyroscopic(md, J, eye[a])
            if a != b:                        # the coefficient of ω_a ω_b
                h = ffrf_gyroscopic(md, J, eye[a] + eye[b]) - h - ffrf_gyroscopic(md, J, eye[b])
            P[:, 6 + c, j] = h
    P[:, 6:, 12:21] = 0.5 * P[:, 6:, 3:12]
    cols = [*range(12), *(range(12, 21) if second else ()), *(range(21, 24) if stiff else ())]
    return np.ascontiguousarray(P.reshape(72, 24)[:, cols])


def ffrf_gyroscopic(md, J, w):
    """``[ω̃ ω̃ md; ω̃ J ω]`` (6,): the terms of ``h_ω``'s rigid rows quadratic in ``ω``."""
    wt = ffrf_skew(w)
    return np.concatenate((wt @ (wt @ md), wt @ (J @ w)))


def ffrf_velocity_map(md1, Gr, Ge):
    """``G`` (6 + nq, 3 nq): the terms of ``h_ω`` linear in ``q̇ ⊗ ω`` (index ``3k + c``,
    ``np.outer(q̇, ω).ravel()``) with constant coefficients, ``[2 ω̃ md¹ q̇; Σ_k Gr⁰_k q̇_k ω;
    Σ_k Ge_k q̇_k ω]`` (module docstring): ``2 ω̃ md¹_k q̇_k = 2 q̇_k ω_c (e_c × md¹_k)``."""
    md1 = np.asarray(md1, dtype=np.float64)
    nq = md1.shape[1]
    top = np.zeros((3, nq, 3))
    for c in range(3):
        top[:, :, c] = 2.0 * (ffrf_skew(np.eye(3)[c]) @ md1)
    return np.vstack((top.reshape(3, 3 * nq), np.asarray(Gr, dtype=np.float64),
                      np.asarray(Ge, dtype=np.float64)))


def ffrf_quadratic_map(b, q):
    """``z = [q; y(q)]`` and ``T = ∂z/∂q = [I; A q]`` of the second-order field,
    ``y_j = ½ qᵀ A_j q`` (equations.md §2.3)."""
    Aq = (b["A"] @ q).reshape(b["ny"], b["nq"])
    return np.concatenate((q, 0.5 * (Aq @ q))), np.vstack((np.eye(b["nq"], dtype=Aq.dtype), Aq))


def ffrf_mass_blocks(b, q):
    """The q-dependent blocks of ``M_b(q)`` as a dict: ``md``, ``Mrr`` (6×6), ``Mre``
    (6×nq), ``Mer`` (nq×6), ``Mee`` (nq×nq, the body's own array: not to be written to),
    and what :func:`ffrf_body_loads` reuses: ``E12`` (nq×12) = ``[Ct Cr Oe]`` (``Mer`` and
    ``Oe`` are views of it) and ``c2q[k, ab] = Σ_l q_l C2[l, k, a, b]`` (nq×9, or ``None``);
    for a body with a second-order field, ``z``, ``T`` and ``inner`` (the blocks of the
    extended body at ``z``: ``Mre = Mre_z T``, ``Mer = Tᵀ Mer_z``, ``Mee = Tᵀ Me_z T``, §2.3).
    Matrix products only (BLAS): ``X = T0 + T1 q`` and ``K = P0 + P z``
    (:func:`ffrf_prepare`). The products of the per-call path are ``numpy.dot``: for arrays
    this small the ufunc machinery of ``@`` costs 0.3–0.6 µs more per product, and ``dot``
    sums in the same order (BLAS for floats; one term after the other for object arrays)."""
    if "fixed" in b:                          # a body on a fixed frame: elastic rows only
        dt = np.result_type(q, b["Me"], b["Ct0"])
        return {"md": b["md0"] + b["md1"] @ q, "Mrr": np.zeros((6, 6), dtype=dt),
                "Mre": np.zeros((6, b["nq"]), dtype=dt),
                "Mer": np.hstack((b["Ct0"], np.zeros((b["nq"], 3), dtype=dt))),
                "Mee": b["Me"]}
    if "quad" in b:
        z, T = ffrf_quadratic_map(b, q)
        inner = ffrf_mass_blocks(b["quad"], z)
        return {"md": inner["md"], "Mrr": inner["Mrr"], "Mre": inner["Mre"] @ T,
                "Mer": T.T @ inner["Mer"], "Mee": T.T @ (inner["Mee"] @ T), "z": z, "T": T,
                "inner": inner}
    X = b["T0"] + np.dot(b["T1"], q)
    where, nq = b["where"], b["nq"]
    i, j, _shape = where["E12"]
    E12 = X[i:j].reshape(nq, 12)
    i, j, _shape = where["CrvT"]
    parts, c2w = [X[0:12]], None              # z = [md; J⁰ + J¹q; 2 J²; s]
    if "c2w" in where:
        c2w = X[where["c2w"][0]:where["c2w"][1]].reshape(3, nq, 3)
        parts.append(np.dot(q, c2w).ravel())
    if b["consistent_stiffening"]:
        # reaction of the prestress of the frame acceleration (gravity: a − g) on the
        # rotational rows, ½ s̃(q) with s_a = qᵀ Ct¹_a q (equations.md §2.1)
        parts.append(ffrf_prestress(b, q, E12[:, :3]))
    z = np.concatenate(parts) if len(parts) > 1 else parts[0]
    K = (b["P0"] + np.dot(b["P"][:, :z.size], z)).reshape(6, 12)
    return {"md": X[0:3], "Mrr": K[:, :6], "Mre": np.concatenate((b["md1"], X[i:j].reshape(3, nq))),
            "Mer": E12[:, :6], "Mee": b["Me"], "K": K, "E12": E12, "Oe": E12[:, 6:],
            "c2w": None if c2w is None else c2w.reshape(3, 3 * nq)}


def ffrf_prestress(b, q, Ct):
    """``s_a = qᵀ Ct¹_a q`` (3,): the quadratic forms of the geometric stiffness of the frame
    acceleration cases (``Ct`` = ``Ct(q)``, so ``Ct − Ct⁰ = Ct¹ q``)."""
    return np.dot(q, Ct - b["Ct0"])


def ffrf_body_mass(b, q):
    """The full (6+nq)² body mass matrix ``M_b(q)`` for ``[a, α, q̈]``."""
    m = ffrf_mass_blocks(b, q)
    return np.block([[m["Mrr"], m["Mre"]], [m["Mer"], m["Mee"]]])


def ffrf_velocity_terms(b, q, qd, w, m):
    """``h_ω`` split into the rigid rows (6,) and the elastic rows (nq,) (module docstring);
    ``m`` are the blocks of :func:`ffrf_mass_blocks` at the same ``q``: the loads of
    :func:`ffrf_body_loads` at zero frame acceleration."""
    return ffrf_body_loads(b, q, qd, np.zeros(6), w, m)


def ffrf_body_loads(b, q, qd, acc, w, m):
    """``M_b(q) [acc; 0] + h_ω`` split into the rigid rows (6,) and the elastic rows (nq,)
    (module docstring; ``acc = [ā − g; ᾱ]``, ``m`` the blocks of :func:`ffrf_mass_blocks`
    at the same ``q``). With ``v = [acc; ω_q]`` the rows are the products ``K v`` (rigid,
    :func:`ffrf_rigid_map`) and ``E12 v`` (elastic, ``Ct a + Cr α + Oe ω_q``), plus ``G``
    (:func:`ffrf_velocity_map`) and the second-order ``c2w`` times ``q̇ ⊗ ω``.

    With a second-order field (§2.3) the extended body's loads at ``ż = T q̇`` plus the
    convective acceleration ``T' q̇ = [0; A(q̇, q̇)]``: ``h_r = h_r,z + Mre_z T'q̇``,
    ``h_e = Tᵀ (h_e,z + Me_z T'q̇)``.
    """
    if "fixed" in b:                          # M_b = [0, 0; Ct⁰, 0, Me], no h_ω
        return np.zeros(6, dtype=qd.dtype), b["Ct0"] @ acc[:3]
    if "quad" in b:
        inner, T = m["inner"], m["T"]
        cacc = np.concatenate((0.0 * qd, ((b["A"] @ qd).reshape(b["ny"], b["nq"])) @ qd))
        hr, he = ffrf_body_loads(b["quad"], m["z"], T @ qd, acc, w, inner)
        return hr + inner["Mre"] @ cacc, T.T @ (he + inner["Mee"] @ cacc)
    qw = (qd[:, None] * w).ravel()            # q̇ ⊗ ω, index 3k + c
    g = np.dot(b["G"], qw)                    # [2 ω̃ md¹ q̇; Gr⁰ (q̇ ⊗ ω); Ge (q̇ ⊗ ω)]
    v = ffrf_omega_products(w, acc)           # [acc; ω_q]
    hr = np.dot(m["K"], v) + g[:6]            # Mrr acc + [ω̃ ω̃ md; ω̃ J ω] + …
    if m["c2w"] is not None:
        # hr is complex or object whenever c2w (q) or qw (q̇, ω) are: adding in place is safe
        hr[3:] += np.dot(m["c2w"], qw)
    return hr, np.dot(m["E12"], v) + g[6:]


def ffrf_elastic_forces(b, q, qd):
    """``Ke q + De q̇ + kσ`` (elastic rows, left-hand side; ``De``, ``kσ`` not added where
    :func:`ffrf_prepare` found them zero: ``damped``, ``prestressed``)."""
    f = np.dot(b["Ke"], q)
    if b.get("damped", True):
        f = f + np.dot(b["De"], qd)
    if b.get("prestressed", True):
        f = f + b["ks"]
    return f


def ffrf_kinetic_energy(b, v, w, q, qd):
    """``T = ½ zᵀ M_b(q) z`` with ``z = [v; ω; q̇]`` (frame velocity and angular velocity in
    frame components). Exact for one-sided data; for two-sided data the elastic rows use
    ``W``, so this is the energy of the Petrov–Galerkin model, not a conserved quantity."""
    if "quad" in b:
        z, T = ffrf_quadratic_map(b, q)
        return ffrf_kinetic_energy(b["quad"], v, w, z, T @ qd)
    z = np.concatenate((v, w, qd))
    inertia = dict(b, consistent_stiffening=False)      # the prestress reaction is no inertia
    return 0.5 * float(np.real(z @ (ffrf_body_mass(inertia, q) @ z)))


def ffrf_first_moment(b, q):
    """``md(q) = ∫ r dm`` (3,): the gravity potential of the body is ``m e − g·md(q)``."""
    if "quad" in b:
        return ffrf_first_moment(b["quad"], ffrf_quadratic_map(b, q)[0])
    return b["md0"] + b["md1"] @ q


def ffrf_strain_energy(b, q, g=None):
    """``½ qᵀ Ke q + kσᵀ q`` (the symmetric part of ``Ke`` for two-sided data), plus, with the
    consistent stiffening of the frame-acceleration cases, the prestress potential of gravity
    ``−½ g·s(q)`` (``g`` in frame components)."""
    out = 0.5 * q @ (b["Ke"] @ q) + b["ks"] @ q
    if b["consistent_stiffening"] and g is not None:
        i, j, _shape = b["where"]["E12"]
        Ct = (b["T0"][i:j] + b["T1"][i:j] @ q).reshape(b["nq"], 12)[:, :3]
        out = out - 0.5 * g @ ffrf_prestress(b, q, Ct)
    return float(np.real(out))


def ffrf_loss_matrix(S, t, x, p, u=None):
    """The hysteretic matrix ``G`` of the frequency-domain stiffness ``K + iG`` on the
    coordinates (equations.md §1.1): ``S_Wᵀ G_s S_V`` of the symbolic part's force elements
    (their loss factors times their stiffness, ``G_s`` of ``rigid["loss_matrix"]`` at
    ``y_s = S_V y``, absent: zero) plus every body's ``Le`` on its elastic rows.

    ``S`` is the splice context (:func:`neweul_py.ffrf.splice.ffrf_system`, mixed at the
    schedule for parametric bodies); ``x`` the state ``[y, ẏ]`` (or ``y``).
    """
    n = S["n"]
    x = np.asarray(x, dtype=np.float64)
    y = x[:n]
    yd = x[n:2 * n] if x.size >= 2 * n else np.zeros(n)
    G = np.zeros((n, n))
    own = S["rigid"].get("loss_matrix")
    if own is not None:
        if u is None:
            u = S["default_inputs"](t, p)
        Gs = own(t, np.concatenate((S["SV"] @ y, S["SV"] @ yd)), p, u)
        G = G + S["SW"].T @ (Gs @ S["SV"])
    for b in S["bodies"]:
        if "Le" in b:
            e = slice(b["first"], b["first"] + b["nq"])
            G[e, e] += np.real(b["Le"])
    return G


#: The functions a generated module embeds (in this order), see the module docstring.
KERNEL_FUNCTIONS = (ffrf_skew, ffrf_omega_products, ffrf_prepare, ffrf_linear_stack,
                    ffrf_rigid_map, ffrf_gyroscopic, ffrf_velocity_map, ffrf_quadratic_map,
                    ffrf_mass_blocks, ffrf_prestress,
                    ffrf_body_mass, ffrf_velocity_terms, ffrf_body_loads,
                    ffrf_elastic_forces, ffrf_kinetic_energy, ffrf_first_moment,
                    ffrf_strain_energy, ffrf_loss_matrix)
