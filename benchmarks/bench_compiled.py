#!/usr/bin/env python3
"""Compiled backend: neweul-py's C module against PyDy, KanesMethod and NumPy.

All figures of one run come from fresh processes started by this script, ours in this Python (the
project environment), PyDy's in a peer environment (``--peer-python PATH``, or the environment
variable ``NEWEUL_PEER_PYTHON``: a Python with pydy + cython; never a dependency of neweul-py):

(a) planar chain N = 10 (examples/make_chain.py): rhs per call of the compiled module, the
    NumPy module, ``lambdify([M, F], cse=True)`` + ``numpy.linalg.solve`` of KanesMethod's
    equations, PyDy's Cython backend with ``numpy.linalg.solve`` and with the symbolic LU
    (``linear_sys_solver="sympy"``); code generation + compile time; end to end (derive +
    generate + compile + simulate 10 s, RK45 rtol = atol = 1e-8) and the integrators on the
    compiled rhs (SciPy RK45 / DOP853 / LSODA vs the C loop ``c-dopri5``);
(b) ``neweul generate`` of examples/chain10_planar.yaml as a whole process (NumPy and
    ``--backend c``) against a process running ``KanesMethod.kanes_equations``;
(c) derivation + generation of the planar N = 30 and spatial N = 8 chains, NumPy and C;
(d) a Hex20 flexible pendulum (10 modes, 1 s) in Exudyn (benchmarks/_peer_exudyn.py) and ours
    (benchmarks/_ours_hex_pendulum.py), both generalized-alpha with h = 1e-3, rho_inf = 0.9.

Usage::

    nice -n 10 python benchmarks/bench_compiled.py            # everything (~ 3 min)
    nice -n 10 python benchmarks/bench_compiled.py --skip-peers
    python benchmarks/bench_compiled.py --only generate --kane-runs 3   # (b) alone, ~1 min

Per-call figures are CPU time of the calling process (best of 5 loops); whole processes are
given as wall and CPU time (user + system of the process and its compiler), since on the
shared machine wall-clock time mostly measures the other jobs. Every job runs with bytecode
caching on (a temporary ``PYTHONPYCACHEPREFIX``), as an installed package would. Nothing here
asserts a time: the script prints figures and ratios.
"""

from __future__ import annotations

import argparse
import atexit
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(ROOT / "examples"))
sys.path.insert(0, str(HERE))


# ----------------------------------------------------------------------------- workers
def _generate(n: int, spatial: bool, out_dir: str) -> dict:
    """Derive, write the NumPy module, write and compile the C module (fresh directory)."""
    from make_chain import chain_description

    from neweul_py.analysis.module import load_generated
    from neweul_py.codegen import generate_module
    from neweul_py.codegen.c_module import write_c_module
    from neweul_py.description import description_hash, load_description_text
    from neweul_py.equations import newton_euler

    text = chain_description(n, spatial)
    t0 = time.perf_counter()
    eq = newton_euler(load_description_text(text, "chain"), form="auto")
    t1 = time.perf_counter()
    npath = generate_module(eq, description_hash(text), Path(out_dir) / "chain.py")
    t2, c_text0 = time.perf_counter(), time.process_time()
    cpath = write_c_module(eq, npath)
    t3 = time.perf_counter()
    text_cpu = time.process_time() - c_text0
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    mod = load_generated(cpath)  # builds the core library
    t4 = time.perf_counter()
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    assert mod.BACKEND == "c", mod.BACKEND_NOTE
    mod.rhs_jacobian(0.0, mod.INITIAL_STATE, mod.default_parameters())  # the derivatives
    t5 = time.perf_counter()
    cpu2 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return {"derive": t1 - t0, "numpy": t2 - t1, "c_text": t3 - t2, "compile": t4 - t3,
            "c_text_cpu": text_cpu,
            "compile_cpu": cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime,
            "compile_jac": t5 - t4,
            "compile_jac_cpu": cpu2.ru_utime + cpu2.ru_stime - cpu1.ru_utime - cpu1.ru_stime,
            "path": str(npath), "cpath": str(cpath),
            "c_size": sum(f.stat().st_size for f in Path(out_dir).glob("*.c"))}


