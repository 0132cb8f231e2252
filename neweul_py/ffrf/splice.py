"""Elastic bodies spliced into the system equations (equations.md §2, "splice").

The symbolic part of a model (rigid bodies, force elements, outputs, constraints, node
frames) is a generated function set in the *symbolic coordinates* ``y_s``; for every elastic
body it also returns, as hidden outputs, its reference frame's kinematics
``kin = [J_T, J_R, ā, ᾱ, ω, g, v, e]`` (frame components; ``e = −g·r_O`` the potential per
unit mass of the frame origin). These functions turn that into the protocol functions of a
model with elastic bodies:

1. ``y_s = S_V y``: the dependent node coordinates ``[u; θ] = [Φ_P; Ψ_P] q`` of the node frames;
   the symbolic part's ``M_s``, ``(q − k)_s`` enter as ``S_Wᵀ M_s S_V``, ``S_Wᵀ (q − k)_s``
   (``S_W``: the left basis; node loads reach the elastic rows as ``W_Pᵀ f``);
2. the body equations of :mod:`neweul_py.ffrf.body` with ``J_b = [J_T; J_R; E]``::

       M   += J_Wᵀ M_b(q) J_V
       q−k −= J_Wᵀ (M_b(q) [ā − g; ᾱ; 0] + h_ω + [0; 0; Ke q + De q̇ + kσ])

   with ``J_V = J_b S_V`` and ``J_W = J_b S_W``;
3. Jacobians by the chain rule through the analytic Jacobians of ``kin`` with the
   complex-step derivative of the (polynomial) body terms, ``Im f(x + i h d)/h`` with
   ``h = 1e-30``: exact to round-off (Squire & Trapp, SIAM Rev. 40 (1998) 110–112).

All functions take the splice context ``S`` made by :func:`ffrf_system` (no module state),
are plain NumPy and are embedded verbatim in generated modules
(:mod:`neweul_py.codegen.elastic`), after :data:`neweul_py.ffrf.body.KERNEL_FUNCTIONS`.
"""

from __future__ import annotations

import numpy as np

from .body import (
    ffrf_body_loads,
    ffrf_elastic_forces,
    ffrf_first_moment,
    ffrf_kinetic_energy,
    ffrf_mass_blocks,
    ffrf_prepare,
    ffrf_strain_energy,
)
from .parametric import (
    ffrf_mix,
    ffrf_slope_prepared,
    ffrf_stack,
    ffrf_unmix,
    ffrf_weights,
)
from .varying import ffrf_derived, ffrf_expand

__all__ = ["KIN_TAIL", "MAX_BLOCK_CONDITION", "PROTOCOL", "SPLICE_FUNCTIONS", "ffrf_add_force",
           "ffrf_add_mass", "ffrf_at", "ffrf_bodies", "ffrf_cloud", "ffrf_system", "ffrf_terms"]

#: Largest condition number of a constant block ``D`` of ``M`` that is eliminated with its
#: explicit inverse, in the NumPy kernel (:func:`ffrf_block`, passed by the generated module)
#: and the compiled backend (:func:`neweul_py.codegen.c_solve.constant_block`) alike. The
#: elimination multiplies by ``D⁻¹``, which is not backward stable: its error grows like
#: ``cond(D)`` against the dense LU's (4e-11 against 4e-12 at ``cond(D)`` = 5e4); the
#: ``Me`` of mass-normalized modes has ``cond`` ≈ 1.
MAX_BLOCK_CONDITION = 1e4

#: Entries of ``kin`` per body besides the two Jacobians: ā, ᾱ, ω, g, v (3 each), e (1)
#: (written as the literal 16 in :func:`ffrf_frame`, whose source is embedded).
KIN_TAIL = 16


def ffrf_bodies(data, parts=()):
    """The prepared bodies of a model: the kernel's working form of each body
    (:func:`~neweul_py.ffrf.body.ffrf_prepare`), for a parametric body the mixing form of its
    samples (:func:`~neweul_py.ffrf.parametric.ffrf_stack`). Run once, at generation: the
    generated module reads the result from its data file (:mod:`.data_file`).

    Parameters
    ----------
    data
        One dict per elastic body: ``name``, ``first`` (index of its first coordinate in
        ``y``), ``kin`` (offset of its frame kinematics in the hidden outputs), ``inertia``,
        ``fixed`` (optional) and its flat arrays; a parametric body has ``samples`` (one such
        dict of arrays per sample; ``slopes`` and ``curvatures`` likewise for Hermite
        weights), ``values`` and ``coeff`` (:mod:`.parametric`) instead.
    parts
        Per parametric body ``(S_V,i, S_W,i)`` stacks (k, ns, n; 2k with slopes, 3k with
        curvatures too, the samples' then their slopes' and curvatures'): its node rows per
        sample (stacked with the body's arrays, :func:`~neweul_py.ffrf.parametric.ffrf_stack`).

    Returns
    -------
    list of dict
        Per body the dict :func:`ffrf_system` takes; a parametric body's holds ``mixing``,
        ``rows`` (its node rows in ``S_V``, ``S_W``), ``values`` and ``coeff``.
    """
    bodies, parts = [], list(parts)
    for entry in data:
        if "samples" in entry:
            how = (entry["inertia"], entry.get("fixed", False))
            flats = [dict(sample) for sample in entry["samples"]]
            prepared = [ffrf_prepare(flat, *how) for flat in flats]
            # Hermite weights: the working forms of the slopes (and curvatures) follow the
            # samples' — the linear part of the form (§4.2)
            blocks = 1
            for what in ("slopes", "curvatures"):
                if what in entry:
                    blocks += 1
                    prepared += [ffrf_slope_prepared(ffrf_prepare, flat, dict(d), *how)
                                 for flat, d in zip(flats, entry[what], strict=True)]
            sv_i, sw_i = (np.asarray(a, dtype=np.float64) for a in parts.pop(0))
            coeff = np.asarray(entry["coeff"], dtype=np.float64)
            values = np.asarray(entry["values"], dtype=np.float64)
            # the derivative order of every row: values, then slopes, then curvatures
            orders = np.repeat(np.arange(blocks), len(flats))
            if blocks > 1:            # rows X_1, X_1′(, X_1″), X_2 …: a sample's band is narrow
                k = len(flats)
                order = np.arange(blocks * k).reshape(blocks, k).T.ravel()
                prepared = [prepared[i] for i in order]
                sv_i, sw_i, coeff = sv_i[order], sw_i[order], coeff[:, :, order]
                orders = orders[order]
            # its node rows per sample (the rows not zero in every sample) join the stack
            rows = np.flatnonzero(np.any(sv_i, axis=(0, 2)) | np.any(sw_i, axis=(0, 2)))
            # the arrays are mixed at every σ (ffrf_mixed): the body keeps sample 1's flags;
            # the stack keeps what varies over the samples (tolerance per Δσ of the range)
            b = {k: v for k, v in prepared[0].items() if not isinstance(v, np.ndarray)}
            b.update(mixing=ffrf_stack(prepared, {"_sv": sv_i[:, rows], "_sw": sw_i[:, rows]},
                                       orders, float(values[-1] - values[0])),
                     rows=rows, values=values, coeff=np.ascontiguousarray(coeff))
        else:
            b = ffrf_prepare(entry, entry["inertia"], entry.get("fixed", False))
        b.update(name=entry["name"], first=entry["first"], kin=entry["kin"])
        bodies.append(b)
    return bodies


