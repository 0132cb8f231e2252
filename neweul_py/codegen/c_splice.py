"""Models with elastic bodies in the compiled backend: the kernel traced, the data bound.

The C sources of a model with elastic bodies are made of three parts:

1. **The symbolic part** (rigid bodies, force elements, outputs, constraints, node frames, the
   schedules of parametric bodies and the frame kinematics of every body as hidden outputs;
   :func:`.elastic.symbolic_part`), printed from its CSE'd programs like a rigid model's
   (:mod:`.c_functions`): ``nw_s_rhs_parts`` (hidden outputs, ``M_s``, ``(q − k)_s``),
   ``nw_s_force_jacobians`` … in the symbolic coordinates ``y_s``.
2. **The body equations, traced** (:mod:`.c_trace`, printed by :mod:`.c_kernel`): the
   functions of :mod:`neweul_py.ffrf` the NumPy module runs — ``ffrf_terms``,
   ``ffrf_add_mass``, ``ffrf_add_force``, ``ffrf_symbolic_mass``,
   ``ffrf_fixed_force_jacobians``, :func:`~neweul_py.ffrf.parametric.ffrf_unmix` — are
   called once on traced arrays: the body data of the module's data file
   (:mod:`neweul_py.ffrf.data_file`), the samples of a parametric body mixed with traced
   weights (one product ``w B``), and traced arguments. Their operations become C loops; so
   the C holds the kernel's operations, never a second implementation of them, and the data
   enter through pointers (``nw_bind``), never as numbers in the text. What depends on the
   data alone is computed when they are bound, what depends on the weights of the parametric
   bodies (the mixed samples, ``S_V(σ)``, ``S_W(σ)``, ``∂S_V/∂σ``) when the weights change.
3. **The splice**, fixed C text (:data:`SPLICE_C`, :data:`JACOBIAN_C`) in the order of the
   protocol functions of :mod:`neweul_py.ffrf.splice`: the schedule and the weights of the
   parametric bodies (``nw_at``: the piecewise polynomials of
   :func:`~neweul_py.ffrf.parametric.ffrf_weights` by Horner's rule, with their derivative;
   outside the sampled range an error, which the wrapper reports with the NumPy module's
   message), ``y_s = S_V y``, the Jacobians by the chain rule — the symbolic part's analytic
   ones, sandwiched ``S_Wᵀ (·) S_V``, the complex-step directional derivatives of the traced
   body terms for bodies on moving frames (as ``ffrf_force_directional``), the constant
   ``Ke``, ``De`` of bodies on fixed frames, and the schedule's dependence through ``∂σ/∂y``,
   ``∂σ/∂u`` and the complex step in ``σ`` (as ``ffrf_sigma_terms``).

**The solve** (:data:`ESOLVE_C`): block elimination of the elastic coordinates ``E`` with the
rest ``R`` through the Schur complement ``S = M[R,R] − M[R,E] D⁻¹ M[E,R]`` (Golub & Van Loan,
*Matrix Computations*, §3.2.10; its products are skipped when ``M[E, R]`` is zero: a body on
a fixed frame coupled through force elements). The LU factorization of ``D = M[E, E]`` is
kept: while ``D`` is unchanged it is used as it is (a body on a fixed frame, a parametric
body at constant ``σ``: one factorization; when ``D`` is ``blockdiag(Me(σ))`` by
construction, :func:`~neweul_py.ffrf.splice.ffrf_block_constant`, it is not even compared),
and when ``D`` changed (``σ`` moved) the old factors serve as the preconditioner of
iterative refinement against the new ``D`` (Higham, *Accuracy and Stability of Numerical
Algorithms*, ch. 12) while it converges fast; a slow first contraction, or many right-hand
sides, factors the new ``D``.

**Binding** (docs/generated-module-protocol.md, "Compiled modules"): ``nw_bind(count, data,
sizes)`` takes the pointers of every float64 array of the module's data file in the order of
their keys (``_C_DATA`` of the wrapper: the file's member order) with their sizes, checks
count and sizes, and computes what depends on the data alone; every function returns 2
before it. Integer arrays of the data file (the rows of node maps) are structure and are
compiled in.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import sympy as sp

from ..errors import GenerationError
from ..ffrf.parametric import ffrf_unmix
from ..ffrf.splice import (
    ffrf_add_force,
    ffrf_add_mass,
    ffrf_block_constant,
    ffrf_fixed_force_jacobians,
    ffrf_index,
    ffrf_moving,
    ffrf_symbolic_mass,
    ffrf_terms,
)
from ..model import as_expr
from .c_functions import SymbolGroups, big, c_body, c_function
from .c_kernel import C_DOT, KernelPrinter
from .c_printer import DotRows
from .c_templates import C_DOPRI5, C_LU
from .c_trace import Graph, TArray
from .cse import Block, eliminate
from .elastic import elastic_data, patterns, symbolic_part
from .writer import program_blocks

__all__ = ["ElasticSources", "render_elastic_sources"]

#: The complex step of the directional derivatives (as ``S["step"]`` of the NumPy module).
STEP = 1e-30


@dataclasses.dataclass(frozen=True)
class ElasticSources:
    """The C texts of a model with elastic bodies and what its wrapper needs.

    Attributes
    ----------
    core, jac
        The two C sources (:mod:`.c_module`).
    data
        The keys of the float64 arrays of the data file ``nw_bind`` takes, in order.
    sizes
        ``n``, ``nu``, ``np``, ``ny``, ``nc`` for the wrapper.
    """

    core: str
    jac: str
    data: tuple[str, ...]
    sizes: dict[str, int]


# ---------------------------------------------------------------------------------- trace
@dataclasses.dataclass
class _Trace:
    """The traced kernel of a model: graph, leaves and the outputs of each C function."""

    graph: Graph
    n: int
    ns: int
    nh: int
    nu: int
    parametric: list[dict[str, Any]]      # per parametric body: name, cols, nb, nd, keys
    fixed: bool                           # some body on a fixed frame
    moving: bool                          # some body on a moving frame
    real: dict[str, Any]                  # context mixed with the real weights
    cplx: dict[str, Any] | None           # context mixed with the complex weights
    dsv: list[TArray]                     # ∂S_V/∂σ_k
    elastic: list[int]                    # the elastic coordinates (E)
    block_sigma: bool                     # M[E, E] depends on the schedule alone


def _restore(tree: Any, leaves: dict[str, TArray], arrays: dict[str, np.ndarray]) -> Any:
    """The skeleton with float arrays as data leaves and integer arrays as values."""
    if isinstance(tree, dict):
        if len(tree) == 1 and "@" in tree:
            key = tree["@"]
            return leaves[key] if key in leaves else np.asarray(arrays[key])
        return {k: _restore(v, leaves, arrays) for k, v in tree.items()}
    if isinstance(tree, list):
        return [_restore(v, leaves, arrays) for v in tree]
    if isinstance(tree, tuple):
        return tuple(_restore(v, leaves, arrays) for v in tree)
    return tree


class _Mixed:
    """The mixed values ``w B`` of a parametric body's stack as :func:`~neweul_py.ffrf.
    parametric.ffrf_unmix` reads them (``flat[i:j]``, ``flat[i]``), one product per entry of
    the layout, so that the C code mixes only the entries the kernel uses. An entry that
    does not vary (equal in every sample, zero slopes and curvatures: ``constant``) is the
    first sample's (the value weights sum to one), or zero with the weights' derivative."""

    def __init__(self, w: TArray, B: TArray, constant: np.ndarray, derivative: bool) -> None:
        self.w, self.B, self.constant, self.derivative = w, B, constant, derivative

    def __getitem__(self, key: Any) -> TArray:
        i, j = (key.start, key.stop) if isinstance(key, slice) else (key, key + 1)
        if self.constant[i:j].all():
            block = self.B[0, i:j] if not self.derivative else TArray(
                self.B.graph, self.B.graph.zeros((j - i,)))
        else:
            block = np.dot(self.w, self.B[:, i:j])
        return block if isinstance(key, slice) else block[0]


def _constant_columns(stack: np.ndarray, blocks: int) -> np.ndarray:
    """The columns of a stack (rows ``X_1, X_1′(, X_1″), X_2 …``: ``blocks`` per sample) whose
    value rows are all equal and whose derivative rows are zero."""
    values, derivatives = stack[::blocks], np.delete(stack, np.s_[::blocks], axis=0)
    same = np.all(values == values[0], axis=0)
    return same & (~np.any(derivatives, axis=0) if derivatives.size else True)


def _context(g: Graph, bodies: list[dict], SV0: TArray, SW0: TArray, same: bool,
             weights: list[TArray] | None, n: int, ns: int,
             pattern: tuple[list[int], list[int]], constant: list[np.ndarray],
             derivative: bool = False) -> dict[str, Any]:
    """The splice context the traced kernel runs in, assembled as
    :func:`~neweul_py.ffrf.splice.ffrf_system` and, mixed at ``weights`` (one traced
    vector per parametric body; ``constant``: its stack's columns that do not vary,
    :class:`_Mixed`), :func:`~neweul_py.ffrf.splice.ffrf_mixed` assemble it."""
    out, SV, SW, k = [], SV0, SW0, 0
    for b in bodies:
        if "mixing" not in b:
            bb = dict(b)
            if "quad" not in b and "fixed" not in b:      # Mee E (ffrf_add_mass)
                rows = TArray(g, g.zeros((b["nq"], n)))
                rows[:, b["first"]:b["first"] + b["nq"]] = b["Me"]
                bb["Mee_rows"] = rows
            out.append(bb)
            continue
        w = weights[k]
        mixed = ffrf_unmix(b["mixing"], _Mixed(w, b["mixing"]["stack"], constant[k],
                                               derivative))
        k += 1
        mixed.update(name=b["name"], first=b["first"], kin=b["kin"])
        SV, SW = SV.astype(np.result_type(SV, w)), SW.astype(np.result_type(SW, w))
        SV[b["rows"]] += mixed.pop("_sv")
        SW[b["rows"]] += mixed.pop("_sw")
        out.append(mixed)
    r, c = (np.asarray(v, dtype=np.intp) for v in pattern)
    ix = (ffrf_index(r), ffrf_index(c))
    if not (isinstance(ix[0], slice) and isinstance(ix[1], slice)):
        ix = np.ix_(r, c)
    maps = (ix, SW[ffrf_index(r)].T, SV[ffrf_index(c)])
    acc_map = np.hstack((np.eye(6), np.zeros((6, 3)), -np.eye(6, 3), np.zeros((6, 4))))
    return {"bodies": tuple(out), "n": n, "ns": ns, "SV": SV, "SW": SW,
            "same": same and k == 0, "acc_map": acc_map, "maps": (maps, None)}


def _trace(equations: Any) -> tuple[_Trace, Any]:
    """Trace the kernel of ``equations`` on its data (module docstring); also returns the
    data file (:class:`.elastic.DataFile`)."""
    el = equations.elastic
    a_idx = list(el.active)
    keep = list(el.keep)
    true_index = {j: k for k, j in enumerate(keep)}
    skeleton, data = elastic_data(equations, a_idx, true_index)
    symbolic = symbolic_part(equations)
    mass_pattern, _kin = patterns(symbolic, el.hidden)
    g = Graph()
    leaves = {key: g.leaf(key, arr.shape, 0) for key, arr in sorted(data.arrays.items())
              if arr.dtype.kind == "f"}
    tree = _restore(skeleton, leaves, data.arrays)
    bodies = tree["bodies"]
    n, ns, nh = len(keep), len(a_idx), len(el.hidden)
    nu = len(equations.inputs)
    same = skeleton["SV"] == skeleton["SW"]
    parametric = []
    for b, raw in zip(bodies, skeleton["bodies"], strict=True):
        if "mixing" in b:
            coeff = data.arrays[raw["coeff"]["@"]]
            parametric.append({"name": b["name"], "cols": int(coeff.shape[2]),
                               "nb": int(coeff.shape[1]) + 1, "nd": int(coeff.shape[0]),
                               "values": raw["values"]["@"], "coeff": raw["coeff"]["@"],
                               "rows": np.asarray(b["rows"])})
    w = [g.leaf(f"w{k}", (p["cols"],), 1) for k, p in enumerate(parametric)]
    dw = [g.leaf(f"dw{k}", (p["cols"],), 1) for k, p in enumerate(parametric)]
    wc = [g.leaf(f"wc{k}", (p["cols"],), 1, cplx=True) for k, p in enumerate(parametric)]
    constant = [_constant_columns(data.arrays[raw["mixing"]["stack"]["@"]], blocks)
                for raw, blocks in zip([r for r in skeleton["bodies"] if "mixing" in r],
                                       [1 + bool(s.body.slopes) + bool(s.body.curvatures)
                                        for s in el.splices if s.body.parametric],
                                       strict=True)]
    real = _context(g, bodies, tree["SV"], tree["SW"], same, w, n, ns, mass_pattern,
                    constant)
    cplx = (_context(g, bodies, tree["SV"], tree["SW"], same, wc, n, ns, mass_pattern,
                     constant) if parametric else None)
    dsv = []
    for k, p in enumerate(parametric):               # ∂S_V/∂σ_k: the node rows mixed by w′
        b = next(b for b in bodies if b.get("name") == p["name"] and "mixing" in b)
        d = ffrf_unmix(b["mixing"], _Mixed(dw[k], b["mixing"]["stack"], constant[k],
                                           True))["_sv"]
        m = TArray(g, g.zeros((ns, n)))
        m[p["rows"]] = d
        dsv.append(m)
    fixed = any("fixed" in b for b in bodies)
    moving = any("fixed" not in b for b in bodies)
    elastic = sorted(j for b in bodies for j in range(b["first"], b["first"] + b["nq"]))
    block_sigma = ffrf_block_constant(
        [{k: v for k, v in b.items() if not isinstance(v, TArray)} for b in bodies], ns,
        *_node_structure(skeleton, data.arrays, parametric), mass_pattern,
        np.asarray(_kin, dtype=np.intp))
    return _Trace(g, n, ns, nh, nu, parametric, fixed, moving, real, cplx, dsv,
                  elastic, block_sigma), data


def _node_structure(skeleton: dict, arrays: dict[str, np.ndarray],
                    parametric: list[dict[str, Any]]) -> tuple[np.ndarray, np.ndarray]:
    """The nonzero structure of ``S_V``, ``S_W`` at every schedule: the base maps and the
    node rows of every parametric body in any sample."""
    SV = arrays[skeleton["SV"]["@"]] != 0
    SW = arrays[skeleton["SW"]["@"]] != 0
    for raw in (r for r in skeleton["bodies"] if "mixing" in r):
        stack = arrays[raw["mixing"]["stack"]["@"]]
        rows = np.asarray(arrays[raw["rows"]["@"]])
        for path, i, j, shape in raw["mixing"]["layout"]:
            target = {("_sv",): SV, ("_sw",): SW}.get(tuple(path))
            if target is not None:
                target[rows] |= np.any(stack[:, i:j] != 0, axis=0).reshape(shape)
    return SV, SW


def _kernels(t: _Trace) -> dict[str, tuple[list, list]]:
    """The traced C functions: name → (level-2 leaves ``(C name, TArray)``, outputs
    ``(C name, TArray)``). Each is one splice expression of :mod:`neweul_py.ffrf.splice`."""
    g, n, ns, nh = t.graph, t.n, t.ns, t.nh
    out: dict[str, tuple[list, list]] = {}

    def leaf(name: str, shape: tuple[int, ...], cplx: bool = False) -> TArray:
        return g.leaf(f"{name}@{len(g.leaves)}", shape, 2, cplx)

    # (M, q − k) of ffrf_dynamics after the symbolic part's rhs_parts
    S = t.real
    kin, y, yd = leaf("kin", (nh,)), leaf("y", (n,)), leaf("yd", (n,))
    Ms, fs = leaf("Ms", (ns, ns)), leaf("fs", (ns,))
    terms = ffrf_terms(S, kin, y, yd)
    M = ffrf_add_mass(S, ffrf_symbolic_mass(S, Ms), terms)
    f = ffrf_add_force(S, np.dot(S["SW"].T, fs), terms)
    out["nw_k_dyn"] = ([("kin", kin), ("y", y), ("yd", yd), ("Ms", Ms), ("fs", fs)],
                       [("M", M), ("f", f)])
    if t.fixed:                               # the constant Ke, De of fixed frames
        fy, fyd = leaf("fy", (n, n)), leaf("fyd", (n, n))
        fy2, fyd2 = TArray(g, fy.node), TArray(g, fyd.node)
        ffrf_fixed_force_jacobians(S, fy2, fyd2)
        out["nw_k_fixed"] = ([("fy", fy), ("fyd", fyd)], [("fy_out", fy2), ("fyd_out", fyd2)])
    if t.moving:                              # complex-step directions (moving frames)
        Sm = ffrf_moving(S)
        kc, yc, ydc = leaf("kin", (nh,), True), leaf("y", (n,), True), leaf("yd", (n,), True)
        zero = TArray(g, g.zeros((n,), True))
        fd = ffrf_add_force(Sm, zero, ffrf_terms(Sm, kc, yc, ydc))
        out["nw_k_dirf"] = ([("kin", kc), ("y", yc), ("yd", ydc)], [("f", fd)])
        kc2, yc2, a = leaf("kin", (nh,), True), leaf("y", (n,), True), leaf("a", (n,))
        Mz = TArray(g, g.zeros((n, n), True))
        Ma = np.dot(ffrf_add_mass(Sm, Mz, ffrf_terms(Sm, kc2, yc2,
                                                     TArray(g, g.zeros((n,))))), a)
        out["nw_k_dirm"] = ([("kin", kc2), ("y", yc2), ("a", a)], [("f", Ma)])
    if t.cplx is not None:                    # the complex step in σ (ffrf_sigma_terms)
        Sc = t.cplx
        kc, y3, yd3, fsc = (leaf("kin", (nh,), True), leaf("y", (n,)), leaf("yd", (n,)),
                            leaf("fs", (ns,), True))
        fsig = ffrf_add_force(Sc, np.dot(Sc["SW"].T, fsc), ffrf_terms(Sc, kc, y3, yd3))
        out["nw_k_sigf"] = ([("kin", kc), ("y", y3), ("yd", yd3), ("fs", fsc)],
                            [("f", fsig)])
        kc4, y4, a4, Ms4, mmd = (leaf("kin", (nh,), True), leaf("y", (n,)), leaf("a", (n,)),
                                 leaf("Ms", (ns, ns)), leaf("mmd", (ns,)))
        Mz = TArray(g, g.zeros((n, n), True))
        msig = (np.dot(Sc["SW"].T, np.dot(Ms4, np.dot(Sc["SV"], a4)) + 1j * STEP * mmd)
                + np.dot(ffrf_add_mass(Sc, Mz, ffrf_terms(Sc, kc4, y4,
                                                          TArray(g, g.zeros((n,))))), a4))
        out["nw_k_sigm"] = ([("kin", kc4), ("y", y4), ("a", a4), ("Ms", Ms4), ("mmd", mmd)],
                            [("f", msig)])
    return out


# ---------------------------------------------------------------------- symbolic part
def _symbolic_blocks(symbolic: Any, el: Any, cse: bool) -> dict[str, Block]:
    """The CSE'd programs of the symbolic part (``nw_s_*``)."""
    blocks = program_blocks(symbolic, cse=cse)
    inter = tuple((s, as_expr(e)) for s, e in symbolic.intermediates)
    method = "none" if not cse else ("tree" if inter else "full")
    ny = len(symbolic.outputs) - len(el.hidden)
    hidden = list(symbolic.outputs)[ny:]
    ns = len(symbolic.coordinates)
    M = sp.ImmutableMatrix(symbolic.mass_matrix) if ns else sp.ImmutableMatrix.zeros(0, 0)
    f = list(symbolic.force_vector) if ns else []
    blocks["rhs_parts"] = eliminate(inter, [as_expr(e) for e in (*hidden, *M, *f)],
                                    prefix="_ncg_x", method=method)
    k = len(el.schedules)
    if k:
        blocks["schedule"] = eliminate((), [as_expr(e) for e in el.schedules], method=method)
        Jy, Ju = el.schedule_jacobians
        blocks["schedule_jacobians"] = eliminate((), [as_expr(e) for e in (*Jy, *Ju)],
                                                 method=method)
    return blocks


_S_ARGS = {
    "y": "double t, const double *y, const double *p, const double *u, double *out",
    "yyd": ("double t, const double *y, const double *yd, const double *p, const double *u, "
            "double *out"),
    "a": ("double t, const double *y, const double *p, const double *a, const double *u, "
          "double *out"),
}

#: The symbolic part's functions: name → (block, arguments, what).
_SYMBOLIC = (
    ("rhs_parts", "yyd", "the frame kinematics, mass matrix and forces of the symbolic part"),
    ("mass_matrix", "y", "the symbolic part's mass matrix"),
    ("force_vector", "yyd", "the symbolic part's forces"),
    ("force_jacobians", "yyd", "the symbolic part's force Jacobians"),
    ("mass_matrix_times_derivative", "a", "the symbolic part's ∂(M a)/∂y"),
    ("outputs", "yyd", "the symbolic part's outputs"),
    ("output_jacobians", "yyd", "the symbolic part's output Jacobians"),
    ("constraints", "y", "the constraints"),
    ("constraint_jacobian", "y", "the constraint Jacobian"),
    ("constraint_time_derivative", "y", "∂g/∂t"),
    ("constraint_gamma", "yyd", "γ"),
    ("schedule", "y", "the schedules"),
    ("schedule_jacobians", "y", "the schedule Jacobians"),
)


def _symbolic_functions(symbolic: Any, blocks: dict[str, Block], which: tuple[str, ...],
                        dots: DotRows) -> list[str]:
    g = SymbolGroups(symbolic)
    lines: list[str] = []
    for name, args, what in _SYMBOLIC:
        if name not in which:
            continue
        block = blocks.get(name, Block((), ()))
        body = c_body(g, block, "out", what, dots)
        lines += c_function(f"nw_s_{name}({_S_ARGS[args]})", body, big(block), static=True)
    return lines


# ------------------------------------------------------------------------------- C text
#: The splice of both libraries: binding, weights, the context at the schedule, the
#: dynamics and the sensitivities of the schedule (mirrors neweul_py/ffrf/splice.py).
GLOBALS_C = r"""
/* the bound arrays of the data file and the weights of the parametric bodies */
static const double *nw_D[NW_ND + 1];
static int nw_bound;
static double nw_w[NW_NW + 1], nw_dw[NW_NW + 1];
static double complex nw_wc[NW_NW + 1];
static int nw_have_w;
static long nw_wversion;   /* counts the changes of the weights (and of the bound data) */
"""

SPLICE_C = r"""
/* ---- the splice of the elastic bodies (codegen/c_splice.py; neweul_py/ffrf/splice.py) */

/* the weights w (ncol) at x and their derivative: the piecewise polynomials c (nd, nb-1, ncol)
   on the breakpoints b (ffrf_weights; Horner); 1 outside [b_0, b_{nb-1}] */
static int nw_weights(double x, const double *b, const double *c, int nb, int nd, int ncol,
                      double *w, double *dw)
{
    if (!(b[0] <= x && x <= b[nb - 1])) return 1;
    int j = nb - 2;
    for (int i = 0; i < nb - 1; ++i)
        if (x < b[i + 1]) { j = i; break; }
    const double dx = x - b[j];
    for (int col = 0; col < ncol; ++col) {
        double v = c[(long)j * ncol + col], d = 0.0;
        for (int m = 1; m < nd; ++m) {
            d = d * dx + v;
            v = v * dx + c[((long)m * (nb - 1) + j) * ncol + col];
        }
        w[col] = v;
        dw[col] = d;
    }
    return 0;
}

/* the context at (t, y, p, u): the parametric bodies mixed at their schedules (ffrf_at;
   the mixed samples are kept while the weights are unchanged); 3 outside the samples */
static int nw_at(double t, const double *y, const double *p, const double *u)
{
#if NW_NPB
    double ys0[NW_NS + 1], sigma[NW_NPB], w[NW_NW], dw[NW_NW];
    nw_gemv(NW_NS, NW_N, NW_SV0, NW_N, 1, y, 1, ys0);
    nw_s_schedule(t, ys0, p, u, sigma);
NW_WEIGHTS
    if (!nw_have_w || memcmp(w, nw_w, sizeof w)) {
        memcpy(nw_w, w, sizeof w);
        memcpy(nw_dw, dw, sizeof dw);
        nw_k_sigma();
        nw_have_w = 1;
        ++nw_wversion;
    }
#else
    (void)t; (void)y; (void)p; (void)u;
#endif
    return 0;
}

/* (M, q - k) at the state: y_s = S_V y, the symbolic part, the bodies (ffrf_dynamics) */
static int nw_dyn(double t, const double *y, const double *yd, const double *p,
                  const double *u, double *M, double *f)
{
    static double parts[NW_NH + NW_NS * NW_NS + NW_NS + 1];
    double ys[NW_NS + 1], yds[NW_NS + 1];
    if (nw_at(t, y, p, u)) return 3;
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, y, 1, ys);
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, yd, 1, yds);
    nw_s_rhs_parts(t, ys, yds, p, u, parts);
    nw_k_dyn(parts, y, yd, parts + NW_NH, parts + NW_NH + NW_NS * NW_NS, M, f);
    return 0;
}

/* dsigma/dy (NPB x n, through y_s = S_V(0) y) and dsigma/du (ffrf_sigma_sensitivity); 0 when
   both are zero */
static int nw_sens(double t, const double *y, const double *p, const double *u, double *Sy,
                   double *Su)
{
#if NW_NPB
    double ys0[NW_NS + 1], J[NW_NPB * (NW_NS + NW_NU) + 1];
    int any = 0;
    memset(J, 0, sizeof J);
    nw_gemv(NW_NS, NW_N, NW_SV0, NW_N, 1, y, 1, ys0);
    nw_s_schedule_jacobians(t, ys0, p, u, J);
    for (int i = 0; i < NW_NPB * (NW_NS + NW_NU); ++i) any |= J[i] != 0.0;
    nw_gemm(NW_NPB, NW_N, NW_NS, J, NW_NS, 1, NW_SV0, NW_N, 1, Sy);
    memcpy(Su, J + NW_NPB * NW_NS, NW_NPB * NW_NU * sizeof(double));
    return any;
#else
    (void)t; (void)y; (void)p; (void)u; (void)Sy; (void)Su;
    return 0;
#endif
}

/* M x = b for m right-hand sides (b: n x m, overwritten; M kept) */
""" + "{esolve}" + r"""
int nw_bind(int count, const double *const *data, const long *sizes)
{
    static const long expect[NW_ND + 1] = {NW_SIZES};
    if (count != NW_ND) return 1;
    for (int i = 0; i < NW_ND; ++i)
        if (sizes[i] != expect[i]) return 1;
    for (int i = 0; i < NW_ND; ++i) nw_D[i] = data[i];
NW_BIND
    nw_bound = 1;
    nw_have_w = 0;
    ++nw_wversion;
    return 0;
}
"""

#: The block elimination of the elastic coordinates with the kept factorization of D.
ESOLVE_C = r"""
static const int nw_E[NW_NE] = {NW_ETABLE};
static const int nw_R[NW_NR + 1] = {NW_RTABLE};
static double nw_Dcur[NW_NE * NW_NE], nw_Dlu[NW_NE * NW_NE];
static int nw_Dpiv[NW_NE], nw_Dok, nw_Dfresh;
static long nw_Dversion = -1;

/* factor the current D = M[E,E] (nw_Dfresh: the factors are of it) */
__attribute__((optimize("O3"))) static int nw_dfactor(void)
{
    memcpy(nw_Dlu, nw_Dcur, sizeof nw_Dlu);
    nw_Dok = nw_Dfresh = !nw_lu(NW_NE, nw_Dlu, nw_Dpiv);
    return !nw_Dok;
}

/* D = M[E,E] when it may have changed: with NW_DSIGMA it is blockdiag(Me(sigma)) by
   construction (ffrf_block_constant) and changes with the weights alone; else compared */
static int nw_dupdate(const double *M)
{
    static double D[NW_NE * NW_NE];
    if (NW_DSIGMA && nw_Dok && nw_Dversion == nw_wversion) return 0;
    for (int i = 0; i < NW_NE; ++i)
        for (int j = 0; j < NW_NE; ++j) D[i * NW_NE + j] = M[nw_E[i] * NW_N + nw_E[j]];
    nw_Dversion = nw_wversion;
    if (nw_Dok && !memcmp(D, nw_Dcur, sizeof D)) return 0;
    memcpy(nw_Dcur, D, sizeof D);
    nw_Dfresh = 0;
    return nw_Dok ? 0 : nw_dfactor();
}

/* z = D^-1 z for m columns (NE x m, row-major). The factors of an earlier D are kept while
   iterative refinement against the current D converges fast (Higham, Accuracy and Stability
   of Numerical Algorithms, ch. 12: fixed-precision refinement with a stale factorization, a
   stationary iteration with contraction |I - LU^-1 D|): each step costs two products of
   order NE^2 instead of a factorization of order NE^3. The refinement stops at the round-off
   floor (corrections below 4 eps |z| or no longer halving); a first contraction above 1/4, six
   steps, or more than four columns factor the current D instead. */
__attribute__((optimize("O3"))) static int nw_dsolve(double *z, int m)
{
    static double b[NW_NE * 4], r[NW_NE * 4];
    if (!nw_Dfresh && m <= 4) {
        double prev = 0.0;
        memcpy(b, z, (size_t)NW_NE * m * sizeof(double));
        nw_lu_solve(NW_NE, nw_Dlu, nw_Dpiv, m, z);
        for (int it = 0; it < 6; ++it) {
            double dmax = 0.0, xmax = 0.0;
            for (int i = 0; i < NW_NE; ++i) {
                const double *row = nw_Dcur + (long)i * NW_NE;
                for (int c = 0; c < m; ++c) {
                    double s0 = b[i * m + c], s1 = 0.0;
                    int j = 0;
                    for (; j + 2 <= NW_NE; j += 2) {
                        s0 -= row[j] * z[j * m + c];
                        s1 -= row[j + 1] * z[(j + 1) * m + c];
                    }
                    for (; j < NW_NE; ++j) s0 -= row[j] * z[j * m + c];
                    r[i * m + c] = s0 + s1;
                }
            }
            nw_lu_solve(NW_NE, nw_Dlu, nw_Dpiv, m, r);
            for (int i = 0; i < NW_NE * m; ++i) {
                z[i] += r[i];
                dmax = fmax(dmax, fabs(r[i]));
                xmax = fmax(xmax, fabs(z[i]));
            }
            if (dmax <= 4.0 * DBL_EPSILON * xmax) return 0;            /* converged */
            if (it == 1 && dmax > 0.25 * prev) break;                 /* factors too old */
            if (it > 1 && dmax > 0.5 * prev) return 0;                /* round-off floor */
            prev = dmax;
        }
        memcpy(z, b, (size_t)NW_NE * m * sizeof(double));
    }
    if (!nw_Dfresh && nw_dfactor()) return 1;
    nw_lu_solve(NW_NE, nw_Dlu, nw_Dpiv, m, z);
    return 0;
}

__attribute__((optimize("O3"))) static int nw_esolve(const double *M, double *b, int m)
{
    static double z[NW_NE * 2 * NW_N];
    if (nw_dupdate(M)) return 1;
    for (int i = 0; i < NW_NE; ++i)
        for (int c = 0; c < m; ++c) z[i * m + c] = b[nw_E[i] * m + c];
    if (nw_dsolve(z, m)) return 1;                              /* z = D^-1 b_E */
#if NW_NR
    static double X[NW_NE * NW_NR], S[NW_NR * NW_NR], g[NW_NR * 2 * NW_N];
    int piv[NW_NR], coupled = 0;
    for (int i = 0; i < NW_NE; ++i)
        for (int r = 0; r < NW_NR; ++r) {
            X[i * NW_NR + r] = M[nw_E[i] * NW_N + nw_R[r]];
            coupled |= X[i * NW_NR + r] != 0.0;
        }
    if (coupled && nw_dsolve(X, NW_NR)) return 1;              /* X = D^-1 M[E,R] */
    for (int r = 0; r < NW_NR; ++r) {
        const double *row = M + nw_R[r] * NW_N;
        for (int q = 0; q < NW_NR; ++q) {                       /* S = M[R,R] - M[R,E] X */
            double s = row[nw_R[q]];
            if (coupled) for (int e = 0; e < NW_NE; ++e) s -= row[nw_E[e]] * X[e * NW_NR + q];
            S[r * NW_NR + q] = s;
        }
        for (int c = 0; c < m; ++c) {                           /* g = b_R - M[R,E] z */
            double s = b[nw_R[r] * m + c];
            for (int e = 0; e < NW_NE; ++e) s -= row[nw_E[e]] * z[e * m + c];
            g[r * m + c] = s;
        }
    }
    if (nw_lu(NW_NR, S, piv)) return 1;
    nw_lu_solve(NW_NR, S, piv, m, g);                          /* x_R */
    if (coupled)                                                /* x_E = z - X x_R */
        for (int e = 0; e < NW_NE; ++e)
            for (int c = 0; c < m; ++c) {
                double s = z[e * m + c];
                for (int r = 0; r < NW_NR; ++r) s -= X[e * NW_NR + r] * g[r * m + c];
                z[e * m + c] = s;
            }
    for (int r = 0; r < NW_NR; ++r)
        for (int c = 0; c < m; ++c) b[nw_R[r] * m + c] = g[r * m + c];
#endif
    for (int i = 0; i < NW_NE; ++i)
        for (int c = 0; c < m; ++c) b[nw_E[i] * m + c] = z[i * m + c];
    return 0;
}
"""

#: The protocol functions of the core library.
CORE_C = r"""
int nw_default_inputs(double t, const double *p, double *out)
{
    return nw_s_default_inputs(t, p, out);
}

int nw_mass_matrix(double t, const double *y, const double *p, const double *u, double *out)
{
    static double f[NW_N + 1];
    double yd[NW_N + 1] = {0};
    if (!nw_bound) return 2;
    return nw_dyn(t, y, yd, p, u, out, f);
}

int nw_force_vector(double t, const double *y, const double *yd, const double *p,
                    const double *u, double *out)
{
    static double M[NW_N * NW_N + 1];
    if (!nw_bound) return 2;
    return nw_dyn(t, y, yd, p, u, M, out);
}

int nw_rhs(double t, const double *x, const double *p, const double *u, double *out)
{
    static double M[NW_N * NW_N + 1], f[NW_N + 1];
    int r;
    if (!nw_bound) return 2;
    if ((r = nw_dyn(t, x, x + NW_N, p, u, M, f))) return r;
    if (nw_esolve(M, f, 1)) return 1;
    memmove(out, x + NW_N, NW_N * sizeof(double));
    memcpy(out + NW_N, f, NW_N * sizeof(double));
    return 0;
}

int nw_outputs(double t, const double *x, const double *p, const double *u, double *out)
{
    double ys[NW_NS + 1], yds[NW_NS + 1], o[NW_NY + NW_NH + 1];
    if (!nw_bound) return 2;
    if (nw_at(t, x, p, u)) return 3;
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, x, 1, ys);
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, x + NW_N, 1, yds);
    nw_s_outputs(t, ys, yds, p, u, o);
    memcpy(out, o, NW_NY * sizeof(double));
    return 0;
}

int nw_constraints(double t, const double *y, const double *p, const double *u, double *out)
{
    double ys[NW_NS + 1];
    if (!nw_bound) return 2;
    if (nw_at(t, y, p, u)) return 3;
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, y, 1, ys);
    return nw_s_constraints(t, ys, p, u, out);
}

int nw_constraint_time_derivative(double t, const double *y, const double *p, const double *u,
                                  double *out)
{
    double ys[NW_NS + 1];
    if (!nw_bound) return 2;
    if (nw_at(t, y, p, u)) return 3;
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, y, 1, ys);
    return nw_s_constraint_time_derivative(t, ys, p, u, out);
}

int nw_constraint_gamma(double t, const double *y, const double *yd, const double *p,
                        const double *u, double *out)
{
    double ys[NW_NS + 1], yds[NW_NS + 1];
    if (!nw_bound) return 2;
    if (nw_at(t, y, p, u)) return 3;
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, y, 1, ys);
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, yd, 1, yds);
    return nw_s_constraint_gamma(t, ys, yds, p, u, out);
}

/* G = G_s S_V (+ G_s dS_V/dsigma y dsigma/dy) (ffrf_constraint_jacobian) */
int nw_constraint_jacobian(double t, const double *y, const double *p, const double *u,
                           double *out)
{
    static double Gs[NW_NC * NW_NS + 1];
    double ys[NW_NS + 1];
    NW_DEFAULT_INPUTS;
    if (!nw_bound) return 2;
    if (nw_at(t, y, p, u)) return 3;
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, y, 1, ys);
    nw_s_constraint_jacobian(t, ys, p, u, Gs);
    nw_gemm(NW_NC, NW_N, NW_NS, Gs, NW_NS, 1, NW_SV, NW_N, 1, out);
#if NW_NPB
    static double Sy[NW_NPB * NW_N + 1], Su[NW_NPB * NW_NU + 1];
    if (NW_NC && nw_sens(t, y, p, u, Sy, Su)) {
        double d[NW_NS + 1], v[NW_NC + 1];
        for (int k = 0; k < NW_NPB; ++k) {
            nw_gemv(NW_NS, NW_N, nw_dsv[k], NW_N, 1, y, 1, d);
            nw_gemv(NW_NC, NW_NS, Gs, NW_NS, 1, d, 1, v);
            for (int i = 0; i < NW_NC; ++i)
                for (int j = 0; j < NW_N; ++j) out[i * NW_N + j] += v[i] * Sy[k * NW_N + j];
        }
    }
#endif
    return 0;
}
"""

#: The derivatives (mirrors ffrf_force_jacobians, ffrf_mass_matrix_times_derivative,
#: ffrf_rhs_jacobian, ffrf_output_jacobians and ffrf_sigma_terms).
JACOBIAN_C = r"""
#define NW_H 1e-30
#define NW_NX (2 * NW_NS + NW_NU)

/* kin (nh), dkin/dy = Cs[:, :ns] S_V, dkin/dyd, dkin/du (ffrf_kin_jacobians) */
static void nw_kin_jacobians(double t, const double *ys, const double *yds, const double *p,
                             const double *u, double *kin, double *Ky, double *Kyd, double *Ku)
{
    static double o[NW_NY + NW_NH + 1], C[(NW_NY + NW_NH) * NW_NX + 1];
    nw_s_outputs(t, ys, yds, p, u, o);
    memcpy(kin, o + NW_NY, NW_NH * sizeof(double));
    nw_s_output_jacobians(t, ys, yds, p, u, C);
    const double *Cs = C + NW_NY * NW_NX;
    nw_gemm(NW_NH, NW_N, NW_NS, Cs, NW_NX, 1, NW_SV, NW_N, 1, Ky);
    nw_gemm(NW_NH, NW_N, NW_NS, Cs + NW_NS, NW_NX, 1, NW_SV, NW_N, 1, Kyd);
    for (int i = 0; i < NW_NH; ++i)
        for (int k = 0; k < NW_NU; ++k) Ku[i * NW_NU + k] = Cs[i * NW_NX + 2 * NW_NS + k];
}

/* out (n x n) = S_W^T A S_V for A (ns x ns) with row stride lda */
static void nw_sandwich(const double *A, long lda, double *out)
{
    static double T[NW_NS * NW_N + 1];
    nw_gemm(NW_NS, NW_N, NW_NS, A, lda, 1, NW_SV, NW_N, 1, T);
    nw_gemm(NW_N, NW_N, NW_NS, NW_SW, 1, NW_N, T, NW_N, 1, out);
}

#if NW_NPB
/* d(q - k)/dsigma (n x NPB) or, with a, d(M a)/dsigma: the complex step in each sigma_k of the
   mixed bodies and S_V, S_W with the symbolic part's Jacobians (ffrf_sigma_terms) */
static void nw_sigma_terms(double t, const double *y, const double *yd, const double *p,
                           const double *u, const double *a, double *out)
{
    static double o[NW_NY + NW_NH + 1], C[(NW_NY + NW_NH) * NW_NX + 1], fs[NW_NS + 1];
    static double J[NW_NS * NW_NX + 1], Ms[NW_NS * NW_NS + 1], mm[NW_NS * NW_NS + 1];
    static double complex kinc[NW_NH + 1], fsc[NW_NS + 1], f[NW_N + 1];
    double ys[NW_NS + 1], yds[NW_NS + 1], as[NW_NS + 1], dys[NW_NS + 1], dyds[NW_NS + 1];
    double dk[NW_NH + 1], v[NW_NS + 1], mmd[NW_NS + 1];
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, y, 1, ys);
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, yd, 1, yds);
    nw_s_output_jacobians(t, ys, yds, p, u, C);
    nw_s_outputs(t, ys, yds, p, u, o);
    const double *Cs = C + NW_NY * NW_NX, *kin = o + NW_NY;
    if (!a) {
        nw_s_force_vector(t, ys, yds, p, u, fs);
        nw_s_force_jacobians(t, ys, yds, p, u, J);
    } else {
        nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, a, 1, as);
        nw_s_mass_matrix(t, ys, p, u, Ms);
        nw_s_mass_matrix_times_derivative(t, ys, p, as, u, mm);
    }
    for (int k = 0; k < NW_NPB; ++k) {
        static double complex last[NW_NW];
        static int have;
        for (int i = 0; i < NW_NW; ++i) nw_wc[i] = nw_w[i];
        for (int i = nw_woff[k]; i < nw_woff[k + 1]; ++i) nw_wc[i] += I * NW_H * nw_dw[i];
        if (!have || memcmp(last, nw_wc, sizeof last)) {   /* mixed once per weights */
            nw_k_sigma_c();
            memcpy(last, nw_wc, sizeof last);
            have = 1;
        }
        nw_gemv(NW_NS, NW_N, nw_dsv[k], NW_N, 1, y, 1, dys);
        nw_gemv(NW_NS, NW_N, nw_dsv[k], NW_N, 1, yd, 1, dyds);
        for (int i = 0; i < NW_NH; ++i) {           /* dkin = Cs[:, :ns] dys + Cs[:, ns:2ns] dyds */
            double s = 0.0;
            for (int j = 0; j < NW_NS; ++j)
                s += Cs[i * NW_NX + j] * dys[j] + Cs[i * NW_NX + NW_NS + j] * dyds[j];
            dk[i] = s;
            kinc[i] = kin[i] + I * NW_H * s;
        }
        if (!a) {
            for (int i = 0; i < NW_NS; ++i) {       /* fs + ih (fys dys + fyds dyds) */
                double s = 0.0;
                for (int j = 0; j < NW_NS; ++j)
                    s += J[i * NW_NX + j] * dys[j] + J[i * NW_NX + NW_NS + j] * dyds[j];
                v[i] = s;
                fsc[i] = fs[i] + I * NW_H * s;
            }
            nw_k_sigf(kinc, y, yd, fsc, f);
        } else {
            nw_gemv(NW_NS, NW_NS, mm, NW_NS, 1, dys, 1, mmd);
            nw_k_sigm(kinc, y, a, Ms, mmd, f);
        }
        for (int i = 0; i < NW_N; ++i) out[i * NW_NPB + k] = cimag(f[i]) / NW_H;
    }
    (void)dk; (void)v;
}
#endif

int nw_force_jacobians(double t, const double *y, const double *yd, const double *p,
                       const double *u, double *out)
{
    static double J[NW_NS * NW_NX + 1], fy[NW_N * NW_N + 1], fyd[NW_N * NW_N + 1];
    static double fu[NW_N * NW_NU + 1], T[NW_NS * NW_NU + 1];
    double ys[NW_NS + 1], yds[NW_NS + 1];
    NW_DEFAULT_INPUTS;
    if (!nw_bound) return 2;
    if (nw_at(t, y, p, u)) return 3;
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, y, 1, ys);
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, yd, 1, yds);
    nw_s_force_jacobians(t, ys, yds, p, u, J);
    nw_sandwich(J, NW_NX, fy);
    nw_sandwich(J + NW_NS, NW_NX, fyd);
    for (int i = 0; i < NW_NS; ++i)
        for (int k = 0; k < NW_NU; ++k) T[i * NW_NU + k] = J[i * NW_NX + 2 * NW_NS + k];
    nw_gemm(NW_N, NW_NU, NW_NS, NW_SW, 1, NW_N, T, NW_NU, 1, fu);
NW_FIXED_JACOBIANS
#if NW_MOVING
    {   /* complex steps of the bodies on moving frames (ffrf_force_directional) */
        static double kin[NW_NH + 1], Ky[NW_NH * NW_N + 1], Kyd[NW_NH * NW_N + 1];
        static double Ku[NW_NH * NW_NU + 1];
        static double complex kc[NW_NH + 1], yc[NW_N + 1], ydc[NW_N + 1], fc[NW_N + 1];
        nw_kin_jacobians(t, ys, yds, p, u, kin, Ky, Kyd, Ku);
        for (int j = 0; j < 2 * NW_N + NW_NU; ++j) {
            const double *K = j < NW_N ? Ky : (j < 2 * NW_N ? Kyd : Ku);
            const int col = j < NW_N ? j : (j < 2 * NW_N ? j - NW_N : j - 2 * NW_N);
            const int ld = j < 2 * NW_N ? NW_N : NW_NU;
            for (int i = 0; i < NW_NH; ++i) kc[i] = kin[i] + I * NW_H * K[i * ld + col];
            for (int i = 0; i < NW_N; ++i) { yc[i] = y[i]; ydc[i] = yd[i]; }
            if (j < NW_N) yc[col] += I * NW_H;
            else if (j < 2 * NW_N) ydc[col] += I * NW_H;
            nw_k_dirf(kc, yc, ydc, fc);
            double *target = j < NW_N ? fy : (j < 2 * NW_N ? fyd : fu);
            const int ldt = j < 2 * NW_N ? NW_N : NW_NU;
            for (int i = 0; i < NW_N; ++i) target[i * ldt + col] += cimag(fc[i]) / NW_H;
        }
    }
#endif
#if NW_NPB
    {   /* the weights move with y and u */
        static double Sy[NW_NPB * NW_N + 1], Su[NW_NPB * NW_NU + 1], Fs[NW_N * NW_NPB + 1];
        if (nw_sens(t, y, p, u, Sy, Su)) {
            nw_sigma_terms(t, y, yd, p, u, 0, Fs);
            for (int i = 0; i < NW_N; ++i)
                for (int k = 0; k < NW_NPB; ++k) {
                    const double s = Fs[i * NW_NPB + k];
                    for (int j = 0; j < NW_N; ++j) fy[i * NW_N + j] += s * Sy[k * NW_N + j];
                    for (int j = 0; j < NW_NU; ++j) fu[i * NW_NU + j] += s * Su[k * NW_NU + j];
                }
        }
    }
#endif
    for (int i = 0; i < NW_N; ++i) {
        memcpy(out + i * (2 * NW_N + NW_NU), fy + i * NW_N, NW_N * sizeof(double));
        memcpy(out + i * (2 * NW_N + NW_NU) + NW_N, fyd + i * NW_N, NW_N * sizeof(double));
        memcpy(out + i * (2 * NW_N + NW_NU) + 2 * NW_N, fu + i * NW_NU, NW_NU * sizeof(double));
    }
    return 0;
}

int nw_mass_matrix_times_derivative(double t, const double *y, const double *p,
                                    const double *a, const double *u, double *out)
{
    static double mm[NW_NS * NW_NS + 1];
    double ys[NW_NS + 1], yds[NW_NS + 1] = {0}, as[NW_NS + 1], zero[NW_N + 1] = {0};
    NW_DEFAULT_INPUTS;
    if (!nw_bound) return 2;
    if (nw_at(t, y, p, u)) return 3;
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, y, 1, ys);
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, a, 1, as);
    nw_s_mass_matrix_times_derivative(t, ys, p, as, u, mm);
    nw_sandwich(mm, NW_NS, out);
#if NW_MOVING
    {   /* complex steps of the moving bodies' mass blocks times a */
        static double kin[NW_NH + 1], Ky[NW_NH * NW_N + 1], Kyd[NW_NH * NW_N + 1];
        static double Ku[NW_NH * NW_NU + 1];
        static double complex kc[NW_NH + 1], yc[NW_N + 1], fc[NW_N + 1];
        nw_kin_jacobians(t, ys, yds, p, u, kin, Ky, Kyd, Ku);
        for (int j = 0; j < NW_N; ++j) {
            for (int i = 0; i < NW_NH; ++i) kc[i] = kin[i] + I * NW_H * Ky[i * NW_N + j];
            for (int i = 0; i < NW_N; ++i) yc[i] = y[i];
            yc[j] += I * NW_H;
            nw_k_dirm(kc, yc, a, fc);
            for (int i = 0; i < NW_N; ++i) out[i * NW_N + j] += cimag(fc[i]) / NW_H;
        }
    }
#endif
#if NW_NPB
    {
        static double Sy[NW_NPB * NW_N + 1], Su[NW_NPB * NW_NU + 1], Fa[NW_N * NW_NPB + 1];
        if (nw_sens(t, y, p, u, Sy, Su)) {
            nw_sigma_terms(t, y, zero, p, u, a, Fa);
            for (int i = 0; i < NW_N; ++i)
                for (int k = 0; k < NW_NPB; ++k)
                    for (int j = 0; j < NW_N; ++j)
                        out[i * NW_N + j] += Fa[i * NW_NPB + k] * Sy[k * NW_N + j];
        }
    }
#endif
    (void)zero; (void)yds;
    return 0;
}

int nw_rhs_jacobian(double t, const double *x, const double *p, const double *u, double *out)
{
    static double M[NW_N * NW_N + 1], f[NW_N + 1], fj[NW_N * (2 * NW_N + NW_NU) + 1];
    static double dMa[NW_N * NW_N + 1], b[NW_N * 2 * NW_N + 1];
    const double *y = x, *yd = x + NW_N;
    int r;
    NW_DEFAULT_INPUTS;
    if (!nw_bound) return 2;
    if ((r = nw_dyn(t, y, yd, p, u, M, f))) return r;
    if (nw_esolve(M, f, 1)) return 1;                          /* ydd */
    if ((r = nw_force_jacobians(t, y, yd, p, u, fj))) return r;
    if ((r = nw_mass_matrix_times_derivative(t, y, p, f, u, dMa))) return r;
    for (int i = 0; i < NW_N; ++i)
        for (int j = 0; j < 2 * NW_N; ++j)
            b[i * 2 * NW_N + j] = fj[i * (2 * NW_N + NW_NU) + j]
                                  - (j < NW_N ? dMa[i * NW_N + j] : 0.0);
    if (nw_esolve(M, b, 2 * NW_N)) return 1;
    memset(out, 0, NW_STATE_SIZE * NW_STATE_SIZE * sizeof(double));
    for (int i = 0; i < NW_N; ++i) out[i * NW_STATE_SIZE + NW_N + i] = 1.0;
    memcpy(out + NW_N * NW_STATE_SIZE, b, NW_N * 2 * NW_N * sizeof(double));
    return 0;
}

/* dout/dx = [Cs_y S_V, Cs_yd S_V] (+ the schedule's), dout/du (ffrf_output_jacobians) */
int nw_output_jacobians(double t, const double *x, const double *p, const double *u,
                        double *out)
{
    static double C[(NW_NY + NW_NH) * NW_NX + 1], Cy[NW_NY * NW_N + 1], Cyd[NW_NY * NW_N + 1];
    double ys[NW_NS + 1], yds[NW_NS + 1];
    const int ld = 2 * NW_N + NW_NU;
    NW_DEFAULT_INPUTS;
    if (!nw_bound) return 2;
    if (nw_at(t, x, p, u)) return 3;
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, x, 1, ys);
    nw_gemv(NW_NS, NW_N, NW_SV, NW_N, 1, x + NW_N, 1, yds);
    nw_s_output_jacobians(t, ys, yds, p, u, C);
    nw_gemm(NW_NY, NW_N, NW_NS, C, NW_NX, 1, NW_SV, NW_N, 1, Cy);
    nw_gemm(NW_NY, NW_N, NW_NS, C + NW_NS, NW_NX, 1, NW_SV, NW_N, 1, Cyd);
    for (int i = 0; i < NW_NY; ++i) {
        memcpy(out + i * ld, Cy + i * NW_N, NW_N * sizeof(double));
        memcpy(out + i * ld + NW_N, Cyd + i * NW_N, NW_N * sizeof(double));
        for (int k = 0; k < NW_NU; ++k) out[i * ld + 2 * NW_N + k] = C[i * NW_NX + 2 * NW_NS + k];
    }
#if NW_NPB
    static double Sy[NW_NPB * NW_N + 1], Su[NW_NPB * NW_NU + 1];
    if (NW_NY && nw_sens(t, x, p, u, Sy, Su)) {
        double d[NW_NS + 1], dd[NW_NS + 1];
        for (int k = 0; k < NW_NPB; ++k) {
            nw_gemv(NW_NS, NW_N, nw_dsv[k], NW_N, 1, x, 1, d);
            nw_gemv(NW_NS, NW_N, nw_dsv[k], NW_N, 1, x + NW_N, 1, dd);
            for (int i = 0; i < NW_NY; ++i) {
                double s = 0.0;
                for (int j = 0; j < NW_NS; ++j)
                    s += C[i * NW_NX + j] * d[j] + C[i * NW_NX + NW_NS + j] * dd[j];
                for (int j = 0; j < NW_N; ++j) out[i * ld + j] += s * Sy[k * NW_N + j];
                for (int j = 0; j < NW_NU; ++j) out[i * ld + 2 * NW_N + j] += s * Su[k * NW_NU + j];
            }
        }
    }
#endif
    return 0;
}
"""


def _defines(t: _Trace, nd: int, ny: int, nc: int) -> list[str]:
    R = [j for j in range(t.n) if j not in set(t.elastic)]
    npb = len(t.parametric)
    return [
        f"#define NW_NS {t.ns}", f"#define NW_NH {t.nh}", f"#define NW_NY {ny}",
        f"#define NW_NC {nc}", f"#define NW_NPB {npb}",
        f"#define NW_NW {sum(p['cols'] for p in t.parametric)}", f"#define NW_ND {nd}",
        f"#define NW_NE {len(t.elastic)}", f"#define NW_NR {len(R)}",
        f"#define NW_MOVING {int(t.moving)}", f"#define NW_DSIGMA {int(t.block_sigma)}",
    ]


def _weights_lines(t: _Trace, data: dict[str, int]) -> list[str]:
    lines, off = [], 0
    for k, p in enumerate(t.parametric):
        lines.append(f"    if (nw_weights(sigma[{k}], nw_D[{data[p['values']]}], "
                     f"nw_D[{data[p['coeff']]}], {p['nb']}, {p['nd']}, {p['cols']}, "
                     f"w + {off}, dw + {off})) return 3;")
        off += p["cols"]
    return lines


def _library(t: _Trace, kernels: dict[str, tuple[list, list]], which: tuple[str, ...],
             data: list[str], sizes: dict[str, int], symbolic_lines: list[str],
             jacobian: bool) -> str:
    """One C file: the symbolic part, the traced kernels ``which``, the splice."""
    index = {k: i for i, k in enumerate(data)}
    pr = KernelPrinter(t.graph, data)
    for name in ("w", "dw", "wc"):           # the weights: global arrays of the splice
        off = 0
        for i, p in enumerate(t.parametric):
            leaf = t.graph.leaves[f"{name}{i}"]
            pr.params[leaf.id] = f"(nw_{name} + {off})" if off else f"nw_{name}"
            off += p["cols"]
    body: list[str] = []
    sig_outputs = [t.real["SV"], t.real["SW"], *t.dsv]
    need = [out for name in which for _n, out in kernels[name][1]]
    real_sigma = {t.graph.leaves[f"{nm}{i}"].id for nm in ("w", "dw")
                  for i in range(len(t.parametric))}
    if t.parametric:
        body += pr.schedule_function("nw_k_sigma(void)", [], [*sig_outputs, *[
            x for x in need if _depends_only(t.graph, x.node, real_sigma)]])
        if jacobian:
            body += pr.schedule_function("nw_k_sigma_c(void)", [], need)
    for name in which:
        params, outputs = kernels[name]
        args = ", ".join(f"const {'double complex' if p.node.cplx else 'double'} *{c}"
                         for c, p in params)
        outs = ", ".join(f"{'double complex' if o.node.cplx else 'double'} *{c}"
                         for c, o in outputs)
        body += pr.function(f"{name}({args}, {outs})", params, outputs,
                            direct=name == "nw_k_dyn")
    sv, sw = pr.pointer(t.real["SV"]), pr.pointer(t.real["SW"])
    sv0 = f"nw_D[{index['_splice/SV']}]"
    macros = [f"#define NW_SV {sv}", f"#define NW_SW {sw}", f"#define NW_SV0 {sv0}"]
    if t.parametric:
        offs = np.cumsum([0, *(p["cols"] for p in t.parametric)])
        body.insert(0, f"static const int nw_woff[NW_NPB + 1] = "
                       f"{{{', '.join(str(int(o)) for o in offs)}}};")
        body.insert(1, "static const double *nw_dsv[NW_NPB] = {"
                       + ", ".join(pr.pointer(d) for d in t.dsv) + "};")
    splice = SPLICE_C.replace("NW_WEIGHTS", "\n".join(_weights_lines(t, index)))
    splice = splice.replace("NW_BIND", "\n".join(pr.bind_lines()))
    splice = splice.replace("NW_SIZES", ", ".join(str(sizes[k]) for k in data) or "0")
    R = [j for j in range(t.n) if j not in set(t.elastic)]
    esolve = (ESOLVE_C.replace("NW_ETABLE", ", ".join(map(str, t.elastic)))
              .replace("NW_RTABLE", ", ".join(map(str, R)) or "0"))
    splice = splice.replace("{esolve}", esolve)
    text = [*pr.static, *macros, *body, C_LU, splice]
    if jacobian:
        fixed = ("    nw_k_fixed(fy, fyd, fy, fyd);" if "nw_k_fixed" in which else "")
        text.append(JACOBIAN_C.replace("NW_FIXED_JACOBIANS", fixed))
    else:
        text += [CORE_C, C_DOPRI5]
    return "\n".join([*symbolic_lines, C_DOT, *text])


def _depends_only(graph: Graph, node: Any, leaf_ids: set[int]) -> bool:
    """Whether the level-1 leaves ``node`` depends on are among ``leaf_ids``."""
    seen, stack = set(), [node]
    while stack:
        n = stack.pop()
        if n.id in seen:
            continue
        seen.add(n.id)
        if n.op == "leaf" and n.params[1] == 1 and n.id not in leaf_ids:
            return False
        stack.extend(n.args)
    return True


def render_elastic_sources(equations: Any, model_name: str, *, cse: bool = True
                           ) -> ElasticSources:
    """The C sources of a model with elastic bodies (module docstring).

    Raises
    ------
    GenerationError
        When the kernel does something the tracer cannot record (:mod:`.c_trace`) or a
        symbolic expression cannot be printed.
    """
    el = equations.elastic
    t, data_file = _trace(equations)
    kernels = _kernels(t)
    symbolic = symbolic_part(equations)
    blocks = _symbolic_blocks(symbolic, el, cse)
    ny = len(equations.output_names)
    ce = getattr(equations, "constraints", None)
    nc = 0 if ce is None else int(ce.nc)
    keys = tuple(k for k, a in sorted(data_file.arrays.items()) if a.dtype.kind == "f")
    sizes = {k: int(data_file.arrays[k].size) for k in keys}
    n, nu = t.n, len(equations.inputs)

    def head(what: str) -> list[str]:
        return [f"/* {what} of the model {model_name!r} in C: generated by neweul-py, do not "
                "edit. */", "#include <complex.h>", "#include <float.h>", "#include <math.h>",
                "#include <string.h>",
                f"#define NW_N {n}", f"#define NW_NU {nu}", f"#define NW_STATE_SIZE {2 * n}",
                "#define NW_DEFAULT_INPUTS double nw_ub[NW_NU + 1]; "
                "if (!u) { nw_s_default_inputs(t, p, nw_ub); u = nw_ub; }",
                *_defines(t, len(keys), ny, nc),
                "static int nw_s_default_inputs(double t, const double *p, double *out);",
                GLOBALS_C, ""]

    g = SymbolGroups(symbolic)
    dots = DotRows(len(symbolic.coordinates))
    inputs = c_function("nw_s_default_inputs(double t, const double *p, double *out)",
                        c_body(g, blocks["default_inputs"], "out", "the default inputs", dots),
                        static=True)
    core_sym = [*inputs, *_symbolic_functions(symbolic, blocks, (
        "rhs_parts", "outputs", "constraints", "constraint_jacobian",
        "constraint_time_derivative", "constraint_gamma", "schedule", "schedule_jacobians"),
        dots)]
    core_kernels = ("nw_k_dyn",)
    jac_dots = DotRows(len(symbolic.coordinates))
    inputs_j = c_function("nw_s_default_inputs(double t, const double *p, double *out)",
                          c_body(g, blocks["default_inputs"], "out", "the default inputs",
                                 jac_dots), static=True)
    jac_sym = [*inputs_j, *_symbolic_functions(symbolic, blocks, tuple(
        name for name, _a, _w in _SYMBOLIC), jac_dots)]
    jac_kernels = tuple(k for k in ("nw_k_dyn", "nw_k_fixed", "nw_k_dirf", "nw_k_dirm",
                                    "nw_k_sigf", "nw_k_sigm") if k in kernels)
    core = _library(t, kernels, core_kernels, list(keys), sizes,
                    [*head("Equations of motion"), *dots.helper(), *core_sym], False)
    jac = _library(t, kernels, jac_kernels, list(keys), sizes,
                   [*head("Derivatives of the equations of motion"), *jac_dots.helper(),
                    *jac_sym], True)
    if not t.elastic:
        raise GenerationError("a model with elastic bodies but no elastic coordinates")
    return ElasticSources(core.rstrip("\n") + "\n", jac.rstrip("\n") + "\n", keys, {
        "n": n, "nu": nu, "np": len(equations.parameters), "ny": ny, "nc": nc})