def _ours(n: int, out_dir: str) -> dict:
    """(a), our side: generation, rhs per call, simulations."""
    import numpy as np
    from _peer_pydy import best_per_call

    from neweul_py.analysis.module import load_generated
    from neweul_py.analysis.simulate import simulate

    t0 = time.perf_counter()
    g = _generate(n, False, out_dir)
    t_gen = time.perf_counter() - t0
    mc, mn = load_generated(g["cpath"]), load_generated(g["path"])
    p = mc.default_parameters()
    x0 = np.asarray(mc.INITIAL_STATE, dtype=float)
    out = {"gen": g, "generate_total": t_gen}
    out["rhs_c"] = best_per_call(lambda: mc.rhs(0.0, x0, p))
    out["rhs_numpy"] = best_per_call(lambda: mn.rhs(0.0, x0, p))
    out["jac_c"] = best_per_call(lambda: mc.rhs_jacobian(0.0, x0, p), 0.5)
    out["jac_numpy"] = best_per_call(lambda: mn.rhs_jacobian(0.0, x0, p), 0.5)
    out["rhs_x0"] = mc.rhs(0.0, x0, p).tolist()
    import scipy.integrate  # noqa: F401  (imported at the first SciPy method: not its time)

    sims = {}
    for label, mod, method in (("c-dopri5", mc, "c-dopri5"), ("RK45 (C rhs)", mc, "RK45"),
                               ("DOP853 (C rhs)", mc, "DOP853"), ("LSODA (C rhs)", mc, "LSODA"),
                               ("RK45 (NumPy rhs)", mn, "RK45")):
        t0, c0 = time.perf_counter(), time.process_time()
        r = simulate(mod, 10.0, method=method, rtol=1e-8, atol=1e-8, n_out=2)
        sims[label] = {"time": time.perf_counter() - t0, "cpu": time.process_time() - c0,
                       "nfev": r.nfev,
                       "final": np.hstack((r.y[-1], r.yd[-1])).tolist()}
    out["sims"] = sims
    return out


def _lambdify(n: int) -> dict:
    """(a), lambdify(cse=True) of KanesMethod's M and forcing + numpy.linalg.solve."""
    import numpy as np
    import sympy as sp
    import sympy.physics.mechanics as me
    from _peer_pydy import best_per_call, kane

    km, q, u, params = kane(n)
    qs, us = sp.symbols(f"q1:{n + 1}"), sp.symbols(f"u1:{n + 1}")
    sub = dict(zip(q, qs, strict=True)) | dict(zip(u, us, strict=True))
    f = sp.lambdify((*qs, *us, *params), [me.msubs(km.mass_matrix, sub),
                                          me.msubs(km.forcing, sub)], "numpy", cse=True)
    p = (1.0, 0.5, 9.81)
    x0 = np.zeros(2 * n)
    x0[0] = 0.5

    def rhs(x):
        m_num, f_num = f(*x, *p)
        return np.concatenate([x[n:], np.linalg.solve(m_num, np.ravel(f_num))])

    return {"rhs": best_per_call(lambda: rhs(x0)), "rhs_x0": rhs(x0).tolist()}


def _worker(argv: list[str]) -> None:
    kind = argv[0]
    if kind == "ours":
        out = _ours(int(argv[1]), argv[2])
    elif kind == "lambdify":
        out = _lambdify(int(argv[1]))
    elif kind == "gen":
        out = _generate(int(argv[1]), argv[2] == "spatial", argv[3])
    else:
        raise SystemExit(f"unknown worker {kind}")
    print(json.dumps(out))


def _environment(extra: dict | None) -> dict:
    """The environment of a job: this one, a fixed hash seed, and bytecode caching on (in
    :data:`PYCACHE`, as an installed package has its ``.pyc`` files; a development shell with
    ``PYTHONDONTWRITEBYTECODE=1`` would otherwise recompile neweul-py's ~100 modules in every
    process — ≈ 0.1 s CPU — while sympy's come precompiled from site-packages)."""
    env = {**os.environ, "PYTHONHASHSEED": "0", "PYTHONPYCACHEPREFIX": PYCACHE, **(extra or {})}
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