def ffrf_system(bodies, ns, SV, SW, nhidden, rigid, default_inputs, schedule=None,
                schedule_jacobians=None, mass_pattern=None, kin_pattern=None,
                max_condition=0.0, schedule_parameter_jacobian=None):
    """The splice context of a generated module.

    Parameters
    ----------
    bodies
        The prepared bodies (:func:`ffrf_bodies`).
    ns
        Number of symbolic coordinates ``y_s`` that appear in the symbolic part.
    SV, SW
        ``S_V``, ``S_W`` restricted to those rows, (ns, n) (without the node rows of
        parametric bodies).
    nhidden
        Number of the module's own outputs (the hidden ones follow).
    rigid
        The symbolic part's functions by protocol name.
    default_inputs
        ``default_inputs(t, p)`` of the module.
    schedule, schedule_jacobians
        ``schedule(t, y_s, p, u)``: the scheduling values ``σ`` of the parametric bodies, in
        order, and ``schedule_jacobians(t, y_s, p, u)``: ``∂σ/∂y_s``, ``∂σ/∂u``.
    mass_pattern, kin_pattern, max_condition
        The rows and columns of ``M_s`` and the hidden outputs not zero by construction,
        and the largest condition number of a constant elastic block that
        :func:`ffrf_block` eliminates (:data:`MAX_BLOCK_CONDITION`; 0: none).
    schedule_parameter_jacobian
        ``schedule_parameter_jacobian(t, y_s, p, u)``: ``∂σ/∂p`` (parameter derivatives,
        docs/sensitivity.md).
    """
    bodies = [dict(b) for b in bodies]
    SV, SW = np.asarray(SV, dtype=np.float64), np.asarray(SW, dtype=np.float64)
    for b in bodies:
        if "mixing" not in b and "quad" not in b and "fixed" not in b:
            rows = np.zeros((b["nq"], SV.shape[1]))           # Mee E (ffrf_add_mass)
            rows[:, b["first"]:b["first"] + b["nq"]] = b["Me"]
            b["Mee_rows"] = rows
    npar = sum("mixing" in b for b in bodies)
    gesv = None
    # the small dense solve without numpy's set-up (above 64 coordinates numpy's set-up is
    # negligible, and importing scipy.linalg would cost 0.4 s of the module's import)
    if SV.shape[1] <= 64:
        try:
            from scipy.linalg.lapack import dgesv as gesv
        except ImportError:                   # NumPy only
            gesv = None
    pattern = None if mass_pattern is None else tuple(
        np.asarray(v, dtype=np.intp).ravel() for v in mass_pattern)
    return {"bodies": tuple(bodies), "ns": ns, "n": SV.shape[1], "SV": SV, "SW": SW,
            "same": bool(np.array_equal(SV, SW)) and not npar, "nhidden": nhidden,
            "rigid": rigid, "default_inputs": default_inputs, "step": 1e-30, "gesv": gesv,
            "parametric": npar, "memo": [None],
            "schedule": schedule, "schedule_jacobians": schedule_jacobians,
            "schedule_parameter_jacobian": schedule_parameter_jacobian, "pattern": pattern,
            "maps": ffrf_mass_maps(SV, SW, pattern),
            "acc_map": np.hstack((np.eye(6), np.zeros((6, 3)), -np.eye(6, 3), np.zeros((6, 4)))),
            "block": ffrf_block(bodies, ns, SV, SW, pattern, None if kin_pattern is None
                                else np.asarray(kin_pattern, dtype=np.intp),
                                max_condition)}


def ffrf_block(bodies, ns, SV, SW, pattern, kin_pattern, max_condition):
    """The block elimination of the elastic coordinates ``E`` for ``M x = f``, when their
    block ``D = M[E, E]`` is the constant ``blockdiag(Me)`` by construction (Golub & Van
    Loan, *Matrix Computations*, §3.2.10; as :mod:`neweul_py.codegen.c_solve`)::

        S = M[R, R] − M[R, E] D⁻¹ M[E, R],  S x_R = f_R − M[R, E] D⁻¹ f_E,
        x_E = D⁻¹ (f_E − M[E, R] x_R)

    ``D`` is constant when no mass of the symbolic part sits on the node coordinates
    (``M_s[S_W E, S_V E] = 0``, ``pattern``) and no moving body's frame moves with them (its
    ``J_T``, ``J_R`` columns there are zero, ``kin_pattern``), without second-order fields and
    parametric bodies. Returns ``None`` otherwise, when ``D`` is worse conditioned than
    ``max_condition`` (:data:`MAX_BLOCK_CONDITION`, shared with the compiled backend: the
    elimination multiplies by ``D⁻¹``, which is not backward stable) or when the dense solve
    is cheaper (fewer than 24 elastic coordinates besides rigid
    ones): else ``{"R", "E"}`` (index arrays), ``"r"``, ``"e"`` (the same or slices,
    :func:`ffrf_index`), ``"ix"`` (the index tuples of the blocks ``RR``, ``RE``, ``ER``)
    and ``"Dinv"``."""
    if any("mixing" in b for b in bodies):
        return None
    n = SV.shape[1]
    E = np.concatenate([np.arange(b["first"], b["first"] + b["nq"]) for b in bodies]) \
        if bodies else np.zeros(0, dtype=np.intp)
    R = np.setdiff1d(np.arange(n), E)
    if (R.size and E.size < 24) or not ffrf_block_constant(bodies, ns, SV, SW, pattern,
                                                          kin_pattern):
        return None
    D = np.zeros((E.size, E.size))
    k = 0
    for b in bodies:
        D[k:k + b["nq"], k:k + b["nq"]] = b["Me"]
        k += b["nq"]
    if not np.all(np.isfinite(D)) or np.linalg.cond(D) > max_condition:
        return None
    rs, es = ffrf_index(R), ffrf_index(E)
    if isinstance(rs, slice) and isinstance(es, slice):
        ix = ((rs, rs), (rs, es), (es, rs))
    else:
        ix = (np.ix_(R, R), np.ix_(R, E), np.ix_(E, R))
    return {"R": R, "E": E, "Dinv": np.linalg.inv(D), "ix": ix, "r": rs, "e": es}


