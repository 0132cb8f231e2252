"""The compiled backend: the module's CSE'd program printed as C, behind the same protocol.

``write_c_module(equations, numpy_path)`` writes, next to the NumPy module
``<name>.py`` (its *twin*, written first by :func:`.writer.generate_module`):

* ``<name>_c.c`` and ``<name>_c_jac.c`` (the derivatives, built at their first use) — one C99
  function per protocol function, printed by :class:`.c_printer.CPrinter`
  from exactly the blocks the NumPy module prints (:func:`.writer.program_blocks`: same CSE,
  same forward-mode derivatives), the linear solve of ``rhs`` and ``rhs_jacobian`` by dense LU
  with partial pivoting (no symmetry assumed) or, when the mass matrix has a constant block
  (elastic coordinates), by block elimination with its inverse (:mod:`.c_solve`), and a
  Dormand–Prince 5(4) loop (:mod:`.c_templates`);
* ``<name>_c.py`` — a thin wrapper with the twin's constants and the protocol's names and
  signatures, calling the shared library through cffi (ABI mode: ``dlopen`` of a library built
  by the system C compiler). Build, cache (``__neweul_c__/`` next to the module, keyed by the
  SHA-256 of the C source), verification and loading are the code of :mod:`.c_runtime`, copied
  in. When the library cannot be had (no cffi, no compiler, a compiler error, an unwritable
  cache) the wrapper warns once and binds the twin's functions instead (``BACKEND = "numpy"``).

The wrapper adds one optional function to the protocol, ``integrate_dopri5`` (used by
``analysis.simulate(method="c-dopri5")``).
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import sympy as sp

from ..atomic import atomic_write
from ..progress import StagedProgress
from .c_functions import (
    MMTD_ARGS,
    X_ARGS,
    X_PROLOGUE,
    Y_ARGS,
    YYD_ARGS,
    SymbolGroups,
    big,
    c_body,
    c_function,
    x_prologue,
)
from .c_printer import DotRows
from .c_solve import c_solver, constant_block
from .c_splice import render_elastic_sources
from .c_templates import (
    C_DOPRI5,
    C_GALPHA,
    C_GALPHA_RESIDUAL,
    C_LU,
    C_SUPPORT_DECLARATIONS,
)
from .cse import Block
from .writer import program_blocks

__all__ = ["c_module_path", "core_declarations", "jacobian_declarations",
           "render_c_sources", "render_c_wrapper", "write_c_module"]

def c_module_path(numpy_path: str | os.PathLike[str]) -> Path:
    """``<dir>/<name>_c.py`` for the NumPy module ``<dir>/<name>.py``."""
    p = Path(numpy_path)
    return p.with_name(f"{p.stem}_c.py")


_MF_SIGNATURE = f"nw_mf({YYD_ARGS}, int full)"


#: The cffi declaration of the binding of the data file's arrays (models with elastic bodies,
#: :mod:`.c_splice`).
BIND_DECLARATION = "int nw_bind(int count, const double *const *data, const long *sizes);\n"


#: ``M`` and ``q − k`` in one evaluation, for the generalized-α loop (:data:`.C_GALPHA`).
_MASS_FORCE = [
    "static int nw_mass_force(double t, const double *y, const double *yd, const double *p,",
    "                         const double *u, double *M, double *f)",
    "{",
    "    static double mf[NW_N * NW_N + NW_N];",
    "    int code = nw_mf(t, y, yd, p, u, mf, 1);",
    "    if (code) return code;",
    "    memcpy(M, mf, NW_N * NW_N * sizeof(double));",
    "    memcpy(f, mf + NW_N * NW_N, NW_N * sizeof(double));",
    "    return 0;",
    "}",
    "",
]


def core_declarations() -> str:
    """cffi declarations of the core library (``<name>_c.c``)."""
    return "\n".join([
        "int nw_default_inputs(double t, const double *p, double *out);",
        f"int nw_mass_matrix({Y_ARGS});",
        f"int nw_force_vector({YYD_ARGS});",
        f"int nw_rhs({X_ARGS});",
        f"int nw_outputs({X_ARGS});",
        f"int nw_constraints({Y_ARGS});",
        f"int nw_constraint_jacobian({Y_ARGS});",
        f"int nw_constraint_time_derivative({Y_ARGS});",
        f"int nw_constraint_gamma({YYD_ARGS});",
    ]) + C_SUPPORT_DECLARATIONS


def jacobian_declarations(loss: bool = False) -> str:
    """cffi declarations of the derivative library (``<name>_c_jac.c``); ``loss``: with the
    hysteretic matrix ``nw_loss_matrix`` of models with loss factors."""
    return "\n".join([
        f"int nw_force_jacobians({YYD_ARGS});",
        f"int nw_mass_matrix_times_derivative({MMTD_ARGS});",
        f"int nw_rhs_jacobian({X_ARGS});",
        f"int nw_output_jacobians({X_ARGS});",
        *([f"int nw_loss_matrix({X_ARGS});"] if loss else []),
        f"int nw_force_parameter_jacobian({YYD_ARGS});",
        f"int nw_mass_matrix_parameter_derivative({MMTD_ARGS});",
        f"int nw_output_parameter_jacobian({X_ARGS});",
    ]) + "\n"


_RHS_JACOBIAN = """\
int nw_rhs_jacobian(double t, const double *x, const double *p, const double *u, double *out)
{
    NW_DEFAULT_INPUTS;
    const double *y = x, *yd = x + NW_N;
    double M[NW_N * NW_N], ydd[NW_N], fj[NW_N * (2 * NW_N + NW_NU)];
    double dMa[NW_N * NW_N], b[NW_N * 2 * NW_N];
    nw_fac fac;                                 /* one factorization of M for both solves */
    nw_mass_matrix(t, y, p, u, M);
    nw_force_vector(t, y, yd, p, u, ydd);
    if (nw_factor(M, &fac)) return 1;
    nw_factored_solve(M, &fac, 1, ydd);
    nw_force_jacobians(t, y, yd, p, u, fj);
    nw_mass_matrix_times_derivative(t, y, p, ydd, u, dMa);
    for (int i = 0; i < NW_N; ++i)
        for (int j = 0; j < 2 * NW_N; ++j)
            b[i * 2 * NW_N + j] = fj[i * (2 * NW_N + NW_NU) + j]
                                  - (j < NW_N ? dMa[i * NW_N + j] : 0.0);
    nw_factored_solve(M, &fac, 2 * NW_N, b);
    memset(out, 0, NW_STATE_SIZE * NW_STATE_SIZE * sizeof(double));
    for (int i = 0; i < NW_N; ++i) out[i * NW_STATE_SIZE + NW_N + i] = 1.0;
    memcpy(out + NW_N * NW_STATE_SIZE, b, sizeof b);
    return 0;
}
"""


def _head(model_name: str, what: str, n: int, nu: int, decls: Sequence[str]) -> list[str]:
    return [
        f"/* {what} of the model {model_name!r} in C: generated by neweul-py, do not edit. */",
        "#include <math.h>",
        "#include <string.h>",
        f"#define NW_N {n}",
        f"#define NW_NU {nu}",
        f"#define NW_STATE_SIZE {2 * n}",
        "#define NW_DEFAULT_INPUTS double nw_ub[NW_NU + 1]; "
        "if (!u) { nw_default_inputs(t, p, nw_ub); u = nw_ub; }",
        "",
        *decls,
        "",
    ]


def render_c_sources(equations: Any, blocks: dict[str, Block], model_name: str
                     ) -> tuple[str, str]:
    """The C99 texts of the two libraries (deterministic, like the NumPy module).

    The *core* (``<name>_c.c``: ``M``, ``q − k``, ``rhs`` with its linear solve, outputs,
    constraints, default inputs and the Dormand–Prince loop) is what simulations need and
    builds at import; the *derivatives* (``<name>_c_jac.c``: ``force_jacobians``,
    ``∂(M a)/∂y``, ``rhs_jacobian``, ``output_jacobians``, the parameter derivatives
    ``∂(q−k)/∂p``, ``∂(M a)/∂p``, ``∂out/∂p``, with private copies of ``M`` and
    ``q − k``) are the larger part of the program (chain N = 10: 70 % of it) and are built on
    their first use.
    """
    g = SymbolGroups(equations)
    n, nu = len(g.y), len(g.u)
    lu_protos = ["static int nw_lu(int n, double *a, int *piv);",
                 "static void nw_lu_solve(int n, const double *lu, const int *piv, int m, "
                 "double *b);"]
    # M x = b: dense LU, or block elimination of a constant block (c_solve.py); the core's
    # rhs solves once (nw_solve1), rhs_jacobian twice with one factorization
    block = constant_block(sp.ImmutableMatrix(equations.mass_matrix)) if n else None
    solve, solve_factored = c_solver(block), c_solver(block, factored=True)
    # the entries of that block, which the elimination never reads: not written for rhs
    unread = frozenset() if block is None else frozenset(
        i * n + j for i in block.block for j in block.block)

    # M and q − k from the one CSE'd program of rhs (computed once per call of any of the
    # three; mass_matrix passes ẏ = 0, on which M does not depend; full = 0: without the
    # entries unread)
    dots = DotRows(n)  # the rows of both files
    mf = [
        *c_function(_MF_SIGNATURE,
                   c_body(g, blocks["rhs"], "out", "the right-hand side", dots, unread),
                   static=True),
        *c_function(f"nw_mass_matrix({Y_ARGS})", [
            "double yd[NW_N] = {0}, mf[NW_N * NW_N + NW_N];", "nw_mf(t, y, yd, p, u, mf, 1);",
            "memcpy(out, mf, NW_N * NW_N * sizeof(double));"]),
        *c_function(f"nw_force_vector({YYD_ARGS})", [
            "double mf[NW_N * NW_N + NW_N];", "nw_mf(t, y, yd, p, u, mf, 0);",
            "memcpy(out, mf + NW_N * NW_N, NW_N * sizeof(double));"]),
    ]
    inputs = c_body(g, blocks["default_inputs"], "out", "the default inputs", dots)

    core_head = _head(model_name, "Equations of motion", n, nu, [
        core_declarations(), f"static int {_MF_SIGNATURE};", *lu_protos,
        "static int nw_solve1(double *a, double *b);"])
    core = list(core_head)
    core += c_function("nw_default_inputs(double t, const double *p, double *out)", inputs)
    core += mf
    core += c_function(f"nw_rhs({X_ARGS})", [
        *X_PROLOGUE, "double mf[NW_N * NW_N + NW_N];",
        "nw_mf(t, y, yd, p, u, mf, 0);",
        "if (nw_solve1(mf, mf + NW_N * NW_N)) return 1;",
        "memcpy(out, yd, NW_N * sizeof(double));",
        "memcpy(out + NW_N, mf + NW_N * NW_N, NW_N * sizeof(double));",
    ])
    core += c_function(f"nw_outputs({X_ARGS})",
                      [*x_prologue(g, blocks["outputs"]),
                       *c_body(g, blocks["outputs"], "out", "the outputs", dots)])
    for name, args in (("constraints", Y_ARGS), ("constraint_jacobian", Y_ARGS),
                       ("constraint_time_derivative", Y_ARGS),
                       ("constraint_gamma", YYD_ARGS)):
        core += c_function(f"nw_{name}({args})",
                          c_body(g, blocks[name], "out", name.replace("_", " "), dots))
    core += [C_LU, solve, C_DOPRI5, *_MASS_FORCE, C_GALPHA_RESIDUAL, C_GALPHA]

    jac_head = _head(model_name, "Derivatives of the equations of motion", n, nu, [
        jacobian_declarations("loss_matrix" in blocks),
        "static int nw_default_inputs(double t, const double *p, double *out);",
        f"static int {_MF_SIGNATURE};",
        f"static int nw_mass_matrix({Y_ARGS});",
        f"static int nw_force_vector({YYD_ARGS});", *lu_protos])
    jac = list(jac_head)
    jac += c_function("nw_default_inputs(double t, const double *p, double *out)", inputs,
                     static=True)
    jac += [line.replace("int nw_mass_matrix(", "static int nw_mass_matrix(")
            .replace("int nw_force_vector(", "static int nw_force_vector(") for line in mf]
    b = blocks["force_jacobians"]
    jac += c_function(f"nw_force_jacobians({YYD_ARGS})",
                     c_body(g, b, "out", "the force Jacobians", dots), big(b))
    b = blocks["mass_matrix_times_derivative"]
    jac += c_function(f"nw_mass_matrix_times_derivative({MMTD_ARGS})",
                     c_body(g, b, "out", "∂(M a)/∂y", dots), big(b))
    jac += [C_LU, solve_factored, _RHS_JACOBIAN]   # (nw_fac before its use)
    b = blocks["output_jacobians"]
    jac += c_function(f"nw_output_jacobians({X_ARGS})", [
        *x_prologue(g, b), *c_body(g, b, "out", "the output Jacobians", dots)], big(b))
    if "loss_matrix" in blocks:       # the hysteretic matrix G (equations.md §1.1)
        b = blocks["loss_matrix"]
        jac += c_function(f"nw_loss_matrix({X_ARGS})", [
            *x_prologue(g, b), *c_body(g, b, "out", "the loss matrix", dots)], big(b))
    # the parameter derivatives (docs/sensitivity.md)
    for name, args, what in (("force_parameter_jacobian", YYD_ARGS, "∂(q−k)/∂p"),
                             ("mass_matrix_parameter_derivative", MMTD_ARGS, "∂(M a)/∂p"),
                             ("output_parameter_jacobian", X_ARGS, "∂out/∂p")):
        b = blocks[name]
        head = x_prologue(g, b) if args == X_ARGS else []
        jac += c_function(f"nw_{name}({args})", [*head, *c_body(g, b, "out", what, dots)],
                          big(b))
    # nw_rows (the products of the rows) right after the declarations of each file
    core[len(core_head):len(core_head)] = dots.helper()
    jac[len(jac_head):len(jac_head)] = dots.helper()
    return ("\n".join(core).rstrip("\n") + "\n", "\n".join(jac).rstrip("\n") + "\n")


def render_c_wrapper(
    model_name: str, numpy_name: str, c_files: dict[str, str], sizes: dict[str, int],
    data: tuple[str, ...] = (),
    derived: dict[str, tuple[str, tuple[str, ...]]] | None = None,
) -> str:
    """The Python text of the wrapper module (see :mod:`.c_runtime` for the loading rules).

    ``c_files`` maps ``"core"`` and ``"jac"`` to ``(file name, SHA-256)`` pairs joined by a
    space; ``data``: the keys of the twin's data-file arrays the libraries are bound to
    (``nw_bind``, models with elastic bodies); ``derived``: those of them derived from
    data-file arrays (key → (kind, their keys), :func:`.c_splice_trace.derived_array`).
    """
    here = Path(__file__).parent
    runtime = (here / "c_runtime.py").read_text(encoding="utf-8")
    runtime = runtime.split("# ---- runtime begins\n", 1)[1]
    template = (here / "c_wrapper_template.py").read_text(encoding="utf-8")
    template = template.split("# ---- template begins\n", 1)[1]
    cdef = (core_declarations() + jacobian_declarations(bool(sizes.get("loss")))
            + (BIND_DECLARATION if data else ""))
    core_name, core_sha = c_files["core"].split(" ")
    jac_name, jac_sha = c_files["jac"].split(" ")
    settings = "\n".join([
        f"_MODEL_NAME = {model_name!r}",
        f"_TWIN_FILE = {numpy_name!r}",
        f"_C_FILE = {core_name!r}",
        f"_C_SHA256 = {core_sha!r}",
        f"_C_JAC_FILE = {jac_name!r}",
        f"_C_JAC_SHA256 = {jac_sha!r}",
        *(f"_{k.upper()} = {v!r}" for k, v in sizes.items()),
        f"_C_DATA = {data!r}",
        *([f"_C_DERIVED = {dict(derived or {})!r}"] if data else []),
        f"_CDEF = {cdef!r}",
    ])
    header = (
        f'"""Equations of motion of the model {model_name!r}, compiled: generated by '
        "neweul-py, do not edit.\n\n"
        "Implements the generated-module protocol (docs/generated-module-protocol.md) with "
        f"the C libraries built\nfrom {core_name} (at import) and {jac_name} (at the first "
        "Jacobian call) through cffi, cached in\n__neweul_c__/ by content hash; falls back to "
        f"the NumPy module {numpy_name} with one warning\nwhen a library cannot be built or "
        'loaded (BACKEND tells which).\n"""\n'
    )
    return header + runtime + "\n# ---- module settings\n" + settings + "\n" + template


