"""Generated modules of systems with elastic bodies (equations.md §2, issue 6).

The symbolic part of the equations (rigid bodies, forces, outputs, constraints, node frames)
is rendered by :func:`~neweul_py.codegen.writer.render_module` as usual, with the
reference-frame kinematics of every elastic body (``J_T``, ``J_R``, ``ā``, ``ᾱ``, ``ω``,
``g``; :func:`neweul_py.equations.elastic.elastic_splices`) appended as hidden outputs. Its
public functions are renamed ``_rigid_*`` and wrapped by functions that

1. map the independent coordinates to the symbolic ones, ``y_s = S_V y`` (the dependent node
   coordinates ``[u; θ] = [Φ_P; Ψ_P] q`` of the node frames), and back,
   ``M = S_Wᵀ M_s S_V``, ``q − k = S_Wᵀ (q − k)_s`` (``S_W``: left basis, so node loads enter
   the elastic rows as ``W_Pᵀ f``; :func:`~neweul_py.equations.elastic.node_coordinate_map`);
   constraints likewise: ``g(S_V y)``, ``G = G_s S_V`` (and ``γ``) for the constraint
   itself, ``G_R = G_s S_W`` for the reactions ``G_Rᵀ λ`` (``constraint_reaction_jacobian``:
   a constraint on a node frame of a two-sided body loads its elastic rows through ``W_P``);
2. add the elastic bodies' own terms with small matrix products on the *numeric* invariants::

    M   += J_Wᵀ M_b(q) J_V,   q − k −= J_Wᵀ (M_b(q) [ā − g; ᾱ; 0] + h_ω + [0; 0; Ke q + De q̇ + kσ])

   with ``J_V = J_b S_V`` and ``J_W = J_b S_W`` (``J_b = [J_T; J_R; E]`` in the symbolic
   coordinates): the two differ only when the body hangs on a node frame of a two-sided
   body, whose elastic rows then get the loads of the child through ``W_Pᵀ`` exactly as
   those of rigid bodies and force elements on that node.

So a body with 200 modes costs a few (nq × nq) products per call and six symbolic coordinates
per node frame, not code size.

Data in the module
------------------
Each invariant array is embedded as a base64 string of its zlib-compressed little-endian
float64 bytes (``_ELASTIC_DATA``, decoded once at import by ``_unpack``); the text depends only
on the arrays, so regeneration is byte-identical. The module still needs only NumPy (and the
standard library's ``base64``/``zlib``).

Linearization
-------------
``force_jacobians`` and ``mass_matrix_times_derivative``: the symbolic part analytic as before
(mapped by ``S_Wᵀ``, ``S_V``). The elastic terms are polynomials in the frame kinematics
``kin = (J_T, J_R, ā, ᾱ, ω, g)``, ``q`` and ``q̇``; their Jacobians follow by the chain rule
``∂f_e/∂x = ∂f_e/∂kin · ∂kin/∂x + ∂f_e/∂(q, q̇) · ∂(q, q̇)/∂x`` for ``x = y, ẏ, u`` (the
inputs with their rates ``d_u``, ``dd_u``), with ``∂kin/∂(y_s, ẏ_s, u)`` the analytic output
Jacobians of the hidden outputs (through ``y_s = S_V y``) and the directional derivatives of
the polynomial part by the complex step (``Im f(x + i h d)/h``, ``h = 1e-30``: exact to
round-off, no truncation error; Squire & Trapp, SIAM Rev. 40 (1998) 110–112).
``rhs_jacobian`` combines these as for rigid models.
"""

from __future__ import annotations

import base64
import dataclasses
import zlib
from typing import Any

import numpy as np
import sympy as sp

from ..equations.elastic import ElasticSplice, elastic_splices, node_coordinate_map
from ..errors import GenerationError

__all__ = ["render_elastic_module"]