def ffrf_block_constant(bodies, ns, SV, SW, pattern, kin_pattern):
    """Whether the block ``D = M[E, E]`` of the elastic coordinates is ``blockdiag(Me)`` by
    construction (:func:`ffrf_block`): no mass of the symbolic part on the node coordinates
    (``pattern``), no moving body's frame moving with them (``kin_pattern``), no
    second-order field. ``S_V``, ``S_W``: their nonzero structure (for parametric bodies
    that of every sample's node rows). A parametric body's ``Me(σ)`` then changes with the
    schedule alone (the compiled backend keeps its factorization while ``σ`` stays)."""
    if pattern is None or kin_pattern is None or not bodies:
        return False
    if any("quad" in b for b in bodies):
        return False
    E = np.concatenate([np.arange(b["first"], b["first"] + b["nq"]) for b in bodies])
    rv = np.flatnonzero(np.any(SV[:, E], axis=1))
    rw = np.flatnonzero(np.any(SW[:, E], axis=1))
    if np.intersect1d(pattern[0], rw).size and np.intersect1d(pattern[1], rv).size:
        return False
    size = max(int(kin_pattern.max(initial=-1)) + 1, *(b["kin"] + 6 * ns + 16 for b in bodies))
    nonzero = np.zeros(size, dtype=bool)
    nonzero[kin_pattern] = True
    touched = np.union1d(rv, rw)
    for b in bodies:
        cols = nonzero[b["kin"]:b["kin"] + 6 * ns].reshape(6, ns).any(axis=0)
        if "fixed" not in b and np.any(cols[touched]):
            return False
    return True


def ffrf_index(k):
    """The index array ``k`` as a slice when it is a contiguous ascending range (views
    instead of copies), else ``k``."""
    if k.size and np.array_equal(k, np.arange(k[0], k[0] + k.size)):
        return slice(int(k[0]), int(k[0]) + k.size)
    return k


def ffrf_dense_solve(S, M, f):
    """``M⁻¹ f`` by the dense LU with partial pivoting: LAPACK's ``dgesv`` through SciPy
    when it is installed and ``n ≤ 64`` (``S["gesv"]``; 22×22: a third of
    ``numpy.linalg.solve``'s time,
    whose set-up dominates small systems), else — and for complex or singular systems —
    ``numpy.linalg.solve`` (its ``LinAlgError``)."""
    gesv = S["gesv"]
    if gesv is not None and M.dtype == np.float64 and f.dtype == np.float64:
        x, info = gesv(M, f)[2:]
        if info == 0:
            return x
    return np.linalg.solve(M, f)


def ffrf_solve(S, M, f):
    """``M⁻¹ f`` (``f``: (n,) or (n, k)): by :func:`ffrf_block`'s elimination when the
    context has it, else the dense LU (:func:`ffrf_dense_solve`)."""
    blk = S["block"]
    if blk is None:
        return ffrf_dense_solve(S, M, f)
    R, E, Dinv = blk["r"], blk["e"], blk["Dinv"]
    out = np.empty(f.shape, dtype=np.result_type(M, f))
    yf = np.dot(Dinv, f[E])
    if not blk["R"].size:
        out[E] = yf
        return out
    RR, RE, ER = blk["ix"]
    Y = np.dot(Dinv, M[ER])
    B = M[RE]
    xR = np.linalg.solve(M[RR] - np.dot(B, Y), f[R] - np.dot(B, yf))
    out[R] = xR
    out[E] = yf - np.dot(Y, xR)
    return out


def ffrf_mass_maps(SV, SW, pattern):
    """What ``S_Wᵀ M_s S_V`` needs besides ``M_s`` when the rows ``r`` and columns ``c`` of
    ``M_s`` that can be nonzero are known (``pattern``, else ``None``): ``(index, S_W[r]ᵀ,
    S_V[c])``, ``index`` selecting ``M_s[r, c]`` (slices for contiguous ranges); and
    ``S_Vᵀ`` for the symbolic state ``[S_V y, S_V ẏ] = ([y; ẏ] S_Vᵀ)`` in one product."""
    if pattern is None:
        return None, SV.T.copy()
    r, c = pattern
    ix = (ffrf_index(r), ffrf_index(c))
    if not isinstance(ix[0], slice) or not isinstance(ix[1], slice):
        ix = np.ix_(r, c)
    return (ix, np.ascontiguousarray(SW[r].T), np.ascontiguousarray(SV[c])), SV.T.copy()


def ffrf_schedule(S, t, p, x=None, u=None):
    """``σ(t, y_s, p, u)`` with ``y_s = S_V y`` (``x``: ``y`` or the state ``[y, ẏ]``; the
    node rows of parametric bodies are not in this ``S_V``, and schedules cannot use them)."""
    y = np.zeros(S["n"]) if x is None else np.asarray(x, dtype=np.float64)[:S["n"]]
    if u is None:
        u = S["default_inputs"](t, p)
    return S["schedule"](t, S["SV"] @ y, p, u)


def ffrf_at(S, t, p, x=None, u=None):
    """The context at time ``t``, parameters ``p``, coordinates ``x`` (``y`` or the state)
    and inputs ``u``: parametric bodies mixed at their scheduling values ``σ`` and ``S_V(σ)``,
    ``S_W(σ)`` (frozen-parameter equations: the weights' time derivatives are not taken,
    :mod:`~neweul_py.ffrf.parametric`; their dependence on ``y`` and ``u`` enters the Jacobians,
    :func:`ffrf_sigma_terms`); ``S`` itself without parametric bodies.

    The last mixed context is remembered (``S["memo"]``, one entry keyed by the bytes of
    ``σ``): the Newton iterations of an implicit step, and the Jacobian calls at one time,
    evaluate the module at one ``σ`` several times and mix the samples once."""
    if not S["parametric"]:
        return S
    sigma = np.asarray(ffrf_schedule(S, t, p, x, u), dtype=np.float64)
    key = sigma.tobytes()
    memo = S["memo"][0]
    if memo is not None and memo[0] == key:
        return memo[1]
    mixed = ffrf_mixed(S, sigma)
    S["memo"][0] = (key, mixed)
    return mixed