#: Bytecode cache of the jobs (a temporary directory per run, warmed by the first jobs).
PYCACHE = tempfile.mkdtemp(prefix="neweul-bench-pyc-")
atexit.register(shutil.rmtree, PYCACHE, True)


def _run(cmd: list[str], env: dict | None = None) -> dict:
    proc = subprocess.run(cmd, capture_output=True, text=True, env=_environment(env))
    if proc.returncode != 0:
        sys.stderr.write(proc.stderr)
        raise SystemExit(f"{cmd} failed")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _ours_job(*args: str) -> dict:
    return _run([sys.executable, __file__, "--worker", *args])


def _wall(cmd: list[str], env: dict | None = None) -> tuple[float, float]:
    """Wall time and CPU time (user + system, the process and what it waited for: the C or
    Cython compiler) of a whole process."""
    c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, env=_environment(env))
    wall = time.perf_counter() - t0
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, c1.ru_utime + c1.ru_stime - c0.ru_utime - c0.ru_stime


def _rel(a: list[float], b: list[float]) -> float:
    import numpy as np

    a, b = np.asarray(a), np.asarray(b)
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


def _whole_process(kane_runs: int) -> None:
    """(b): ``neweul generate`` of examples/chain10_planar.yaml as whole processes (best CPU
    of 5 cold runs, the bytecode cache warm) against the KanesMethod process (best CPU of
    ``kane_runs``; plain sympy, this Python)."""
    print("\n(b) whole process, examples/chain10_planar.yaml")
    with tempfile.TemporaryDirectory() as tmp:
        cache = {"NEWEUL_CACHE": str(Path(tmp) / "cache")}
        cli = [sys.executable, "-m", "neweul_py.cli", "generate",
               str(ROOT / "examples" / "chain10_planar.yaml"), "-o", tmp]
        _wall([*cli, "--no-cache"], cache)  # warm the bytecode cache (and nothing else)
        t_np = min((_wall([*cli, "--no-cache"], cache) for _ in range(5)), key=lambda t: t[1])
        t_miss = _wall(cli, cache)  # derives and stores in the content-hash cache
        t_hit = _wall(cli, cache)  # the verified cache entry, no sympy
        t_c = _wall([*cli[:-1], str(Path(tmp) / "c"), "--backend", "c"], cache)
    t_kane = min((_wall([sys.executable, str(HERE / "_peer_pydy.py"), "kane", "10"])
                  for _ in range(kane_runs)), key=lambda t: t[1])
    print(f"    (best CPU of 5 cold runs; KanesMethod best of {kane_runs}; the bytecode cache "
          f"warm: {PYCACHE}; load average {os.getloadavg()[0]:.1f})")
    for label, t in (("neweul generate --no-cache:  ", t_np),
                     ("neweul generate (cache miss):", t_miss),
                     ("neweul generate (cache hit): ", t_hit),
                     ("neweul generate --backend c:", t_c)):
        print(f"    {label} {t[0]:6.2f} s wall, {t[1]:6.2f} s CPU   Kane/ours "
              f"{t_kane[0] / t[0]:5.1f} (wall), {t_kane[1] / t[1]:5.1f} (CPU)")
    print(f"    KanesMethod process:          {t_kane[0]:6.2f} s wall, {t_kane[1]:6.2f} s CPU")