_RENAMED = ("mass_matrix", "force_vector", "rhs", "force_jacobians",
            "mass_matrix_times_derivative", "rhs_jacobian", "outputs", "output_jacobians",
            "constraints", "constraint_jacobian", "constraint_time_derivative",
            "constraint_gamma")


def _pack(a: np.ndarray) -> str:
    raw = np.ascontiguousarray(np.asarray(a, dtype="<f8")).tobytes()
    return base64.b64encode(zlib.compress(raw, 6)).decode("ascii")


def _body_arrays(sp_: ElasticSplice) -> dict[str, np.ndarray | None]:
    """The arrays the runtime needs, in the runtime's layouts (see ``_RUNTIME``)."""
    d = sp_.body.data
    nq = sp_.body.nq

    def m1(key: str) -> np.ndarray | None:
        a = d.get(key)
        if a is None or not np.any(a):
            return None
        return np.asarray(a, dtype=np.float64)

    md1 = m1("md.m1")
    return {
        "md0": d["md.m0"][:, 0],
        "md1": np.zeros((3, nq)) if md1 is None else md1[:, :, 0],
        "J0": d["J.m0"], "J1": m1("J.m1"),                          # (3, nq, 3)
        "Ct0": d["Ct.m0"], "Ct1": m1("Ct.m1"),                      # (nq, nq, 3)
        "Cr0": d["Cr.m0"], "Cr1": m1("Cr.m1"),
        "Crv0": d["Crv.m0"], "Crv1": m1("Crv.m1"),
        "Me": d["Me.m0"], "Gr": d["Gr.m0"], "Ge": d["Ge.m0"],       # per-mode layout
        "Oe0": d["Oe.m0"], "Oe1": m1("Oe.m1"),                      # (nq, nq, 6)
        "ks": d["ksigma.m0"][:, 0], "Ke": d["Ke.m0"], "De": d["De.m0"],
    }


def _data_lines(splices: tuple[ElasticSplice, ...], offsets: list[int],
                firsts: list[int]) -> list[str]:
    lines = ["_ELASTIC_DATA = ("]
    for s, off, first in zip(splices, offsets, firsts, strict=True):
        b = s.body
        lines.append("    {")
        lines.append(f"        'name': {b.name!r},")
        lines.append(f"        'mass': {float(b.data['m'])!r},")
        lines.append(f"        'first': {first},")
        lines.append(f"        'nq': {b.nq},")
        lines.append(f"        'kin': {off},")
        for key, arr in _body_arrays(s).items():
            if arr is None:
                lines.append(f"        {key!r}: None,")
            else:
                shape = tuple(int(x) for x in np.shape(arr))
                lines.append(f"        {key!r}: ({shape!r}, {_pack(arr)!r}),")
        lines.append("    },")
    lines.append(")")
    return lines