def ffrf_mixed(S, sigma):
    """The context with the parametric bodies mixed at ``sigma`` (real, or complex for the
    complex-step derivative in ``σ``); it keeps ``base`` and ``sigma``."""
    bodies, SV, SW, k = [], S["SV"], S["SW"], 0
    for b in S["bodies"]:
        if "mixing" not in b:
            bodies.append(b)
            continue
        w = ffrf_weights(b["values"], b["coeff"], sigma[k], b["name"])
        mixed = ffrf_mix(b["mixing"], w)    # one product w B for all arrays and node rows
        mixed.update(name=b["name"], first=b["first"], kin=b["kin"])
        SV, SW = SV.astype(np.result_type(SV, w)), SW.astype(np.result_type(SW, w))  # copies
        SV[b["rows"]] += mixed.pop("_sv")
        SW[b["rows"]] += mixed.pop("_sw")
        bodies.append(mixed)
        k += 1
    return dict(S, bodies=tuple(bodies), SV=SV, SW=SW, same=bool(np.array_equal(SV, SW)),
                base=S, sigma=np.asarray(sigma), maps=ffrf_mass_maps(SV, SW, S["pattern"]))


def ffrf_sigma_sensitivity(S, t, y, p, u):
    """``(∂σ/∂y, ∂σ/∂u)`` of a mixed context, ``(k, n)`` and ``(k, nu)``, or ``None`` when the
    schedules depend on neither (functions of ``t`` and ``p`` only)."""
    if "base" not in S or S["schedule_jacobians"] is None:
        return None
    Sy, Su = S["schedule_jacobians"](t, S["base"]["SV"] @ y, p, u)
    if not np.any(Sy) and not np.any(Su):
        return None
    return Sy @ S["base"]["SV"], Su


def ffrf_sigma_terms(S, t, y, yd, p, u, a=None):
    """``∂(q − k)/∂σ`` (n, k) — or ``∂(M a)/∂σ`` with ``a`` — of a mixed context: the
    complex step of the mixed bodies, ``S_V(σ)``, ``S_W(σ)`` in each ``σ_k``, with the
    symbolic part's analytic Jacobians for its arguments ``y_s = S_V(σ) y`` (module
    docstring, step 3)."""
    sigma, h, ns = S["sigma"], S["step"], S["ns"]
    ys, yds = S["SV"] @ y, S["SV"] @ yd
    rig = S["rigid"]
    Cs = rig["output_jacobians"](t, np.concatenate((ys, yds)), p, u)[0][S["nhidden"]:]
    kin = ffrf_kin(S, t, y, yd, p, u)
    if a is None:
        fs = rig["force_vector"](t, ys, yds, p, u)
        fys, fyds, _fu = rig["force_jacobians"](t, ys, yds, p, u)
    else:
        a_s = S["SV"] @ a
        Ms = rig["mass_matrix"](t, ys, p, u)
        mm = rig["mass_matrix_times_derivative"](t, ys, p, a_s, u)
    out = np.empty((S["n"], sigma.size))
    for k, Sc in enumerate(ffrf_sigma_steps(S)):
        dSV = Sc["SV"].imag / h
        dys, dyds = dSV @ y, dSV @ yd
        dkin = Cs[:, :ns] @ dys + Cs[:, ns:] @ dyds
        terms = ffrf_terms(Sc, kin + 1j * h * dkin, y, yd)
        if a is None:
            f = Sc["SW"].T @ (fs + 1j * h * (fys @ dys + fyds @ dyds))
            f = ffrf_add_force(Sc, f, terms)
        else:
            f = Sc["SW"].T @ (Ms @ (Sc["SV"] @ a) + 1j * h * (mm @ dys))
            f = f + ffrf_add_mass(Sc, np.zeros((S["n"], S["n"]), dtype=complex), terms) @ a
        out[:, k] = f.imag / h
    return out


def ffrf_frame(S, b, kin):
    """``(J_V, J_W, tail)`` of body ``b`` from the hidden outputs ``kin``, ``tail = [ā, ᾱ,
    ω, g, v, e]`` (16; a body on a fixed frame has no Jacobian entries there: its
    ``J_V = J_W = 0``)."""
    o = b["kin"]
    if "fixed" in b:
        zero = np.zeros((6, S["n"]), dtype=kin.dtype)
        return zero, zero, kin[o:o + 16]
    ns = S["ns"]
    Js = kin[o:o + 6 * ns].reshape(6, ns)     # [J_T; J_R]
    Jv = np.dot(Js, S["SV"])
    return Jv, Jv if S["same"] else np.dot(Js, S["SW"]), kin[o + 6 * ns:o + 6 * ns + 16]


def ffrf_terms(S, kin, y, yd):
    """Per body: ``(J_V, J_W, acc, ω, q, q̇, blocks)`` — the frame kinematics
    (``acc = [ā − g; ᾱ]``) and the mass blocks of
    :func:`~neweul_py.ffrf.body.ffrf_mass_blocks` (``None`` for a body on a fixed frame,
    whose mass is its constant ``Me``), evaluated once for the mass matrix and the force
    vector."""
    out = []
    for b in S["bodies"]:
        Jv, Jw, tail = ffrf_frame(S, b, kin)
        e = slice(b["first"], b["first"] + b["nq"])
        q = y[e]
        out.append((Jv, Jw, np.dot(S["acc_map"], tail), tail[6:9], q, yd[e],
                    None if "fixed" in b else ffrf_mass_blocks(b, q)))
    return out


def ffrf_add_mass(S, M, terms):
    """``M += J_Wᵀ M_b(q) J_V`` for every body (the ``E`` rows/columns as index slices):
    ``J_Wᵀ (Mrr J_V + Mre E) + Eᵀ (Mer J_V + Mee E)``; a constant ``Mee`` enters through its
    rows ``Mee E`` (``Mee_rows``, (nq, n), made by :func:`ffrf_system`)."""
    for b, (Jv, Jw, *_k, m) in zip(S["bodies"], terms, strict=True):
        e = slice(b["first"], b["first"] + b["nq"])
        if m is None:                         # a fixed frame, J_V = J_W = 0: Me alone
            M = M.astype(np.result_type(M, b["Me"]))       # a copy, as M + … below
            M[e, e] += b["Me"]
            continue
        U = np.dot(m["Mrr"], Jv)
        U[:, e] += m["Mre"]
        M = M + np.dot(Jw.T, U)
        V = np.dot(m["Mer"], Jv)
        rows = b.get("Mee_rows")
        if rows is not None and m["Mee"] is b["Me"]:
            M[e, :] += V + rows               # the constant Mee E: no strided addition
        else:
            M[e, :] += V
            M[e, e] += m["Mee"]
    return M


