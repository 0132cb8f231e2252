#!/usr/bin/env python3
"""Rigid-core benchmarks: N-link planar pendulum chain, neweul-py against sympy.physics.mechanics.

Measured in one run, each timing in a fresh Python process (so that no sympy cache is shared):

1. derivation + code generation of the chain by neweul-py (``load → newton_euler → generate``)
   for N = 2 … 30, versus ``sympy.physics.mechanics.KanesMethod`` derivation alone
   (``kanes_equations``) for N ≤ ``--kane-max`` (default 10; it takes minutes beyond);
2. time per call of the right-hand side at N = ``--rhs-n`` (default 10): the generated
   module's ``rhs`` versus ``lambdify`` of Kane's mass matrix and forcing + ``numpy.linalg.solve``
   (both checked to agree first);
3. operation counts (``sympy.count_ops``) of both right-hand sides after CSE.

Usage::

    python benchmarks/bench_rigid_chain.py                 # the default set (a few minutes)
    python benchmarks/bench_rigid_chain.py --quick         # N = 2, 5, 10 only
    python benchmarks/bench_rigid_chain.py --kane-max 15   # let Kane run further (slow)

Nothing here asserts a time: the script prints figures and ratios.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples"))


# ----------------------------------------------------------------------------- workers
def _ours(n: int, out_dir: str) -> dict:
    """Derive and generate the N-link planar chain; return timings."""
    t0 = time.perf_counter()
    from make_chain import chain_description

    from neweul_py.codegen import generate_module
    from neweul_py.description import description_hash, load_description_text
    from neweul_py.equations import newton_euler

    t_import = time.perf_counter() - t0
    text = chain_description(n)
    t0 = time.perf_counter()
    system = load_description_text(text, f"chain{n}")
    eq = newton_euler(system, form="auto")
    t1 = time.perf_counter()
    path = generate_module(eq, description_hash(text), Path(out_dir) / f"chain{n}_planar.py")
    t2 = time.perf_counter()
    return {"derive": t1 - t0, "generate": t2 - t1, "total": t2 - t0, "import": t_import,
            "size": path.stat().st_size, "path": str(path),
            "form": "recursive" if eq.intermediates else "closed"}


def _kane_model(n: int):
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
        if i > 0:  # the joint is the tip of the previous link
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


def _kane(n: int) -> dict:
    import sympy.physics.mechanics as me

    q, u, _params, N, bodies, loads, kd = _kane_model(n)
    t0 = time.perf_counter()
    kane = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
    kane.kanes_equations(bodies, loads)
    t1 = time.perf_counter()
    return {"derive": t1 - t0}


def _rhs(n: int, module_path: str) -> dict:
    import numpy as np
    import sympy as sp
    import sympy.physics.mechanics as me

    from neweul_py.analysis.module import load_generated

    q, u, params, N, bodies, loads, kd = _kane_model(n)
    kane = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
    kane.kanes_equations(bodies, loads)
    qs = sp.symbols(f"q1:{n + 1}")
    us = sp.symbols(f"u1:{n + 1}")
    sub = dict(zip(q, qs, strict=True)) | dict(zip(u, us, strict=True))
    M = me.msubs(kane.mass_matrix, sub)
    F = me.msubs(kane.forcing, sub)
    args = (*qs, *us, *params)
    fM = sp.lambdify(args, M, "numpy")
    fF = sp.lambdify(args, F, "numpy")
    fMF = sp.lambdify(args, [M, F], "numpy", cse=True)  # a stronger peer: one CSE'd function

    mod = load_generated(module_path)
    p = mod.default_parameters()  # m, l, g — same order as params
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, 2 * n)

    def kane_rhs(x: np.ndarray) -> np.ndarray:
        vals = (*x, *p)
        acc = np.linalg.solve(fM(*vals), np.asarray(fF(*vals), dtype=float).ravel())
        return np.concatenate([x[n:], acc])

    def kane_cse_rhs(x: np.ndarray) -> np.ndarray:
        m_num, f_num = fMF(*x, *p)
        acc = np.linalg.solve(m_num, np.asarray(f_num, dtype=float).ravel())
        return np.concatenate([x[n:], acc])

    ours, theirs = mod.rhs(0.0, x, p), kane_rhs(x)
    err = float(np.max(np.abs(ours - theirs)) / np.max(np.abs(theirs)))
    err = max(err, float(np.max(np.abs(kane_cse_rhs(x) - theirs)) / np.max(np.abs(theirs))))

    def best(fn, seconds: float = 1.0) -> float:
        """Best of 5 timings, each of as many calls as fit in about ``seconds``."""
        t0 = time.perf_counter()
        fn()
        single = time.perf_counter() - t0
        k = max(3, int(seconds / max(single, 1e-7)))
        times = []
        for _ in range(5):
            t0 = time.perf_counter()
            for _ in range(k):
                fn()
            times.append((time.perf_counter() - t0) / k)
        return min(times)

    t_ours = best(lambda: mod.rhs(0.0, x, p))
    t_kane = best(lambda: kane_rhs(x))
    t_kane_cse = best(lambda: kane_cse_rhs(x))

    # operation counts after CSE
    ops_kane_raw = int(sp.count_ops(M) + sp.count_ops(F))
    t0 = time.perf_counter()
    rep, red = sp.cse([*M, *F], order="none")
    t_cse = time.perf_counter() - t0
    ops_kane = int(sum(sp.count_ops(e) for _, e in rep) + sum(sp.count_ops(e) for e in red))
    return {"err": err, "ours": t_ours, "kane": t_kane, "kane_cse": t_kane_cse,
            "ops_kane_raw": ops_kane_raw,
            "ops_kane_cse": ops_kane, "kane_cse_time": t_cse}


def _ops_ours(n: int) -> dict:
    import sympy as sp
    from make_chain import chain_description

    from neweul_py.codegen.blocks import mass_entries
    from neweul_py.codegen.cse import eliminate
    from neweul_py.description import load_description_text
    from neweul_py.equations import newton_euler

    eq = newton_euler(load_description_text(chain_description(n)), form="auto")
    values, _ = mass_entries(eq.mass_matrix)
    method = "tree" if eq.intermediates else "full"
    block = eliminate(eq.intermediates, [*values, *eq.force_vector], method=method)
    ops = sum(sp.count_ops(e) for _, e in block.assignments) + sum(
        sp.count_ops(e) for e in block.finals)
    return {"ops": int(ops), "assignments": len(block.assignments)}


def _worker(argv: list[str]) -> None:
    kind, n = argv[0], int(argv[1])
    if kind == "ours":
        out = _ours(n, argv[2])
    elif kind == "kane":
        out = _kane(n)
    elif kind == "rhs":
        out = _rhs(n, argv[2])
    elif kind == "ops":
        out = _ops_ours(n)
    else:
        raise SystemExit(f"unknown worker {kind}")
    print(json.dumps(out))


def _run(*args: str, timeout: float | None = None) -> dict | None:
    try:
        proc = subprocess.run(
            [sys.executable, __file__, "--worker", *args], capture_output=True, text=True,
            timeout=timeout, env={**os.environ, "PYTHONHASHSEED": "0"},
        )
    except subprocess.TimeoutExpired:
        return None
    if proc.returncode != 0:
        sys.stderr.write(proc.stderr)
        raise SystemExit(f"worker {args} failed")
    return json.loads(proc.stdout.strip().splitlines()[-1])


# ----------------------------------------------------------------------------- main
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worker", nargs="+", help=argparse.SUPPRESS)
    parser.add_argument("--sizes", type=int, nargs="+",
                        default=[2, 3, 4, 5, 6, 8, 10, 15, 20, 25, 30])
    parser.add_argument("--quick", action="store_true", help="N = 2, 5, 10 only")
    parser.add_argument("--kane-max", type=int, default=10,
                        help="largest N for KanesMethod (default 10)")
    parser.add_argument("--kane-timeout", type=float, default=900.0,
                        help="give up on one KanesMethod derivation after this many seconds")
    parser.add_argument("--rhs-n", type=int, default=10, help="N of the per-call rhs timing")
    args = parser.parse_args()
    if args.worker:
        _worker(args.worker)
        return
    sizes = [2, 5, 10] if args.quick else args.sizes
    print(f"Python {sys.version.split()[0]}; one fresh process per figure\n")
    print("1. derivation + code generation of the N-link planar chain")
    print(f"{'N':>3} {'form':>9} {'ours [s]':>9} {'(derive':>8} {'generate)':>10} "
          f"{'module':>9} {'Kane [s]':>9} {'Kane/ours':>9}")
    with tempfile.TemporaryDirectory() as tmp:
        paths: dict[int, str] = {}
        for n in sizes:
            o = _run("ours", str(n), tmp)
            assert o is not None
            paths[n] = o["path"]
            k = (_run("kane", str(n), timeout=args.kane_timeout)
                 if n <= args.kane_max else None)
            kt = f"{k['derive']:9.2f}" if k else f"{'-':>9}"
            ratio = f"{k['derive'] / o['total']:9.1f}" if k else f"{'-':>9}"
            print(f"{n:3d} {o['form']:>9} {o['total']:9.2f} {o['derive']:8.2f} "
                  f"{o['generate']:10.2f} {o['size'] / 1e3:7.0f}kB {kt} {ratio}", flush=True)
        n = args.rhs_n
        if n not in paths:
            o = _run("ours", str(n), tmp)
            assert o is not None
            paths[n] = o["path"]
        r = _run("rhs", str(n), paths[n])
        ops = _run("ops", str(n))
    assert r is not None and ops is not None
    print(f"\n2. right-hand side per call at N = {n} (relative difference of the two: "
          f"{r['err']:.1e})")
    print(f"   ours (generated module rhs):            {r['ours'] * 1e6:9.1f} µs")
    print(f"   lambdify(Kane M, forcing) + solve:      {r['kane'] * 1e6:9.1f} µs")
    print(f"   ratio Kane/ours:                        {r['kane'] / r['ours']:9.1f}")
    print(f"   (stronger peer: lambdify(..., cse=True): {r['kane_cse'] * 1e6:8.1f} µs, ratio "
          f"{r['kane_cse'] / r['ours']:.1f})")
    print(f"\n3. operation counts (sympy.count_ops) of the right-hand side at N = {n}")
    print(f"   ours, after CSE ({ops['assignments']} assignments): {ops['ops']:9d}")
    print(f"   Kane M + forcing, raw:                  {r['ops_kane_raw']:9d}")
    print(f"   Kane M + forcing, after sympy.cse:      {r['ops_kane_cse']:9d} "
          f"(cse took {r['kane_cse_time']:.1f} s)")
    print(f"   ratio Kane(cse)/ours:                   {r['ops_kane_cse'] / ops['ops']:9.1f}")


if __name__ == "__main__":
    main()
