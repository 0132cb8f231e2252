#!/usr/bin/env python3
"""Peer side of bench_compiled.py: the N-link planar chain in sympy.physics.mechanics/PyDy.

Runs in a separate peer environment (pydy, cython; never a dependency of neweul-py)
or, for ``kane``, in any Python with sympy. One job per process, JSON on the last line:

* ``kane N`` — ``KanesMethod.kanes_equations`` of the chain (the whole-process peer of
  ``neweul generate``);
* ``pydy N SOLVER`` — derive, then ``pydy.codegen.ode_function_generators.generate_ode_function``
  with the Cython generator and ``linear_sys_solver`` = SOLVER (``numpy``: ``numpy.linalg.solve``
  at run time; ``sympy``: symbolic LU of the mass matrix, CSE'd), time the rhs per call, and
  simulate 10 s with ``solve_ivp(RK45, rtol = atol = 1e-8)`` from the chain's initial state;
* ``e2e N SOLVER`` — only derive, generate + compile, simulate (timed as a whole process).

The model is the one of examples/make_chain.py (uniform rods of mass m and length l, relative
joint angles about y, gravity −z, ``u = q̇``), as in bench_rigid_chain.py.
"""

from __future__ import annotations

import json
import sys
import time


def chain_model(n: int):
    """KanesMethod ingredients of the N-link planar chain."""
    import sympy as sp
    import sympy.physics.mechanics as me

    q = me.dynamicsymbols(f"q1:{n + 1}")
    u = me.dynamicsymbols(f"u1:{n + 1}")
    m, l, g = sp.symbols("m l g", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    bodies, loads = [], []
    parent, joint = N, O
    for i in range(n):
        A = parent.orientnew(f"A{i + 1}", "Axis", (q[i], parent.y))
        A.set_ang_vel(parent, u[i] * parent.y)
        if i > 0:
            tip = joint.locatenew(f"P{i + 1}", -l * parent.z)
            tip.v2pt_theory(joint, N, parent)
            joint = tip
        cm = joint.locatenew(f"C{i + 1}", -l / 2 * A.z)
        cm.v2pt_theory(joint, N, A)
        inertia = me.inertia(A, m * l**2 / 12, m * l**2 / 12, 0)
        bodies.append(me.RigidBody(f"B{i + 1}", cm, A, m, (inertia, cm)))
        loads.append((cm, -m * g * N.z))
        parent = A
    kd = [q[i].diff() - u[i] for i in range(n)]
    return q, u, (m, l, g), N, bodies, loads, kd


def kane(n: int):
    import sympy.physics.mechanics as me

    q, u, _params, N, bodies, loads, kd = chain_model(n)
    km = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
    km.kanes_equations(bodies, loads)
    return km, q, u, _params


def best_per_call(fn, seconds: float = 1.0) -> float:
    """Best of 5 timings, each of as many calls as fit in about ``seconds``, in CPU time of
    this process (``time.process_time``: on the shared machine wall-clock loops also count the
    time other jobs hold the cores)."""
    t0 = time.process_time()
    fn()
    single = time.process_time() - t0
    k = max(3, int(seconds / max(single, 1e-6)))
    times = []
    for _ in range(5):
        t0 = time.process_time()
        for _ in range(k):
            fn()
        times.append((time.process_time() - t0) / k)
    return min(times)


def cpu_total() -> float:
    """CPU seconds of this process and of the children it waited for (compilers)."""
    import resource

    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def _fresh(rhs, p):
    """``f(t, x)`` for ``solve_ivp`` returning a new array per call: PyDy's generated function
    writes every result into one buffer it returns again and again, and RK45 keeps the
    derivatives of a step's stages (``K[i] = f(...)``), which would all be that one array —
    the last stage's — and make the steps wrong."""
    return lambda t, x: rhs(x, t, p).copy()


def pydy(n: int, solver: str) -> dict:
    import numpy as np
    import sympy as sp
    from pydy.codegen.ode_function_generators import generate_ode_function
    from scipy.integrate import solve_ivp

    t0 = time.perf_counter()
    km, q, u, params = kane(n)
    t1, c1 = time.perf_counter(), cpu_total()
    kw = {"linear_sys_solver": solver, "cse": True} if solver == "sympy" else {}
    rhs = generate_ode_function(km.forcing, q, u, params, mass_matrix=km.mass_matrix,
                                coordinate_derivatives=sp.Matrix(u),
                                generator="cython", constants_arg_type="array", **kw)
    t2, c2 = time.perf_counter(), cpu_total()
    p = np.array([1.0, 0.5, 9.81])
    x0 = np.zeros(2 * n)
    x0[0] = 0.5
    per_call = best_per_call(lambda: rhs(x0, 0.0, p))
    t3, c3 = time.perf_counter(), time.process_time()
    sol = solve_ivp(_fresh(rhs, p), (0.0, 10.0), x0, method="RK45", rtol=1e-8, atol=1e-8)
    t4, c4 = time.perf_counter(), time.process_time()
    return {"derive": t1 - t0, "codegen_compile": t2 - t1, "codegen_cpu": c2 - c1,
            "rhs": per_call,
            "simulate": t4 - t3, "simulate_cpu": c4 - c3, "nfev": int(sol.nfev),
            "final": sol.y[:, -1].tolist(), "rhs_x0": rhs(x0, 0.0, p).tolist()}


def e2e(n: int, solver: str) -> dict:
    """Derive, generate + compile (Cython), simulate 10 s: the whole job, nothing else."""
    import numpy as np
    import sympy as sp
    from pydy.codegen.ode_function_generators import generate_ode_function
    from scipy.integrate import solve_ivp

    km, q, u, params = kane(n)
    kw = {"linear_sys_solver": solver, "cse": True} if solver == "sympy" else {}
    rhs = generate_ode_function(km.forcing, q, u, params, mass_matrix=km.mass_matrix,
                                coordinate_derivatives=sp.Matrix(u), generator="cython",
                                constants_arg_type="array", **kw)
    p = np.array([1.0, 0.5, 9.81])
    x0 = np.zeros(2 * n)
    x0[0] = 0.5
    sol = solve_ivp(_fresh(rhs, p), (0.0, 10.0), x0, method="RK45", rtol=1e-8, atol=1e-8)
    return {"nfev": int(sol.nfev)}


def main(argv: list[str]) -> None:
    job, n = argv[0], int(argv[1])
    t0 = time.perf_counter()
    if job == "kane":
        kane(n)
        out = {"derive": time.perf_counter() - t0}
    elif job == "pydy":
        out = pydy(n, argv[2])
    elif job == "e2e":
        out = e2e(n, argv[2])
    else:
        raise SystemExit(f"unknown job {job}")
    print(json.dumps(out))


if __name__ == "__main__":
    main(sys.argv[1:])