def ffrf_add_force(S, f, terms):
    """``q − k −= J_Wᵀ (M_b [ā − g; ᾱ; 0] + h_ω + [0; 0; Ke q + De q̇ + kσ])`` (the rigid
    rows of a body on a fixed frame, ``J_W = 0``, are not formed)."""
    for b, (_Jv, Jw, acc, w, q, qd, m) in zip(S["bodies"], terms, strict=True):
        e = slice(b["first"], b["first"] + b["nq"])
        hr, he = ffrf_body_loads(b, q, qd, acc, w, m)
        he = he + ffrf_elastic_forces(b, q, qd)
        if m is None:
            f = f.astype(np.result_type(f, he))            # a copy, as f − … below
        else:
            f = f - np.dot(Jw.T, hr)
        f[e] -= he
    return f


def ffrf_symbolic_mass(S, Ms):
    """``S_Wᵀ M_s S_V``: through the rows and columns of ``M_s`` known to be in use
    (``S["maps"]``, :func:`ffrf_mass_maps`), else :func:`ffrf_sandwich`."""
    maps = S["maps"][0]
    if maps is None:
        return ffrf_sandwich(S["SW"], Ms, S["SV"])
    ix, SWrT, SVc = maps
    return np.dot(SWrT, np.dot(Ms[ix], SVc))


def ffrf_sandwich(SW, A, SV):
    """``S_Wᵀ A S_V`` through the rows and columns of ``A`` that are not zero: the symbolic
    part's matrices vanish on the node coordinates that carry no mass or force element, and
    ``S_V`` has a row per symbolic coordinate (``ns`` can be far above the rows in use)."""
    r = np.flatnonzero(np.any(A, axis=1))
    c = np.flatnonzero(np.any(A, axis=0))
    return SW[r].T @ (A[np.ix_(r, c)] @ SV[c])


def ffrf_kin(S, t, y, yd, p, u):
    """The hidden outputs (frame kinematics of the bodies) at ``y_s = S_V y``."""
    xs = np.concatenate((S["SV"] @ y, S["SV"] @ yd))
    return S["rigid"]["outputs"](t, xs, p, u)[S["nhidden"]:]


def ffrf_mass_matrix(S, t, y, p, u=None):
    """``M = S_Wᵀ M_s S_V + Σ J_Wᵀ M_b J_V`` (unsymmetric with two-sided data)."""
    y = np.asarray(y, dtype=np.float64)
    z = np.zeros_like(y)
    terms = ffrf_terms(S, ffrf_kin(S, t, y, z, p, u), y, z)
    Ms = S["rigid"]["mass_matrix"](t, S["SV"] @ y, p, u)
    return ffrf_add_mass(S, ffrf_symbolic_mass(S, Ms), terms)


def ffrf_force_vector(S, t, y, yd, p, u=None):
    """``q − k`` with the elastic bodies' terms."""
    y = np.asarray(y, dtype=np.float64)
    yd = np.asarray(yd, dtype=np.float64)
    terms = ffrf_terms(S, ffrf_kin(S, t, y, yd, p, u), y, yd)
    fs = S["rigid"]["force_vector"](t, S["SV"] @ y, S["SV"] @ yd, p, u)
    return ffrf_add_force(S, S["SW"].T @ fs, terms)


def ffrf_rhs(S, t, x, p, u=None):
    """``[ẏ, M⁻¹ (q − k)]`` (:func:`ffrf_dynamics`)."""
    x = np.asarray(x, dtype=np.float64)
    M, f = ffrf_dynamics(S, t, x, p, u)
    n = S["n"]
    return np.concatenate((x[n:2 * n], ffrf_solve(S, M, f)))


def ffrf_dynamics(S, t, x, p, u=None):
    """``(M, q − k)`` at the state ``x`` (float64): one evaluation of the symbolic state
    ``[S_V y, S_V ẏ]``, of the symbolic part (its ``rhs_parts``: the hidden outputs,
    ``M_s`` and ``(q − k)_s`` from one CSE'd program) and of the frame
    kinematics and mass blocks for both."""
    n = S["n"]
    y, yd = x[:n], x[n:2 * n]
    xs = np.dot(x[:2 * n].reshape(2, n), S["maps"][1]).ravel()
    kin, Ms, fs = S["rigid"]["rhs_parts"](t, xs, p, u)   # one CSE'd call (codegen/writer.py)
    terms = ffrf_terms(S, kin, y, yd)
    return (ffrf_add_mass(S, ffrf_symbolic_mass(S, Ms), terms),
            ffrf_add_force(S, np.dot(S["SW"].T, fs), terms))


def ffrf_kin_jacobians(S, t, y, yd, p, u):
    """``∂kin/∂y``, ``∂kin/∂ẏ`` (through ``y_s = S_V y``) and ``∂kin/∂u``: the analytic
    output Jacobians of the symbolic part."""
    xs = np.concatenate((S["SV"] @ y, S["SV"] @ yd))
    Cs, Ds = S["rigid"]["output_jacobians"](t, xs, p, u)
    Cs, ns = Cs[S["nhidden"]:], S["ns"]
    return (ffrf_sparse_product(Cs[:, :ns], S["SV"]), ffrf_sparse_product(Cs[:, ns:], S["SV"]),
            Ds[S["nhidden"]:])


def ffrf_sparse_product(A, B):
    """``A B`` through the rows and columns of ``A`` that are not zero (the frame
    kinematics of a body on a fixed frame are zero, and ``6 ns + 16`` rows per body times
    ``S_V`` would be the largest product of a Jacobian)."""
    r = np.flatnonzero(np.any(A, axis=1))
    c = np.flatnonzero(np.any(A, axis=0))
    out = np.zeros((A.shape[0], B.shape[1]), dtype=np.result_type(A, B))
    out[r] = A[np.ix_(r, c)] @ B[c]
    return out


def ffrf_force_directional(S, kin, y, yd, directions):
    """Directional derivatives of the elastic terms of ``q − k`` (complex step), one
    column per ``(d kin, d y, d ẏ)``."""
    h = S["step"]
    out = np.empty((S["n"], len(directions)))
    zero = np.zeros(S["n"], dtype=complex)
    for j, (dk, dy, dyd) in enumerate(directions):
        f = ffrf_add_force(S, zero, ffrf_terms(S, kin + 1j * h * dk, y + 1j * h * dy,
                                               yd + 1j * h * dyd))
        out[:, j] = f.imag / h
    return out


def ffrf_moving(S):
    """The context with only the bodies whose frame moves (the others are linear in their
    coordinates and need no complex step)."""
    return dict(S, bodies=tuple(b for b in S["bodies"] if "fixed" not in b))