# ----------------------------------------------------------------------------- main
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worker", nargs="+", help=argparse.SUPPRESS)
    parser.add_argument("--peer-python", default=os.environ.get("NEWEUL_PEER_PYTHON", ""),
                        help="Python of the peer environment (pydy, cython, exudyn)")
    parser.add_argument("--skip-peers", action="store_true")
    parser.add_argument("-n", type=int, default=10, help="chain length of (a) (default 10)")
    parser.add_argument("--only", choices=("all", "generate"), default="all",
                        help="generate: part (b) alone (no peer venv needed: KanesMethod is "
                        "plain sympy)")
    parser.add_argument("--kane-runs", type=int, default=1, metavar="K",
                        help="KanesMethod processes of (b), best CPU of K (default 1)")
    args = parser.parse_args()
    if args.worker:
        _worker(args.worker)
        return
    if args.only == "generate":
        print(f"Python {sys.version.split()[0]}; one fresh process per job; "
              f"load average {os.getloadavg()[0]:.1f}")
        _whole_process(args.kane_runs)
        return
    n = args.n
    peer = not args.skip_peers and bool(args.peer_python) and Path(args.peer_python).exists()
    print(f"Python {sys.version.split()[0]}; one fresh process per job; "
          f"load average {os.getloadavg()[0]:.1f}\n")
    with tempfile.TemporaryDirectory() as tmp:
        o = _ours_job("ours", str(n), tmp)
        lam = _ours_job("lambdify", str(n))
        pyd = {s: _run([args.peer_python, str(HERE / "_peer_pydy.py"), "pydy", str(n), s])
               for s in (("numpy", "sympy") if peer else ())}
    g = o["gen"]
    print(f"(a) planar chain N = {n}: rhs per call, CPU time (agreement with ours: relative "
          "max diff)")
    rows = [("ours, compiled C module", o["rhs_c"], 0.0),
            ("ours, NumPy module", o["rhs_numpy"], 0.0),
            ("lambdify([M, F], cse=True) + solve", lam["rhs"], _rel(lam["rhs_x0"], o["rhs_x0"]))]
    for s, label in (("numpy", "PyDy Cython, numpy.linalg.solve"),
                     ("sympy", "PyDy Cython, symbolic LU")):
        if s in pyd:
            rows.append((label, pyd[s]["rhs"], _rel(pyd[s]["rhs_x0"], o["rhs_x0"])))
    for label, t, err in rows:
        print(f"    {label:38s} {t * 1e6:9.2f} µs   ×{t / o['rhs_c']:7.1f} of compiled"
              f"   (diff {err:.1e})")
    print(f"    NumPy module: lambdify(cse=True) / ours = {lam['rhs'] / o['rhs_numpy']:.1f} "
          "(goal >= 5; goal <= 20 us per call)")
    print(f"    rhs_jacobian: compiled {o['jac_c'] * 1e6:.1f} µs, NumPy "
          f"{o['jac_numpy'] * 1e6:.1f} µs (×{o['jac_numpy'] / o['jac_c']:.0f})")
    print(f"  code generation + compile: ours {g['c_text'] + g['compile']:.2f} s (C text "
          f"{g['c_text']:.2f} s, cc of the core {g['compile']:.2f} s [cc CPU "
          f"{g['compile_cpu']:.2f} s]; NumPy module {g['numpy']:.2f} s, derivation "
          f"{g['derive']:.2f} s; derivative library at first use {g['compile_jac']:.2f} s "
          f"[CPU {g['compile_jac_cpu']:.2f} s])")
    print(f"    ours in CPU time: {g['c_text_cpu'] + g['compile_cpu']:.2f} s")
    for s in pyd:
        print(f"    PyDy Cython ({s}): {pyd[s]['codegen_compile']:.2f} s, CPU "
              f"{pyd[s]['codegen_cpu']:.2f} s (derivation {pyd[s]['derive']:.2f} s); ratio "
              f"of CPU {pyd[s]['codegen_cpu'] / (g['c_text_cpu'] + g['compile_cpu']):.1f}")
    print("  10 s simulation, rtol = atol = 1e-8 (CPU time [wall], rhs calls, ratio of CPU):")
    base = o["sims"]["c-dopri5"]
    for label, r in o["sims"].items():
        print(f"    {label:24s} {r['cpu']:7.3f} s [{r['time']:7.3f}] {r['nfev']:6d} calls  "
              f"×{r['cpu'] / base['cpu']:6.1f}  "
              f"(final state vs c-dopri5: {_rel(r['final'], base['final']):.1e})")
    for s in pyd:
        print(f"    {'PyDy ' + s + ' RK45':24s} {pyd[s]['simulate_cpu']:7.3f} s "
              f"[{pyd[s]['simulate']:7.3f}] {pyd[s]['nfev']:6d} calls  "
              f"×{pyd[s]['simulate_cpu'] / base['cpu']:6.1f}  "
              f"(final state vs c-dopri5: {_rel(pyd[s]['final'], base['final']):.1e})")
    print("  end to end, whole processes (derive + generate + compile + simulate 10 s, "
          "rtol = atol = 1e-8):")
    with tempfile.TemporaryDirectory() as tmp:
        t_e2e = _wall([sys.executable, "-m", "neweul_py.cli", "simulate",
                       str(ROOT / "examples" / "chain10_planar.yaml"), "--backend", "c",
                       "--method", "c-dopri5", "--t-end", "10", "--rtol", "1e-8", "--atol",
                       "1e-8", "--n-out", "2"], {"NEWEUL_CACHE": tmp})
    print(f"    ours: neweul simulate --backend c --method c-dopri5 (empty cache): "
          f"{t_e2e[0]:6.2f} s wall, {t_e2e[1]:6.2f} s CPU")
    for s in pyd:
        t = _wall([args.peer_python, str(HERE / "_peer_pydy.py"), "e2e", str(n), s])
        print(f"    PyDy Cython ({s}), RK45:  {t[0]:6.2f} s wall, {t[1]:6.2f} s CPU   "
              f"PyDy/ours {t[0] / t_e2e[0]:5.1f} (wall), {t[1] / t_e2e[1]:5.1f} (CPU)")

    _whole_process(args.kane_runs)

    print("\n(c) derivation + generation (fresh process each)")
    print(f"    {'model':14s} {'derive':>7s} {'NumPy':>7s} {'C text':>7s} {'cc core':>8s} "
          f"{'cc deriv.':>9s} {'C source':>9s}   [s; cc CPU in brackets]")
    with tempfile.TemporaryDirectory() as tmp:
        for k, kind in ((30, "planar"), (8, "spatial")):
            d = Path(tmp) / f"{kind}{k}"
            r = _ours_job("gen", str(k), kind, str(d))
            print(f"    {kind + ' N=' + str(k):14s} {r['derive']:7.2f} {r['numpy']:7.2f} "
                  f"{r['c_text']:7.2f} {r['compile']:8.2f} {r['compile_jac']:9.2f} "
                  f"{r['c_size'] / 1e6:7.1f}MB   [{r['compile_cpu']:.1f}, "
                  f"{r['compile_jac_cpu']:.1f}]")

    if peer:
        print("\n(d) Hex20 flexible pendulum, 10 modes, 1 s (generalized-α, h = 1e-3)")
        e = _run([args.peer_python, str(HERE / "_peer_exudyn.py"), "16", "10"])
        print(f"    Exudyn ObjectFFRFreducedOrder: {e['solve']:.3f} s ({e['dofs']} FE dofs, "
              f"modes {e['modes_time']:.2f} s; tip at 1 s: "
              f"{', '.join(f'{v:.5f}' for v in e['tip'])})")
        print(f"    Exudyn SolveDynamic: {e['solve']:.3f} s wall, {e['solve_cpu']:.3f} s CPU")
        for backend, label in (("numpy", "NumPy module"), ("c", "compiled module")):
            o = _run([sys.executable, str(HERE / "_ours_hex_pendulum.py"), "16", "10",
                      "generalized-alpha", "1e-3", "0.9", backend])
            print(f"    ours, generalized-alpha h = 1e-3, rho_inf = 0.9 ({label}, "
                  f"{o['backend']}): {o['simulate']:.3f} s wall, {o['simulate_cpu']:.3f} s CPU, "
                  f"{o['rhs_calls']} rhs calls; tip at 1 s: "
                  f"{', '.join(f'{v:.5f}' for v in o['tip'])}")
            print(f"    ours / Exudyn: {o['simulate'] / e['solve']:.2f} (wall), "
                  f"{o['simulate_cpu'] / e['solve_cpu']:.2f} (CPU); tip z differs by "
                  f"{abs(o['tip'][1] - e['tip'][2]):.1e} m, x by "
                  f"{abs(o['tip'][0] - e['tip'][0]):.1e} m")


if __name__ == "__main__":
    main()
