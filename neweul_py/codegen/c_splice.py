"""Models with elastic bodies in the compiled backend: the kernel traced, the data bound.

The C sources of a model with elastic bodies are made of three parts:

1. **The symbolic part** (rigid bodies, force elements, outputs, constraints, node frames, the
   schedules of parametric bodies and the frame kinematics of every body as hidden outputs;
   :func:`.elastic.symbolic_part`), printed from its CSE'd programs like a rigid model's
   (:mod:`.c_functions`): ``nw_s_rhs_parts`` (hidden outputs, ``M_s``, ``(q − k)_s``),
   ``nw_s_force_jacobians`` … in the symbolic coordinates ``y_s``.
2. **The body equations, traced** (:mod:`.c_splice_trace` with :mod:`.c_trace`, printed
   by :mod:`.c_kernel`): the functions of :mod:`neweul_py.ffrf` the NumPy module runs —
   ``ffrf_terms``,
   ``ffrf_add_mass``, ``ffrf_add_force``, ``ffrf_symbolic_mass``,
   ``ffrf_fixed_force_jacobians``, :func:`~neweul_py.ffrf.parametric.ffrf_unmix` — are
   called once on traced arrays: the body data of the module's data file
   (:mod:`neweul_py.ffrf.data_file`), the samples of a parametric body mixed with traced
   weights (``w B`` per entry of its layout, from the compact form), and traced arguments.
   Their operations become C loops; so the C holds the kernel's operations, never a second
   implementation of them, and the data enter through pointers (``nw_bind``), never as
   numbers in the text. What depends on the
   data alone is computed when they are bound, what depends on the weights of the parametric
   bodies (the mixed samples, ``S_V(σ)``, ``S_W(σ)``, ``∂S_V/∂σ``) when the weights change,
   by the first function that reads it (``nw_mixed``; outputs and constraints need no mix
   unless ``S_V`` is mixed, ``NW_SV_MIXED``).
3. **The splice**, fixed C text (:mod:`.c_splice_text`; the Jacobians in
   :mod:`.c_splice_jacobians` and :mod:`.c_splice_parameters`) in the order of the
   protocol functions of :mod:`neweul_py.ffrf.splice`: the schedule and the weights of the
   parametric bodies (``nw_weights_at``: the piecewise polynomials of
   :func:`~neweul_py.ffrf.parametric.ffrf_weights` by Horner's rule, with their derivative;
   outside the sampled range an error, which the wrapper reports with the NumPy module's
   message), ``y_s = S_V y``, the Jacobians by the chain rule — the symbolic part's analytic
   ones, sandwiched ``S_Wᵀ (·) S_V``, the complex-step directional derivatives of the traced
   body terms for bodies on moving frames (as ``ffrf_force_directional``), the constant
   ``Ke``, ``De`` of bodies on fixed frames, and the schedule's dependence through ``∂σ/∂y``,
   ``∂σ/∂u`` and the complex step in ``σ`` (as ``ffrf_sigma_terms``).

**The solve** (:data:`.c_splice_text.ESOLVE_C`): block elimination of the elastic
coordinates ``E`` with the rest ``R`` through the Schur complement
``S = M[R,R] − M[R,E] D⁻¹ M[E,R]`` (Golub & Van Loan, *Matrix Computations*, §3.2.10; its
products are skipped when ``M[E, R]`` is zero: a body on a fixed frame coupled through force
elements). The LU factorization of ``D = M[E, E]`` is
kept: while ``D`` is unchanged it is used as it is (a body on a fixed frame, a parametric
body at constant ``σ``: one factorization; when ``D`` is ``blockdiag(Me(σ))`` by
construction, :func:`~neweul_py.ffrf.splice.ffrf_block_constant`, it is not even compared),
and when ``D`` changed (``σ`` moved) the old factors serve as the preconditioner of
iterative refinement against the new ``D`` (Higham, *Accuracy and Stability of Numerical
Algorithms*, ch. 12) until the normwise backward error is at the round-off of the residual;
a slow contraction, or many right-hand sides, factors the new ``D``.

**Binding** (docs/generated-module-protocol.md, "Compiled modules"): ``nw_bind(count, data,
sizes)`` takes the pointers of every float64 array of the module's data file in the order of
their keys (``_C_DATA`` of the wrapper: the file's member order) with their sizes, checks
count and sizes, and computes what depends on the data alone; every function returns 2
before it. A parametric body is bound in its compact form (:mod:`neweul_py.ffrf.varying`):
its base and the columns that vary as the data file stores them, and what the wrapper
derives from them once, when it binds (``_C_DERIVED``, :func:`.c_splice_trace.derived_array`):
the first row of its samples and its index tables as float64. The C code mixes them as
:func:`~neweul_py.ffrf.parametric.ffrf_mix` does (:data:`.c_kernel_text.C_MIX`), reading only the
varying columns of the samples next to ``σ``. Integer arrays of the data file (the rows of
node maps) are structure and are compiled in.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import sympy as sp

from ..errors import GenerationError
from ..model import as_expr
from .c_functions import SymbolGroups, big, c_body, c_function
from .c_kernel import KernelPrinter
from .c_kernel_text import C_DOT, C_MIX
from .c_printer import DotRows
from .c_splice_jacobians import JACOBIAN_C
from .c_splice_parameters import PARAMETER_C
from .c_splice_text import (
    CORE_C,
    ESOLVE_C,
    GLOBALS_C,
    POLY_C,
    SMAP_C,
    SPLICE_C,
    WMAP_C,
)
from .c_splice_trace import SpliceTrace, trace_splice, traced_kernels
from .c_templates import C_DOPRI5, C_GALPHA, C_LU
from .c_trace import Graph
from .cse import Block, eliminate
from .elastic import symbolic_part
from .writer import program_blocks

__all__ = ["ElasticSources", "render_elastic_sources"]

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
    arrays
        Those arrays, in that order (what a host without the data file binds: the FMU,
        :mod:`.fmu`).
    derived
        The keys of ``data`` that are no member of the data file, ``key → (kind, the keys
        of the members it is derived from)``
        (:func:`~.c_splice_trace.derived_array`: a parametric body's first row of samples
        and its index tables as float64).
    """

    core: str
    jac: str
    data: tuple[str, ...]
    sizes: dict[str, int]
    arrays: tuple[np.ndarray, ...] = ()
    derived: dict[str, tuple[str, tuple[str, ...]]] = dataclasses.field(default_factory=dict)


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
        Jp = (el.schedule_parameter_jacobian if el.schedule_parameter_jacobian is not None
              else sp.zeros(k, len(symbolic.parameters)))
        blocks["schedule_parameter_jacobian"] = eliminate((), [as_expr(e) for e in Jp],
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
    ("force_parameter_jacobian", "yyd", "the symbolic part's ∂(q−k)/∂p"),
    ("mass_matrix_parameter_derivative", "a", "the symbolic part's ∂(M a)/∂p"),
    ("output_parameter_jacobian", "yyd", "the symbolic part's ∂out/∂p"),
    ("schedule_parameter_jacobian", "y", "the schedules' ∂σ/∂p"),
)