def ffrf_fixed_force_jacobians(S, fy, fyd):
    """The Jacobians of the elastic rows of bodies on a fixed frame, in place: their load
    ``Ct (ā − g) + Ke q + De q̇ + kσ`` is linear in ``q``, ``q̇`` and ``ā − g`` is constant (the
    frame never moves), so ``∂/∂q = Ke`` and ``∂/∂q̇ = De``."""
    for b in S["bodies"]:
        if "fixed" not in b:
            continue
        e = slice(b["first"], b["first"] + b["nq"])
        fy[e, e] -= b["Ke"]
        fyd[e, e] -= b["De"]


def ffrf_force_jacobians(S, t, y, yd, p, u=None):
    """``∂(q−k)/∂y``, ``∂(q−k)/∂ẏ`` (n, n) and ``∂(q−k)/∂u`` (n, nu)."""
    y = np.asarray(y, dtype=np.float64)
    yd = np.asarray(yd, dtype=np.float64)
    if u is None:
        u = S["default_inputs"](t, p)
    SV, SW, n = S["SV"], S["SW"], S["n"]
    fys, fyds, fus = S["rigid"]["force_jacobians"](t, SV @ y, SV @ yd, p, u)
    fy, fyd = ffrf_sandwich(SW, fys, SV), ffrf_sandwich(SW, fyds, SV)
    fu = SW.T @ fus
    ffrf_fixed_force_jacobians(S, fy, fyd)
    Sm = ffrf_moving(S)
    if Sm["bodies"]:                          # complex steps for the moving bodies only
        kin = ffrf_kin(S, t, y, yd, p, u)
        Ky, Kyd, Ku = ffrf_kin_jacobians(S, t, y, yd, p, u)
        z, eye = np.zeros(n), np.eye(n)
        fy += ffrf_force_directional(Sm, kin, y, yd, [(Ky[:, j], eye[j], z) for j in range(n)])
        fyd += ffrf_force_directional(Sm, kin, y, yd,
                                      [(Kyd[:, j], z, eye[j]) for j in range(n)])
        if fu.shape[1]:
            fu += ffrf_force_directional(Sm, kin, y, yd,
                                         [(Ku[:, k], z, z) for k in range(fu.shape[1])])
    sens = ffrf_sigma_sensitivity(S, t, y, p, u)
    if sens is not None:                      # the weights move with y and u
        Fs = ffrf_sigma_terms(S, t, y, yd, p, u)
        fy += Fs @ sens[0]
        fu += Fs @ sens[1]
    return fy, fyd, fu


def ffrf_mass_matrix_times_derivative(S, t, y, p, a, u=None):
    """``∂(M(y) a)/∂y`` for a fixed vector ``a``, shape (n, n)."""
    y = np.asarray(y, dtype=np.float64)
    a = np.asarray(a, dtype=np.float64)
    if u is None:
        u = S["default_inputs"](t, p)
    SV, SW, n, h = S["SV"], S["SW"], S["n"], S["step"]
    dMa = ffrf_sandwich(SW, S["rigid"]["mass_matrix_times_derivative"](t, SV @ y, p, SV @ a, u),
                        SV)
    z = np.zeros(n)
    Sm = ffrf_moving(S)                      # M_b of a body on a fixed frame is constant
    if Sm["bodies"]:
        kin = ffrf_kin(S, t, y, z, p, u)
        Ky = ffrf_kin_jacobians(S, t, y, z, p, u)[0]
        zero = np.zeros((n, n), dtype=complex)
        for j in range(n):
            dy = np.zeros(n)
            dy[j] = 1.0
            Mc = ffrf_add_mass(Sm, zero, ffrf_terms(Sm, kin + 1j * h * Ky[:, j],
                                                    y + 1j * h * dy, z))
            dMa[:, j] += (Mc @ a).imag / h
    sens = ffrf_sigma_sensitivity(S, t, y, p, u)
    if sens is not None:
        dMa += ffrf_sigma_terms(S, t, y, z, p, u, a) @ sens[0]
    return dMa


def ffrf_rhs_jacobian(S, t, x, p, u=None):
    """``∂rhs/∂x = [[0, I], [M⁻¹(∂f/∂y − ∂(M ÿ)/∂y), M⁻¹ ∂f/∂ẏ]]``."""
    x = np.asarray(x, dtype=np.float64)
    n = S["n"]
    y, yd = x[:n], x[n:2 * n]
    M, f = ffrf_dynamics(S, t, x, p, u)
    ydd = ffrf_solve(S, M, f)
    fy, fyd, _fu = ffrf_force_jacobians(S, t, y, yd, p, u)
    dMa = ffrf_mass_matrix_times_derivative(S, t, y, p, ydd, u)
    J = np.zeros((2 * n, 2 * n))
    J[:n, n:] = np.eye(n)
    J[n:, :] = ffrf_solve(S, M, np.hstack((fy - dMa, fyd)))
    return J


def ffrf_symbolic_state(S, x):
    """``[S_V y, S_V ẏ]``: the state of the symbolic part."""
    x = np.asarray(x, dtype=np.float64)
    n = S["n"]
    return np.concatenate((S["SV"] @ x[:n], S["SV"] @ x[n:2 * n]))


def ffrf_outputs(S, t, x, p, u=None):
    """The module's own outputs."""
    return S["rigid"]["outputs"](t, ffrf_symbolic_state(S, x), p, u)[:S["nhidden"]]


def ffrf_output_jacobians(S, t, x, p, u=None):
    """``∂out/∂x`` (ny, 2n) and ``∂out/∂u`` (ny, nu)."""
    x = np.asarray(x, dtype=np.float64)
    if u is None:
        u = S["default_inputs"](t, p)
    Cs, Ds = S["rigid"]["output_jacobians"](t, ffrf_symbolic_state(S, x), p, u)
    Cs, ns, SV, n = Cs[:S["nhidden"]], S["ns"], S["SV"], S["n"]
    C, D = np.hstack((Cs[:, :ns] @ SV, Cs[:, ns:] @ SV)), Ds[:S["nhidden"]].copy()
    sens = ffrf_sigma_sensitivity(S, t, x[:n], p, u)
    if sens is not None:                      # S_V(σ) moves with the schedule
        dSV = ffrf_dsv(S)
        Os = np.stack([Cs[:, :ns] @ (d @ x[:n]) + Cs[:, ns:] @ (d @ x[n:2 * n]) for d in dSV],
                      axis=1)
        C[:, :n] += Os @ sens[0]
        D += Os @ sens[1]
    return C, D