_RUNTIME = '''
# ---- elastic bodies (floating frame of reference, equations.md §2; codegen/elastic.py)
def _unpack(entry):
    if entry is None or not isinstance(entry, tuple):
        return entry
    shape, text = entry
    raw = _zlib.decompress(_b64.b64decode(text))
    return _np.frombuffer(raw, dtype="<f8").reshape(shape).copy()


def _prepare(b):
    """Stack every first-order invariant so that X(q) = X0 + X1 q is one matrix product."""
    b = {k: _unpack(v) for k, v in b.items()}
    nq = b["nq"]
    zeros, firsts, where, start = [], [], {}, 0
    for key in ("J", "Ct", "Cr", "Crv", "Oe"):
        m0 = b[key + "0"]
        m1 = b[key + "1"]                       # (rows, nq, cols) or None
        size = m0.size
        zeros.append(m0.ravel())
        firsts.append(_np.zeros((size, nq)) if m1 is None
                      else m1.transpose(0, 2, 1).reshape(size, nq))
        where[key] = (start, start + size, m0.shape)
        start += size
    b["T0"] = _np.concatenate(zeros)
    b["T1"] = _np.ascontiguousarray(_np.vstack(firsts))
    b["where"] = where
    return b


_ELASTIC = tuple(_prepare(b) for b in _ELASTIC_DATA)
_N = len(COORDINATES)
_NHIDDEN = len(OUTPUTS)
_SVA = _unpack(_SV_ACTIVE)
_SWA = _unpack(_SW_ACTIVE)
_SAME_BASES = bool(_np.array_equal(_SVA, _SWA))
# complex step of the elastic terms (polynomials in the frame kinematics, q and q'):
# Im f(x + i h d) / h = f'(x) d to round-off for this h (Squire & Trapp 1998)
_STEP = 1e-30


def _skew(v):
    return _np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _body_terms(b, kin, y, yd):
    """Frame kinematics, q, q', md(q) and the mass blocks of one elastic body.

    The frame Jacobians come twice: ``J_T S_V`` for the motion (the node coordinates of a
    host body's node frame are ``[Phi_P; Psi_P] q``) and ``J_T S_W`` for the rows (the test
    directions of a two-sided host: loads of a child body on its node reach the host's
    elastic equations as ``W_P^T f``, like those of rigid bodies and force elements)."""
    i0, nq = b["first"], b["nq"]
    o = b["kin"]
    ns = _NS
    JTs = kin[o:o + 3 * ns].reshape(3, ns)
    JRs = kin[o + 3 * ns:o + 6 * ns].reshape(3, ns)
    v = kin[o + 6 * ns:o + 6 * ns + 12]
    q = y[i0:i0 + nq]
    qd = yd[i0:i0 + nq]
    X = b["T0"] + b["T1"] @ q
    X = {k: X[s:e].reshape(shape) for k, (s, e, shape) in b["where"].items()}
    md = b["md0"] + b["md1"] @ q
    Mrr = _np.zeros((6, 6), dtype=X["J"].dtype)
    Mrr[0, 0] = Mrr[1, 1] = Mrr[2, 2] = b["mass"]
    Mrr[3:, :3] = _skew(md)
    Mrr[:3, 3:] = -Mrr[3:, :3]
    Mrr[3:, 3:] = X["J"]
    Mre = _np.vstack((b["md1"], X["Crv"].T))
    Mer = _np.hstack((X["Ct"], X["Cr"]))
    Jv = _np.vstack((JTs, JRs)) @ _SVA
    Jw = Jv if _SAME_BASES else _np.vstack((JTs, JRs)) @ _SWA
    return Jv, Jw, v, q, qd, md, Mrr, Mre, Mer, X["Oe"]


def _terms(kin, y, yd):
    return [_body_terms(b, kin, y, yd) for b in _ELASTIC]


def _elastic_mass(M, terms):
    """M += J_W^T M_b(q) J_V for every elastic body (J_W = J_V but on a two-sided host's
    node coordinates)."""
    for b, (Jv, Jw, _v, _q, _qd, _md, Mrr, Mre, Mer, _Oe) in zip(_ELASTIC, terms):
        e = slice(b["first"], b["first"] + b["nq"])
        M += Jw.T @ (Mrr @ Jv)
        M[:, e] += Jw.T @ Mre
        M[e, :] += Mer @ Jv
        M[e, e] += b["Me"]
    return M


def _elastic_force(f, terms):
    """q - k -= J_W^T (M_b [abar - g; alphabar; 0] + h_w + [0; 0; Ke q + De qd + ks])."""
    for b, (_Jv, Jw, v, q, qd, md, Mrr, _Mre, Mer, Oe) in zip(_ELASTIC, terms):
        abar, alphabar, w, g = v[0:3], v[3:6], v[6:9], v[9:12]
        acc = _np.concatenate((abar - g, alphabar))
        wt = _skew(w)
        wq = _np.array([w[0] * w[0], w[1] * w[1], w[2] * w[2],
                        w[0] * w[1], w[1] * w[2], w[0] * w[2]])
        qw = _np.outer(qd, w).ravel()
        hr = Mrr @ acc
        hr[:3] += wt @ (wt @ md) + 2.0 * (wt @ (b["md1"] @ qd))
        hr[3:] += wt @ (Mrr[3:, 3:] @ w) + b["Gr"] @ qw
        he = Mer @ acc + Oe @ wq + b["Ge"] @ qw + b["ks"] + b["Ke"] @ q + b["De"] @ qd
        f -= Jw.T @ hr
        f[b["first"]:b["first"] + b["nq"]] -= he
    return f


def _sym(v):
    """Coordinates of the symbolic part, y_s = S_V y: the rigid coordinates and the
    dependent node coordinates [u; theta] = [Phi_P; Psi_P] q."""
    return _SVA @ v


def _kin(t, ys, yds, p, u):
    return _rigid_outputs(t, _np.concatenate((ys, yds)), p, u)[_NHIDDEN:]


def _reduce(Ms):
    """S_W^T M_s S_V."""
    return _SWA.T @ Ms @ _SVA


def _all(t, y, yd, p, u, mass=True, force=True):
    y = _np.asarray(y, dtype=_np.float64)
    yd = _np.asarray(yd, dtype=_np.float64)
    ys, yds = _sym(y), _sym(yd)
    terms = _terms(_kin(t, ys, yds, p, u), y, yd)
    M = f = None
    if mass:
        M = _elastic_mass(_reduce(_rigid_mass_matrix(t, ys, p, u)), terms)
    if force:
        f = _elastic_force(_SWA.T @ _rigid_force_vector(t, ys, yds, p, u), terms)
    return M, f


def mass_matrix(t, y, p, u=None):
    """Mass matrix ``M(y, t)``, shape (n, n); unsymmetric with two-sided elastic data."""
    return _all(t, y, _np.zeros(_N), p, u, force=False)[0]


def force_vector(t, y, yd, p, u=None):
    """Generalized forces ``q - k``, shape (n,), with the elastic bodies' terms."""
    return _all(t, y, yd, p, u, mass=False)[1]


def rhs(t, x, p, u=None):
    """First-order form ``[yd, M^-1 (q - k)]`` of the equations of motion."""
    x = _np.asarray(x, dtype=_np.float64)
    M, f = _all(t, x[:_N], x[_N:2 * _N], p, u)
    xd = _np.empty(2 * _N)
    xd[:_N] = x[_N:2 * _N]
    xd[_N:] = _np.linalg.solve(M, f)
    return xd


def _kin_jacobians(t, ys, yds, p, u):
    """d kin/dy, d kin/dyd (through y_s = S_V y) and d kin/du of the frame kinematics of the
    elastic bodies: the analytic output Jacobians of the symbolic part."""
    Cs, Ds = _rigid_output_jacobians(t, _np.concatenate((ys, yds)), p, u)
    Cs = Cs[_NHIDDEN:]
    return Cs[:, :_NS] @ _SVA, Cs[:, _NS:] @ _SVA, Ds[_NHIDDEN:]


def _elastic_force_derivatives(kin, y, yd, directions):
    """Directional derivatives of the elastic terms of q - k (complex step, exact to
    round-off): one column per ``(d kin, d y, d yd)`` of ``directions``."""
    h = _STEP
    out = _np.empty((_N, len(directions)))
    for j, (dk, dy, dyd) in enumerate(directions):
        terms = _terms(kin + 1j * h * dk, y + 1j * h * dy, yd + 1j * h * dyd)
        out[:, j] = _elastic_force(_np.zeros(_N, dtype=complex), terms).imag / h
    return out


def force_jacobians(t, y, yd, p, u=None):
    """``d(q-k)/dy``, ``d(q-k)/dyd`` (n, n) and ``d(q-k)/du`` (n, nu): the symbolic part
    analytic (mapped by S_W^T, S_V); the elastic terms by the chain rule through the
    analytic Jacobians of the frame kinematics (inputs, their rates and the node
    coordinates included), with the complex-step derivative of the (polynomial) elastic
    terms, exact to round-off."""
    y = _np.asarray(y, dtype=_np.float64)
    yd = _np.asarray(yd, dtype=_np.float64)
    if u is None:
        u = default_inputs(t, p)
    ys, yds = _sym(y), _sym(yd)
    fys, fyds, fus = _rigid_force_jacobians(t, ys, yds, p, u)
    fy, fyd, fu = _reduce(fys), _reduce(fyds), _SWA.T @ fus
    kin = _kin(t, ys, yds, p, u)
    Ky, Kyd, Ku = _kin_jacobians(t, ys, yds, p, u)
    z = _np.zeros(_N)
    eye = _np.eye(_N)
    fy += _elastic_force_derivatives(kin, y, yd, [(Ky[:, j], eye[j], z) for j in range(_N)])
    fyd += _elastic_force_derivatives(kin, y, yd,
                                      [(Kyd[:, j], z, eye[j]) for j in range(_N)])
    if fu.shape[1]:
        fu += _elastic_force_derivatives(kin, y, yd,
                                         [(Ku[:, k], z, z) for k in range(fu.shape[1])])
    return fy, fyd, fu


def mass_matrix_times_derivative(t, y, p, a, u=None):
    """``d(M(y) a)/dy`` for a fixed vector ``a``, shape (n, n); symbolic part analytic,
    elastic part by the chain rule as in ``force_jacobians`` (complex step of the
    polynomial elastic terms, exact to round-off)."""
    y = _np.asarray(y, dtype=_np.float64)
    a = _np.asarray(a, dtype=_np.float64)
    if u is None:
        u = default_inputs(t, p)
    ys = _sym(y)
    dMa = _reduce(_rigid_mass_matrix_times_derivative(t, ys, p, _sym(a), u))
    zs = _np.zeros(_NS)
    kin = _kin(t, ys, zs, p, u)
    Ky = _kin_jacobians(t, ys, zs, p, u)[0]
    z = _np.zeros(_N)
    h = _STEP
    for j in range(_N):
        e = _np.zeros(_N)
        e[j] = 1.0
        terms = _terms(kin + 1j * h * Ky[:, j], y + 1j * h * e, z)
        dMa[:, j] += (_elastic_mass(_np.zeros((_N, _N), dtype=complex), terms) @ a).imag / h
    return dMa


def rhs_jacobian(t, x, p, u=None):
    """``d rhs/dx`` = [[0, I], [M^-1(df/dy - d(M ydd)/dy), M^-1 df/dyd]]."""
    x = _np.asarray(x, dtype=_np.float64)
    y, yd = x[:_N], x[_N:2 * _N]
    M, f = _all(t, y, yd, p, u)
    ydd = _np.linalg.solve(M, f)
    fy, fyd, _fu = force_jacobians(t, y, yd, p, u)
    dMa = mass_matrix_times_derivative(t, y, p, ydd, u)
    J = _np.zeros((2 * _N, 2 * _N))
    J[:_N, _N:] = _np.eye(_N)
    J[_N:, :] = _np.linalg.solve(M, _np.hstack((fy - dMa, fyd)))
    return J


def outputs(t, x, p, u=None):
    """The outputs, ordered as ``OUTPUTS``."""
    x = _np.asarray(x, dtype=_np.float64)
    xs = _np.concatenate((_sym(x[:_N]), _sym(x[_N:2 * _N])))
    return _rigid_outputs(t, xs, p, u)[:_NHIDDEN]


def output_jacobians(t, x, p, u=None):
    """``dout/dx`` (ny, STATE_SIZE) and ``dout/du`` (ny, nu), analytic."""
    x = _np.asarray(x, dtype=_np.float64)
    xs = _np.concatenate((_sym(x[:_N]), _sym(x[_N:2 * _N])))
    Cs, Ds = _rigid_output_jacobians(t, xs, p, u)
    Cs = Cs[:_NHIDDEN]
    C = _np.hstack((Cs[:, :_NS] @ _SVA, Cs[:, _NS:] @ _SVA))
    return C, Ds[:_NHIDDEN].copy()


def constraints(t, y, p, u=None):
    """The constraints ``g(y, t)``, ordered as ``CONSTRAINTS``."""
    return _rigid_constraints(t, _sym(_np.asarray(y, dtype=_np.float64)), p, u)


def constraint_jacobian(t, y, p, u=None):
    """``G = dg/dy = G_s S_V``, shape (nc, n): the constraints move with the node
    coordinates ``[Phi_P; Psi_P] q``."""
    G = _rigid_constraint_jacobian(t, _sym(_np.asarray(y, dtype=_np.float64)), p, u)
    return G @ _SVA


def constraint_reaction_jacobian(t, y, p, u=None):
    """``G_R = G_s S_W``, shape (nc, n): the reactions are ``G_R^T lambda`` (on a node frame
    of a two-sided body they reach its elastic rows as ``W_P^T f``, like every node load);
    equal to ``constraint_jacobian`` where no two-sided node frame is involved."""
    G = _rigid_constraint_jacobian(t, _sym(_np.asarray(y, dtype=_np.float64)), p, u)
    return G @ _SWA


def constraint_time_derivative(t, y, p, u=None):
    """``dg/dt``, shape (nc,)."""
    return _rigid_constraint_time_derivative(t, _sym(_np.asarray(y, dtype=_np.float64)), p, u)


def constraint_gamma(t, y, yd, p, u=None):
    """``gamma`` with ``G ydd + gamma = 0``, shape (nc,)."""
    return _rigid_constraint_gamma(t, _sym(_np.asarray(y, dtype=_np.float64)),
                                   _sym(_np.asarray(yd, dtype=_np.float64)), p, u)
'''