def write_c_module(
    equations: Any, numpy_path: str | os.PathLike[str], *, cse: bool = True,
    progress: StagedProgress = None,
) -> Path:
    """Write ``<name>_c.c`` and ``<name>_c.py`` next to the NumPy module ``numpy_path``.

    Parameters
    ----------
    equations
        The symbolic equations the NumPy module was generated from.
    numpy_path
        The NumPy module (already written).
    progress
        A staged hook (:func:`.writer.program_blocks`).

    Returns
    -------
    Path
        The wrapper ``<name>_c.py``.

    Raises
    ------
    GenerationError
        For expressions that cannot be printed, or a kernel operation that cannot be traced
        (:mod:`.c_splice`).
    """
    system = equations.system
    data: tuple[str, ...] = ()
    derived: dict[str, tuple[str, tuple[str, ...]]] = {}
    if getattr(equations, "elastic", None) is not None:
        # the kernel traced on its data, which are bound at load time (codegen/c_splice.py)
        src = render_elastic_sources(equations, system.name, cse=cse)
        core, jac, data, derived = src.core, src.jac, src.data, src.derived
        sizes = {**src.sizes, "loss": 0}
    else:
        blocks = program_blocks(equations, cse=cse, progress=progress)
        core, jac = render_c_sources(equations, blocks, system.name)
        ce = getattr(equations, "constraints", None)
        sizes = {
            "n": len(equations.coordinates),
            "nu": len(equations.inputs),
            "np": len(equations.parameters),
            "ny": len(equations.outputs),
            "nc": 0 if ce is None else int(ce.nc),
            "loss": int("loss_matrix" in blocks),
        }
    numpy_path = Path(numpy_path)
    wrapper = c_module_path(numpy_path)
    c_path = wrapper.with_suffix(".c")
    jac_path = wrapper.with_name(f"{wrapper.stem}_jac.c")
    files = {"core": f"{c_path.name} {hashlib.sha256(core.encode()).hexdigest()}",
             "jac": f"{jac_path.name} {hashlib.sha256(jac.encode()).hexdigest()}"}
    py = render_c_wrapper(system.name, numpy_path.name, files, sizes, data, derived)
    atomic_write(c_path, core)
    atomic_write(jac_path, jac)
    return atomic_write(wrapper, py)
