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
equations: :mod:`neweul_py.elastic.invariants` evaluates bodies with them and the generated
modules embed their source verbatim (:mod:`neweul_py.codegen.elastic`). They accept complex
arrays (the generated Jacobians use the complex step). Names start with ``ffrf_`` because the
embedded copies share the generated module's namespace.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "KERNEL_FUNCTIONS",
    "ffrf_body_mass",
    "ffrf_elastic_forces",
    "ffrf_first_moment",
    "ffrf_kinetic_energy",
    "ffrf_loss_matrix",
    "ffrf_mass_blocks",
    "ffrf_omega_products",
    "ffrf_prepare",
    "ffrf_quadratic_map",
    "ffrf_skew",
    "ffrf_strain_energy",
    "ffrf_velocity_terms",
]


def ffrf_skew(v):
    """``ṽ`` with ``ṽ b = v × b`` for one 3-vector (real or complex)."""
    return np.array([[0.0 * v[0], -v[2], v[1]], [v[2], 0.0 * v[0], -v[0]],
                     [-v[1], v[0], 0.0 * v[0]]])


def ffrf_omega_products(w):
    """``ω_q = [ωx², ωy², ωz², ωxωy, ωyωz, ωxωz]`` (the column order of ``Oe``)."""
    return np.array([w[0] * w[0], w[1] * w[1], w[2] * w[2], w[0] * w[1], w[1] * w[2],
                     w[0] * w[2]])