def _symmetric(splices: tuple[ElasticSplice, ...]) -> bool:
    """Whether every elastic body's ``M_b`` is symmetric for all ``q`` (to round-off): one-sided
    data without geometric stiffening in the mass blocks (``Ct = md¹ᵀ``, ``Cr = Crv``)."""

    def same(a: np.ndarray | None, b: np.ndarray | None) -> bool:
        a = np.zeros(0) if a is None else np.asarray(a)
        b = np.zeros(0) if b is None else np.asarray(b)
        if not a.size and not b.size:
            return True
        if a.size and not b.size:
            return not np.any(a)
        if b.size and not a.size:
            return not np.any(b)
        scale = max(float(np.abs(a).max()), float(np.abs(b).max()), 1e-300)
        return a.shape == b.shape and float(np.abs(a - b).max()) <= 1e-12 * scale

    for s in splices:
        d = s.body.data
        if s.body.two_sided:
            return False
        md1 = d["md.m1"][:, :, 0].T if "md.m1" in d else None
        if not (same(d.get("Ct.m1"), None) and same(d["Cr.m0"], d["Crv.m0"])
                and same(d.get("Cr.m1"), d.get("Crv.m1")) and same(d["Ct.m0"], md1)
                and same(d["Me.m0"], d["Me.m0"].T)):
            return False
    return True