def ffrf_sigma_parameter_sensitivity(S, t, y, p, u):
    """``∂σ/∂p`` (k, np) of a mixed context, or ``None`` when the schedules depend on no
    parameter."""
    if "base" not in S or S["schedule_parameter_jacobian"] is None:
        return None
    Sp = S["schedule_parameter_jacobian"](t, S["base"]["SV"] @ y, p, u)
    return Sp if np.any(Sp) else None


def ffrf_force_parameter_jacobian(S, t, y, yd, p, u=None):
    """``∂(q−k)/∂p`` (n, np) at fixed ``u``: the symbolic part's, the elastic terms through
    the frame kinematics (complex step along ``∂kin/∂p``, for bodies on fixed frames too:
    their gravity may depend on parameters) and through the schedules."""
    y = np.asarray(y, dtype=np.float64)
    yd = np.asarray(yd, dtype=np.float64)
    if u is None:
        u = S["default_inputs"](t, p)
    SV, SW, n = S["SV"], S["SW"], S["n"]
    fp = SW.T @ S["rigid"]["force_parameter_jacobian"](t, SV @ y, SV @ yd, p, u)
    if S["bodies"] and fp.shape[1]:           # every body: g of a fixed frame may move too
        kin = ffrf_kin(S, t, y, yd, p, u)
        xs = np.concatenate((SV @ y, SV @ yd))
        Kp = S["rigid"]["output_parameter_jacobian"](t, xs, p, u)[S["nhidden"]:]
        z = np.zeros(n)
        used = [j for j in range(fp.shape[1]) if np.any(Kp[:, j])]
        if used:
            fp[:, used] += ffrf_force_directional(S, kin, y, yd, [(Kp[:, j], z, z)
                                                                   for j in used])
    sens = ffrf_sigma_parameter_sensitivity(S, t, y, p, u)
    if sens is not None:
        fp += ffrf_sigma_terms(S, t, y, yd, p, u) @ sens
    return fp


def ffrf_mass_matrix_parameter_derivative(S, t, y, p, a, u=None):
    """``∂(M(y) a)/∂p`` (n, np) for a fixed vector ``a``."""
    y = np.asarray(y, dtype=np.float64)
    a = np.asarray(a, dtype=np.float64)
    if u is None:
        u = S["default_inputs"](t, p)
    SV, SW, n, h = S["SV"], S["SW"], S["n"], S["step"]
    dMa = SW.T @ S["rigid"]["mass_matrix_parameter_derivative"](t, SV @ y, p, SV @ a, u)
    z = np.zeros(n)
    Sm = ffrf_moving(S)
    if Sm["bodies"] and dMa.shape[1]:
        kin = ffrf_kin(S, t, y, z, p, u)
        xs = np.concatenate((SV @ y, SV @ z))
        Kp = S["rigid"]["output_parameter_jacobian"](t, xs, p, u)[S["nhidden"]:]
        zero = np.zeros((n, n), dtype=complex)
        for j in np.flatnonzero(np.any(Kp, axis=0)):
            Mc = ffrf_add_mass(Sm, zero, ffrf_terms(Sm, kin + 1j * h * Kp[:, j], y, z))
            dMa[:, j] += (Mc @ a).imag / h
    sens = ffrf_sigma_parameter_sensitivity(S, t, y, p, u)
    if sens is not None:
        dMa += ffrf_sigma_terms(S, t, y, z, p, u, a) @ sens
    return dMa


def ffrf_rhs_parameter_jacobian(S, t, x, p, u=None):
    """``∂rhs/∂p = [0; M⁻¹(∂(q−k)/∂p − ∂(M ÿ)/∂p)]`` (STATE_SIZE, np) at fixed ``u``."""
    x = np.asarray(x, dtype=np.float64)
    n = S["n"]
    M, f = ffrf_dynamics(S, t, x, p, u)
    ydd = ffrf_solve(S, M, f)
    fp = ffrf_force_parameter_jacobian(S, t, x[:n], x[n:2 * n], p, u)
    dMa = ffrf_mass_matrix_parameter_derivative(S, t, x[:n], p, ydd, u)
    J = np.zeros((2 * n, fp.shape[1]))
    if fp.shape[1]:
        J[n:, :] = ffrf_solve(S, M, fp - dMa)
    return J


def ffrf_output_parameter_jacobian(S, t, x, p, u=None):
    """``∂out/∂p`` (ny, np) at fixed state and ``u``."""
    x = np.asarray(x, dtype=np.float64)
    if u is None:
        u = S["default_inputs"](t, p)
    n, ns, nh = S["n"], S["ns"], S["nhidden"]
    xs = ffrf_symbolic_state(S, x)
    Op = S["rigid"]["output_parameter_jacobian"](t, xs, p, u)[:nh].copy()
    sens = ffrf_sigma_parameter_sensitivity(S, t, x[:n], p, u)
    if sens is not None:                      # S_V(σ) moves with the schedule
        Cs = S["rigid"]["output_jacobians"](t, xs, p, u)[0][:nh]
        Os = np.stack([Cs[:, :ns] @ (d @ x[:n]) + Cs[:, ns:] @ (d @ x[n:2 * n])
                       for d in ffrf_dsv(S)], axis=1)
        Op += Os @ sens
    return Op


def ffrf_sigma_steps(S):
    """The mixed context at ``σ + i h e_k`` for each parametric body ``k`` (the complex
    step in ``σ``)."""
    sigma, h = S["sigma"], S["step"]
    return [ffrf_mixed(S["base"], sigma + 1j * h * np.eye(sigma.size)[k])
            for k in range(sigma.size)]


def ffrf_dsv(S):
    """``∂S_V/∂σ_k`` (one (ns, n) array per parametric body) of a mixed context."""
    return [Sc["SV"].imag / S["step"] for Sc in ffrf_sigma_steps(S)]


def ffrf_energy(S, t, x, p, u=None):
    """``[kinetic, gravity, springs, strain]``: the symbolic part's energies plus, per body,
    ``½ zᵀ M_b z`` (``z = [v; ω; q̇]``), ``m e − g·md(q)`` and ``½ qᵀ Ke q + kσᵀ q``."""
    x = np.asarray(x, dtype=np.float64)
    n = S["n"]
    y, yd = x[:n], x[n:2 * n]
    out = np.array(S["rigid"]["energy"](t, ffrf_symbolic_state(S, x), p, u), dtype=np.float64)
    kin = ffrf_kin(S, t, y, yd, p, u)
    for b in S["bodies"]:
        tail = ffrf_frame(S, b, kin)[2]
        w, g, v, e = tail[6:9], tail[9:12], tail[12:15], tail[15]
        sl = slice(b["first"], b["first"] + b["nq"])
        q, qd = y[sl], yd[sl]
        out[0] += ffrf_kinetic_energy(b, v, w, q, qd)
        out[1] += b["mass"] * e - g @ ffrf_first_moment(b, q)
        out[3] += ffrf_strain_energy(b, q, g)
    return out