def ffrf_prepare(flat, inertia="consistent", fixed=False):
    """The kernel's working form of one body from its flat invariants (schema.py keys).

    The first-order parts of ``J``, ``Ct``, ``Cr``, ``Crv``, ``Oe`` are stacked into one
    matrix ``T1`` so that all of them follow from one product ``T0 + T1 q``.

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
        slice and shape in the stack), ``C2`` ((nq, nq, 3, 3) or ``None``), ``Me``, ``Gr``,
        ``Ge``, ``ks`` (nq,), ``Ke``, ``De``, and ``Le`` (the hysteretic matrix of
        ``K + iG``, equations.md §1.2) when the data hold ``Le.m0``.
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
    zeros, firsts, where, start = [], [], {}, 0
    for key in ("J", "Ct", "Cr", "Crv", "Oe"):
        m0 = np.asarray(flat[key + ".m0"], dtype=np.float64)
        m1 = flat.get(key + ".m1")
        size = m0.size
        zeros.append(m0.ravel())
        firsts.append(np.zeros((size, nq)) if m1 is None else
                      np.asarray(m1, dtype=np.float64).transpose(0, 2, 1).reshape(size, nq))
        where[key] = (start, start + size, m0.shape)
        start += size
    md1 = flat.get("md.m1")
    c2 = flat.get("J.m2") if inertia == "consistent" else None
    ct1 = flat.get("Ct.m1")
    stiff = (c2 is not None and ct1 is not None and np.any(ct1)
             and not bool(np.asarray(flat.get("two_sided", False))))
    b = {
        "mass": float(np.asarray(flat["m"])),
        "nq": nq,
        "md0": np.asarray(flat["md.m0"], dtype=np.float64)[:, 0],
        "md1": np.zeros((3, nq)) if md1 is None else np.asarray(md1, dtype=np.float64)[:, :, 0],
        "T0": np.concatenate(zeros),
        "T1": np.ascontiguousarray(np.vstack(firsts)),
        "where": where,
        "C2": None if c2 is None else np.ascontiguousarray(
            np.asarray(c2, dtype=np.float64).reshape(nq, 9 * nq)),
        "consistent_stiffening": bool(stiff),
        "Ct0": np.asarray(flat["Ct.m0"], dtype=np.float64),
        "Me": np.asarray(flat["Me.m0"], dtype=np.float64),
        "Gr": np.asarray(flat["Gr.m0"], dtype=np.float64),
        "Ge": np.asarray(flat["Ge.m0"], dtype=np.float64),
        "ks": np.asarray(flat["ksigma.m0"], dtype=np.float64)[:, 0],
        "Ke": np.asarray(flat["Ke.m0"], dtype=np.float64),
        "De": np.asarray(flat["De.m0"], dtype=np.float64),
    }
    if "Le.m0" in flat:
        b["Le"] = np.asarray(flat["Le.m0"], dtype=np.float64)
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


def ffrf_quadratic_map(b, q):
    """``z = [q; y(q)]`` and ``T = ∂z/∂q = [I; A q]`` of the second-order field,
    ``y_j = ½ qᵀ A_j q`` (equations.md §2.3)."""
    Aq = (b["A"] @ q).reshape(b["ny"], b["nq"])
    return np.concatenate((q, 0.5 * (Aq @ q))), np.vstack((np.eye(b["nq"], dtype=Aq.dtype), Aq))


def ffrf_mass_blocks(b, q):
    """The q-dependent blocks of ``M_b(q)`` as a dict: ``md``, ``Mrr`` (6×6), ``Mre``
    (6×nq), ``Mer`` (nq×6), ``Mee`` (nq×nq), and what :func:`ffrf_velocity_terms` reuses:
    ``Oe`` (nq×6) and ``c2q[k, ab] = Σ_l q_l C2[l, k, a, b]`` (nq×9, or ``None``); for a
    body with a second-order field, ``z``, ``T`` and ``inner`` (the blocks of the extended
    body at ``z``: ``Mre = Mre_z T``, ``Mer = Tᵀ Mer_z``, ``Mee = Tᵀ Me_z T``, §2.3).
    Matrix products only (BLAS)."""
    if "fixed" in b:                          # a body on a fixed frame: elastic rows only
        dt = np.result_type(q, b["Me"], b["Ct0"])
        return {"md": b["md0"] + b["md1"] @ q, "Mrr": np.zeros((6, 6), dtype=dt),
                "Mre": np.zeros((6, b["nq"]), dtype=dt),
                "Mer": np.hstack((b["Ct0"], np.zeros((b["nq"], 3), dtype=dt))),
                "Mee": b["Me"].astype(dt)}
    if "quad" in b:
        z, T = ffrf_quadratic_map(b, q)
        inner = ffrf_mass_blocks(b["quad"], z)
        return {"md": inner["md"], "Mrr": inner["Mrr"], "Mre": inner["Mre"] @ T,
                "Mer": T.T @ inner["Mer"], "Mee": T.T @ (inner["Mee"] @ T), "z": z, "T": T,
                "inner": inner}
    X = b["T0"] + b["T1"] @ q
    X = {k: X[i:j].reshape(shape) for k, (i, j, shape) in b["where"].items()}
    J = X["J"]
    c2q = None
    if b["C2"] is not None:
        c2q = (q @ b["C2"]).reshape(b["nq"], 9)
        J = J + (q @ c2q).reshape(3, 3)
    md = b["md0"] + b["md1"] @ q
    Mrr = np.zeros((6, 6), dtype=J.dtype)
    Mrr[0, 0] = Mrr[1, 1] = Mrr[2, 2] = b["mass"]
    Mrr[3:, :3] = ffrf_skew(md)
    Mrr[:3, 3:] = -Mrr[3:, :3]
    Mrr[3:, 3:] = J
    if b["consistent_stiffening"]:
        # reaction of the prestress of the frame acceleration (gravity: a − g) on the
        # rotational rows, ½ s̃(q) with s_a = qᵀ Ct¹_a q (equations.md §2.1)
        Mrr[3:, :3] += 0.5 * ffrf_skew(ffrf_prestress(b, q, X["Ct"]))
    return {"md": md, "Mrr": Mrr, "Mre": np.vstack((b["md1"], X["Crv"].T)),
            "Mer": np.hstack((X["Ct"], X["Cr"])), "Mee": b["Me"].astype(J.dtype),
            "Oe": X["Oe"], "c2q": c2q}


def ffrf_prestress(b, q, Ct):
    """``s_a = qᵀ Ct¹_a q`` (3,): the quadratic forms of the geometric stiffness of the frame
    acceleration cases (``Ct`` = ``Ct(q)``, so ``Ct − Ct⁰ = Ct¹ q``)."""
    return q @ (Ct - b["Ct0"])


def ffrf_body_mass(b, q):
    """The full (6+nq)² body mass matrix ``M_b(q)`` for ``[a, α, q̈]``."""
    m = ffrf_mass_blocks(b, q)
    return np.block([[m["Mrr"], m["Mre"]], [m["Mer"], m["Mee"]]])


def ffrf_velocity_terms(b, q, qd, w, m):
    """``h_ω`` split into the rigid rows (6,) and the elastic rows (nq,) (module docstring);
    ``m`` are the blocks of :func:`ffrf_mass_blocks` at the same ``q``.

    With a second-order field (§2.3) the extended body's terms at ``ż = T q̇`` plus the
    convective acceleration ``T' q̇ = [0; A(q̇, q̇)]``: ``h_r = h_r,z + Mre_z T'q̇``,
    ``h_e = Tᵀ (h_e,z + Me_z T'q̇)``.
    """
    if "fixed" in b:
        return np.zeros(6, dtype=qd.dtype), np.zeros(b["nq"], dtype=qd.dtype)
    if "quad" in b:
        inner, T = m["inner"], m["T"]
        acc = np.concatenate((0.0 * qd, ((b["A"] @ qd).reshape(b["ny"], b["nq"])) @ qd))
        hr, he = ffrf_velocity_terms(b["quad"], m["z"], T @ qd, w, inner)
        return hr + inner["Mre"] @ acc, T.T @ (he + inner["Mee"] @ acc)
    wt = ffrf_skew(w)
    qw = np.outer(qd, w).ravel()
    md, Jq, c2q = m["md"], m["Mrr"][3:, 3:], m["c2q"]
    hr = np.concatenate((wt @ (wt @ md) + 2.0 * (wt @ (b["md1"] @ qd)),
                         wt @ (Jq @ w) + b["Gr"] @ qw))
    if c2q is not None:
        hr[3:] += 2.0 * ((qd @ c2q).reshape(3, 3) @ w)
    he = m["Oe"] @ ffrf_omega_products(w) + b["Ge"] @ qw
    return hr, he


def ffrf_elastic_forces(b, q, qd):
    """``Ke q + De q̇ + kσ`` (elastic rows, left-hand side)."""
    return b["Ke"] @ q + b["De"] @ qd + b["ks"]


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
        X = b["T0"] + b["T1"] @ q
        i, j, shape = b["where"]["Ct"]
        out = out - 0.5 * g @ ffrf_prestress(b, q, X[i:j].reshape(shape))
    return float(np.real(out))


def ffrf_loss_matrix(S, t, x, p, u=None):
    """The hysteretic matrix ``G`` of the frequency-domain stiffness ``K + iG`` on the
    coordinates (equations.md §1.2): ``S_Wᵀ G_s S_V`` of the symbolic part's force elements
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
KERNEL_FUNCTIONS = (ffrf_skew, ffrf_omega_products, ffrf_prepare, ffrf_quadratic_map,
                    ffrf_mass_blocks, ffrf_prestress, ffrf_body_mass, ffrf_velocity_terms,
                    ffrf_elastic_forces, ffrf_kinetic_energy, ffrf_first_moment,
                    ffrf_strain_energy, ffrf_loss_matrix)