def _symbolic_functions(symbolic: Any, blocks: dict[str, Block], which: tuple[str, ...],
                        dots: DotRows) -> list[str]:
    g = SymbolGroups(symbolic)
    lines: list[str] = []
    for name, args, what in _SYMBOLIC:
        if name not in which:
            continue
        block = blocks.get(name, Block((), ()))
        # rhs_parts' one caller, nw_dyn, passes a static buffer that only it writes and
        # nothing writes back into: its zero finals stay zero (no memset of NS² doubles)
        body = c_body(g, block, "out", what, dots, zeroed=name == "rhs_parts")
        lines += c_function(f"nw_s_{name}({_S_ARGS[args]})", body, big(block), static=True)
    return lines


# ------------------------------------------------------------------------------- C text
def _defines(t: SpliceTrace, nd: int, ny: int, nc: int) -> list[str]:
    R = [j for j in range(t.n) if j not in set(t.elastic)]
    npb = len(t.parametric)
    return [
        f"#define NW_NS {t.ns}", f"#define NW_NH {t.nh}", f"#define NW_NY {ny}",
        f"#define NW_NC {nc}", f"#define NW_NPB {npb}",
        f"#define NW_NW {sum(p['cols'] for p in t.parametric)}", f"#define NW_ND {nd}",
        f"#define NW_NE {len(t.elastic)}", f"#define NW_NR {len(R)}",
        f"#define NW_MOVING {int(t.moving)}", f"#define NW_DSIGMA {int(t.block_sigma)}",
    ]