def ffrf_constraints(S, t, y, p, u=None):
    """``g(S_V y, t)``."""
    return S["rigid"]["constraints"](t, S["SV"] @ np.asarray(y, dtype=np.float64), p, u)


def ffrf_constraint_jacobian(S, t, y, p, u=None):
    """``G = G_s S_V`` (+ ``G_s (∂S_V/∂σ) y ∂σ/∂y`` for schedules of the coordinates): the
    constraints move with the node coordinates."""
    y = np.asarray(y, dtype=np.float64)
    Gs = S["rigid"]["constraint_jacobian"](t, S["SV"] @ y, p, u)
    G = Gs @ S["SV"]
    sens = ffrf_sigma_sensitivity(S, t, y, p, S["default_inputs"](t, p) if u is None else u)
    if sens is not None:
        G = G + np.stack([Gs @ (d @ y) for d in ffrf_dsv(S)], axis=1) @ sens[0]
    return G


def ffrf_constraint_reaction_jacobian(S, t, y, p, u=None):
    """``G_R = G_s S_W``: the reactions ``G_Rᵀ λ`` reach the elastic rows of a two-sided
    host through ``W_P`` like every node load."""
    y = np.asarray(y, dtype=np.float64)
    return S["rigid"]["constraint_jacobian"](t, S["SV"] @ y, p, u) @ S["SW"]


def ffrf_constraint_time_derivative(S, t, y, p, u=None):
    """``∂g/∂t``."""
    y = np.asarray(y, dtype=np.float64)
    return S["rigid"]["constraint_time_derivative"](t, S["SV"] @ y, p, u)


def ffrf_constraint_gamma(S, t, y, yd, p, u=None):
    """``γ`` with ``G ÿ + γ = 0``."""
    SV = S["SV"]
    return S["rigid"]["constraint_gamma"](t, SV @ np.asarray(y, dtype=np.float64),
                                          SV @ np.asarray(yd, dtype=np.float64), p, u)


def ffrf_node_positions(S, nodes, r, R, t, x, p, u=None):
    """Per elastic body of ``nodes`` (``first``, ``nq``, ``frame``: index into the frame
    poses ``r`` (nF, 3), ``R`` (nF, 3, 3) or −1 for ISYS, ``cloud``: :func:`ffrf_cloud`, and
    for parametric bodies ``k``, the index of its schedule): its nodes at ``x_P + Φ_P q``
    in ISYS (nk, 3), mixed at the schedule."""
    sigma = ffrf_schedule(S, t, p, x, u) if S["parametric"] else ()
    out = []
    for b in nodes:
        cloud = b["cloud"]
        if "values" in cloud:
            cloud = ffrf_mix(cloud["mixing"], ffrf_weights(cloud["values"], cloud["coeff"],
                                                           sigma[b["k"]], b["name"]))
        q = x[b["first"]:b["first"] + b["nq"]]
        local = cloud["origin"] + cloud["phi"] @ q
        f = b["frame"]
        out.append(local if f < 0 else r[f] + local @ R[f].T)
    return out


def ffrf_cloud(datasets, values=None, coeff=None, samples=None):
    """The node cloud of :func:`ffrf_node_positions`: ``origin`` (nk, 3) and ``phi``
    (nk, 3, nq) of a body's data (``nodes.origin.m0``, ``nodes.phi``), or of a parametric
    body (``values``, ``coeff`` of its weights) the mixing form of its data sets (samples,
    then slopes and curvatures, the columns of its weights; ``samples``: their number,
    default all data sets) with ``values``, ``coeff``. Made at generation."""
    clouds = [{"origin": np.asarray(d["nodes.origin.m0"], dtype=np.float64)[:, :, 0],
               "phi": np.asarray(d["nodes.phi"], dtype=np.float64)} for d in datasets]
    if values is None:
        return clouds[0]
    values = np.asarray(values, dtype=np.float64)
    orders = np.arange(len(clouds)) // (samples or len(clouds))
    return {"mixing": ffrf_stack(clouds, None, orders, float(values[-1] - values[0])),
            "values": values, "coeff": np.asarray(coeff, dtype=np.float64)}


#: The protocol functions a module with elastic bodies delegates to (protocol name → splice
#: function); each takes the context first.
PROTOCOL = {
    "mass_matrix": ffrf_mass_matrix,
    "force_vector": ffrf_force_vector,
    "rhs": ffrf_rhs,
    "force_jacobians": ffrf_force_jacobians,
    "mass_matrix_times_derivative": ffrf_mass_matrix_times_derivative,
    "rhs_jacobian": ffrf_rhs_jacobian,
    "outputs": ffrf_outputs,
    "output_jacobians": ffrf_output_jacobians,
    "energy": ffrf_energy,
    "constraints": ffrf_constraints,
    "constraint_jacobian": ffrf_constraint_jacobian,
    "constraint_reaction_jacobian": ffrf_constraint_reaction_jacobian,
    "constraint_time_derivative": ffrf_constraint_time_derivative,
    "constraint_gamma": ffrf_constraint_gamma,
    "force_parameter_jacobian": ffrf_force_parameter_jacobian,
    "mass_matrix_parameter_derivative": ffrf_mass_matrix_parameter_derivative,
    "rhs_parameter_jacobian": ffrf_rhs_parameter_jacobian,
    "output_parameter_jacobian": ffrf_output_parameter_jacobian,
}

#: The functions a generated module embeds after the kernel's (in this order).
SPLICE_FUNCTIONS = (ffrf_weights, ffrf_mix, ffrf_unmix, ffrf_derived, ffrf_expand, ffrf_system,
                    ffrf_index, ffrf_mass_maps, ffrf_block_constant, ffrf_block,
                    ffrf_dense_solve, ffrf_solve,
                    ffrf_schedule, ffrf_at, ffrf_mixed, ffrf_sigma_sensitivity,
                    ffrf_sigma_parameter_sensitivity,
                    ffrf_sigma_steps, ffrf_sigma_terms, ffrf_dsv, ffrf_frame,
                    ffrf_terms, ffrf_add_mass, ffrf_add_force, ffrf_dynamics,
                    ffrf_symbolic_mass,
                    ffrf_sandwich, ffrf_kin,
                    ffrf_kin_jacobians, ffrf_sparse_product,
                    ffrf_force_directional, ffrf_moving, ffrf_fixed_force_jacobians,
                    ffrf_symbolic_state, ffrf_node_positions,
                    *PROTOCOL.values())