def _replace_line(text: str, prefix: str, line: str) -> str:
    lines = [ln for ln in text.splitlines() if ln.startswith(prefix)]
    if len(lines) != 1:
        raise GenerationError(f"elastic splice: cannot find the constant {prefix.strip()}")
    return text.replace(lines[0] + "\n", line + "\n", 1)


def render_elastic_module(equations: Any, source_hash: str, *, cse: bool = True) -> str:
    """The module text of a system with elastic bodies (see the module docstring).

    Parameters
    ----------
    equations
        The :class:`~neweul_py.equations.Equations` of the system (the symbolic part; its
        ``system`` holds the elastic bodies).
    source_hash
        SHA-256 of the description.
    cse
        Passed to :func:`~neweul_py.codegen.writer.render_module`.

    Raises
    ------
    GenerationError
        If the rendered symbolic part does not have the expected structure.
    """
    from .writer import _units, render_module

    system = equations.system
    splices = elastic_splices(system)
    keep, SV, SW = node_coordinate_map(system)
    elastic_q = {n for b in system.elastic_bodies for n in b.coordinate_names}
    active = [j for j, c in enumerate(system.coordinates) if c.name not in elastic_q]
    true_index = {j: k for k, j in enumerate(keep)}
    extra: list[sp.Expr] = []
    offsets = []
    for s in splices:
        offsets.append(len(extra))
        extra += s.expressions(active)
    names = list(equations.output_names)
    hidden = [f"_elastic_{i}" for i in range(len(extra))]
    # the symbolic part without the elastic coordinates (they appear in no expression: the
    # node frames move with the dependent node coordinates), so that it stays small
    a_idx = list(active)
    ce = equations.constraints
    if ce is not None:
        ce = dataclasses.replace(ce, G=ce.G[:, a_idx])
    eq2 = dataclasses.replace(
        equations,
        coordinates=tuple(equations.coordinates[j] for j in a_idx),
        velocities=tuple(equations.velocities[j] for j in a_idx),
        mass_matrix=equations.mass_matrix[a_idx, a_idx],
        force_vector=equations.force_vector[a_idx, 0],
        outputs=sp.ImmutableMatrix(len(names) + len(extra), 1, [*equations.outputs, *extra]),
        output_names=(*names, *hidden),
        constraints=ce,
    )
    text = render_module(eq2, source_hash, cse=cse, _elastic=False)
    for fn in _RENAMED:
        old = f"\ndef {fn}("
        if text.count(old) != 1:
            raise GenerationError(f"elastic splice: cannot find the function {fn} to wrap")
        text = text.replace(old, f"\ndef _rigid_{fn}(")
    text = _replace_line(text, "OUTPUTS = ", f"OUTPUTS = {names!r}")
    sym_line = [ln for ln in text.splitlines() if ln.startswith("MASS_MATRIX_SYMMETRIC = ")]
    symmetric = (bool(sym_line) and sym_line[0].endswith("True") and _symmetric(splices)
                 and np.array_equal(SV, SW))
    text = _replace_line(text, "MASS_MATRIX_SYMMETRIC = ",
                         f"MASS_MATRIX_SYMMETRIC = {symmetric!r}")
    coords = [system.coordinates[j] for j in keep]
    cu, _ou = _units(system)
    x0 = [float(c.initial) for c in coords] + [float(c.velocity) for c in coords]
    text = _replace_line(text, "COORDINATES = ", f"COORDINATES = {[c.name for c in coords]!r}")
    text = _replace_line(text, "COORDINATE_UNITS = ",
                         f"COORDINATE_UNITS = {[cu[j] for j in keep]!r}")
    text = _replace_line(text, "INITIAL_STATE = ", f"INITIAL_STATE = {x0!r}")
    text = _replace_line(text, "STATE_SIZE = ", f"STATE_SIZE = {2 * len(keep)}")
    text = text.replace("\nimport math as _math\n",
                        "\nimport base64 as _b64\nimport math as _math\nimport zlib as _zlib\n", 1)
    bodies = ", ".join(f"{s.body.name!r} ({s.body.nq} modes"
                       f"{', two-sided' if s.body.two_sided else ''})" for s in splices)
    text = text.replace('"""\n\nimport base64',
                        f'\nElastic bodies: {bodies}.\n"""\n\nimport base64', 1)
    maps = [
        f"_NS = {len(active)}",
        f"_SV_ACTIVE = ({SV[active].shape!r}, {_pack(SV[active])!r})",
        f"_SW_ACTIVE = ({SW[active].shape!r}, {_pack(SW[active])!r})",
    ]
    firsts = [true_index[s.first] for s in splices]
    return (text.rstrip("\n") + "\n\n\n" + "\n".join(maps) + "\n"
            + "\n".join(_data_lines(splices, offsets, firsts)) + "\n"
            + _RUNTIME.rstrip("\n") + "\n")