def _weights_lines(t: SpliceTrace, data: dict[str, int],
                   polynomials: dict[tuple[int, str], tuple[str, int]]
                   ) -> tuple[list[str], list[str]]:
    """The weights at the schedules in ``nw_weights_at``, and the polynomial rows of the
    mixes that read them, made in ``nw_mixed`` when the weights changed (``nw_poly``,
    :meth:`.KernelPrinter._polynomial_rows`)."""
    lines, off, args = [], 0, []
    for k, p in enumerate(t.parametric):
        args.append(f"nw_D[{data[p['values']]}], nw_D[{data[p['coeff']]}], {p['nb']}, "
                    f"{p['nd']}, {p['cols']}")
        lines.append(f"    if (nw_weights(sigma[{k}], {args[k]}, w + {off}, dw + {off})) "
                     "return 3;")
        off += p["cols"]
    rows = [f"        nw_poly(sigma[{k}], {args[k]}, nw_D[{data[name]}], {nv}, {buf}, "
            f"nw_pw{k}, &{buf}_at);" for (k, name), (buf, nv) in sorted(polynomials.items())]
    return lines, rows


def _busy_weights(t: SpliceTrace, p: dict[str, Any]) -> int:
    """The most weights of the parametric body ``p`` that are not zero on one interval of
    its schedule: the rows a mix reads without the polynomial rows of ``nw_poly``, which
    read ``nd`` (worth it only with fewer)."""
    coeff = np.asarray(t.bound[p["coeff"]]).reshape(p["nd"], p["nb"] - 1, p["cols"])
    return int(np.any(coeff != 0.0, axis=0).sum(axis=1).max(initial=0))


#: The residual ``M a − (q − k)`` of the generalized-α loop (:data:`.C_GALPHA`), with ``M a``
#: of the traced ``nw_k_dynr`` (:mod:`.c_matvec`): ``M`` is not formed.
_RESIDUAL = r"""
static int nw_ga_residual(double t, const double *z, const double *a, const double *p,
                          const double *u, double *r)
{
    if (!nw_bound) return 2;
    if (nw_sym(t, z, z + NW_N, p, u)) return 3;
    nw_k_dynr(parts, z, z + NW_N, parts + NW_NH, parts + NW_NH + NW_NS * NW_NS, a, r);
    return 0;
}
"""


def _library(t: SpliceTrace, kernels: dict[str, tuple[list, list]], which: tuple[str, ...],
             data: list[str], sizes: dict[str, int], symbolic_lines: list[str],
             jacobian: bool) -> str:
    """One C file: the symbolic part, the traced kernels ``which``, the splice."""
    index = {k: i for i, k in enumerate(data)}
    pr = KernelPrinter(t.graph, data)
    pr.polynomial_weights = {t.graph.leaves[f"w{i}"].id: (i, p["nd"])
                             for i, p in enumerate(t.parametric)
                             if p["nd"] < _busy_weights(t, p)}
    for name in ("w", "dw", "wc"):           # the weights: global arrays of the splice
        off = 0
        for i, p in enumerate(t.parametric):
            leaf = t.graph.leaves[f"{name}{i}"]
            pr.params[leaf.id] = f"(nw_{name} + {off})" if off else f"nw_{name}"
            off += p["cols"]
    sw_storage, sw_offset, sw_strides = t.graph.storage_view(t.real["SW"].node)
    if sw_strides == (t.n, 1) and tuple(t.real["SW"].shape) == (t.ns, t.n):
        pr.row_spans[sw_storage.id] = (sw_offset, t.n, "nw_wmap")  # x @ S_W by rows' spans
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
                            direct=name in ("nw_k_dyn", "nw_k_dynr"))
    sv, sw = pr.pointer(t.real["SV"]), pr.pointer(t.real["SW"])
    sv0 = f"nw_D[{index['_splice/SV']}]"
    sv_sigma = int(pr.level[t.real["SV"].node.id] > 0)     # S_V(σ) mixed with the weights
    sv_mixed = int(sv_sigma or any(pr.level[d.node.id] > 0 for d in t.dsv))
    sw_sigma = int(pr.level[t.real["SW"].node.id] > 0)
    macros = [f"#define NW_SV {sv}", f"#define NW_SW {sw}", f"#define NW_SV0 {sv0}",
              f"#define NW_SV_SIGMA {sv_sigma}", f"#define NW_SV_MIXED {sv_mixed}",
              f"#define NW_SW_SIGMA {sw_sigma}"]
    if t.parametric:
        offs = np.cumsum([0, *(p["cols"] for p in t.parametric)])
        body.insert(0, f"static const int nw_woff[NW_NPB + 1] = "
                       f"{{{', '.join(str(int(o)) for o in offs)}}};")
        body.insert(1, "static const double *nw_dsv[NW_NPB] = {"
                       + ", ".join(pr.pointer(d) for d in t.dsv) + "};")
    weights, rows = _weights_lines(t, index, pr.polynomials)
    splice = (SPLICE_C.replace("NW_POLY_ROWS\n", "".join(f"{line}\n" for line in rows))
              .replace("NW_POLY\n", POLY_C.lstrip("\n"))
              .replace("NW_SMAP", SMAP_C.strip("\n")))
    splice = splice.replace("NW_WEIGHTS", "\n".join(weights))
    splice = splice.replace("NW_BIND", "\n".join(pr.bind_lines()))
    splice = splice.replace("NW_SIZES", ", ".join(str(sizes[k]) for k in data) or "0")
    R = [j for j in range(t.n) if j not in set(t.elastic)]
    esolve = (ESOLVE_C.replace("NW_ETABLE", ", ".join(map(str, t.elastic)))
              .replace("NW_RTABLE", ", ".join(map(str, R)) or "0"))
    splice = splice.replace("{esolve}", esolve)
    text = [*pr.static, *macros, WMAP_C, *body, C_LU, splice]
    if jacobian:
        fixed = ("    nw_k_fixed(fy, fyd, fy, fyd);" if "nw_k_fixed" in which else "")
        text += [JACOBIAN_C.replace("NW_FIXED_JACOBIANS", fixed), PARAMETER_C]
    else:
        text += [CORE_C, C_DOPRI5, _RESIDUAL, C_GALPHA]
    return "\n".join([*symbolic_lines, C_DOT, C_MIX, *text])


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
    t, _data_file = trace_splice(equations)
    kernels = traced_kernels(t)
    symbolic = symbolic_part(equations)
    blocks = _symbolic_blocks(symbolic, el, cse)
    ny = len(equations.output_names)
    ce = getattr(equations, "constraints", None)
    nc = 0 if ce is None else int(ce.nc)
    keys = tuple(k for k, a in sorted(t.bound.items()) if a.dtype.kind == "f")
    sizes = {k: int(t.bound[k].size) for k in keys}
    n, nu = t.n, len(equations.inputs)

    def head(what: str) -> list[str]:
        return [f"/* {what} of the model {model_name!r} in C: generated by neweul-py, do not "
                "edit. */", "#include <complex.h>", "#include <float.h>", "#include <math.h>",
                "#include <string.h>",
                f"#define NW_N {n}", f"#define NW_NU {nu}", f"#define NW_STATE_SIZE {2 * n}",
                f"#define NW_NP {len(equations.parameters)}",
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
    core_kernels = ("nw_k_dyn", "nw_k_dynr")
    jac_dots = DotRows(len(symbolic.coordinates))
    inputs_j = c_function("nw_s_default_inputs(double t, const double *p, double *out)",
                          c_body(g, blocks["default_inputs"], "out", "the default inputs",
                                 jac_dots), static=True)
    jac_sym = [*inputs_j, *_symbolic_functions(symbolic, blocks, tuple(
        name for name, _a, _w in _SYMBOLIC), jac_dots)]
    jac_kernels = tuple(k for k in ("nw_k_dyn", "nw_k_fixed", "nw_k_dirf", "nw_k_dirm",
                                    "nw_k_dirp", "nw_k_sigf", "nw_k_sigm") if k in kernels)
    core = _library(t, kernels, core_kernels, list(keys), sizes,
                    [*head("Equations of motion"), *dots.helper(), *core_sym], False)
    jac = _library(t, kernels, jac_kernels, list(keys), sizes,
                   [*head("Derivatives of the equations of motion"), *jac_dots.helper(),
                    *jac_sym], True)
    if not t.elastic:
        raise GenerationError("a model with elastic bodies but no elastic coordinates")
    return ElasticSources(core.rstrip("\n") + "\n", jac.rstrip("\n") + "\n", keys, {
        "n": n, "nu": nu, "np": len(equations.parameters), "ny": ny, "nc": nc},
        tuple(t.bound[k] for k in keys), {k: t.derived[k] for k in keys if k in t.derived})
