#!/usr/bin/env python3
"""A large parametric elastic body: data by reference and the compiled backend against NumPy.

Model: a fixed–free chain of equal masses and springs (``tests/support/fe_builders.
spring_chain``, ``modes + 100`` DOFs) whose stiffness and mass both change with a parameter
``s`` (``k = 10⁴ (1 + s)``, ``m = 0.1 (1 + 0.2 s)`` — so every reduced matrix, the mass
included, varies, as the middle-ear body's u–p coupling does with the static pressure), at
``--samples`` values of ``s`` in [0, 1], projected on one basis of ``--modes`` directions
(the modes at ``s = 0``) with the slopes and curvatures from the FE models at ``s ± 0.01``
(quintic Hermite weights, ``basis_parametric_body``); on ISYS, a rigid mass on a
spring–damper at the free end, where a tone acts (the coupling of the middle ear's ossicles
through node frames). The schedule is ``s0 + ds sin²(π t / t_ramp)``.

Measured in one run (BLAS single-threaded):

1. **Data by reference** — the sizes of the data file and of the module, and ``import +
   first rhs`` of the NumPy module and of the compiled module (library built before), each in
   a fresh Python process (median of 3), with Python's bytecode cache and compiling the
   module's source (the module cache imports verified bytes, which are always compiled).
2. **Per call**, NumPy module and compiled module: ``rhs`` at a constant schedule (the
   Newton iterations of an implicit step), ``rhs`` with the schedule moving at every call,
   ``rhs_jacobian``, and the Newton matrix of generalized-α (``force_jacobians``,
   ``mass_matrix_times_derivative``, ``mass_matrix``); the ratio NumPy / C.
3. **Time integration**: the tone under the ramp ``ds`` over ``t_ramp``, generalized-α
   (ρ∞ = 0.5) with ``--steps-per-period`` steps, from rest; wall time, rhs calls, the
   ratio, and the largest difference of the mass's displacement relative to its amplitude.

Nothing is asserted. Usage::

    python benchmarks/bench_parametric_compiled.py [--modes 300] [--samples 9]
        [--dir DIR] [--periods 40]

``--dir`` keeps the body and the generated modules (the body is built once, reused).
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
import timeit
from pathlib import Path
from typing import Any

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "support"))

DESCRIPTION = """
name: chain
parameters: {{s0: 0.2, ds: 0.0, t_ramp: 0.5, m2: 0.5, k2: 2.0e3, d2: 1.0, F0: 1.0,
             f_tone: 20.0}}
coordinates: {{z: {{}}}}
frames:
  carrier: {{translation: [z, 0, 0]}}
elastic_bodies:
  chain: {{frame: ISYS, data: body.npz, nodes: {{tip: {node}}}, inertia: sid,
          schedule: s0 + ds*sin(pi*t/t_ramp)**2}}
bodies:
  mass: {{frame: carrier, mass: m2}}
forces:
  link:
    type: bushing
    between: [chain.tip, carrier]
    stiffness: {{diag: [k2, 0, 0]}}
    damping: {{diag: [d2, 0, 0]}}
  tone: {{type: force, frame: chain.tip, vector: [F0*sin(2*pi*f_tone*t), 0, 0], in: ISYS}}
outputs:
  x_mass: {{position: carrier, in: ISYS, component: x}}
"""


def build_body(directory: Path, modes: int, samples: int) -> int:
    """The parametric body file ``directory/body.npz`` (module docstring); returns the node id
    of the free end."""
    from fe_builders import spring_chain

    from neweul_py.elastic import reduce_modal
    from neweul_py.elastic.io.body_files import save_parametric_body
    from neweul_py.elastic.parametric.snapshot_basis import basis_parametric_body

    n = modes + 100

    def fe(s: float):
        return spring_chain(n, k=1.0e4 * (1 + s), m=0.1 * (1 + 0.2 * s), damping=1e-4)

    values, step = np.linspace(0.0, 1.0, samples), 0.01
    fes = [fe(s) for s in values]
    V = reduce_modal(fes[0], modes=modes, store_bases=True).V
    body = basis_parametric_body(fes, V, values, parameter="s", keep_nodes=[n],
                                 interpolation="quintic-hermite",
                                 slope_models=([fe(s - step) for s in values],
                                               [fe(s + step) for s in values]),
                                 slope_step=step)
    save_parametric_body(body, directory / "body.npz")
    return n


def _generate(directory: Path) -> tuple[Path, Path, float, float]:
    """The NumPy module and the compiled one (library built), with their generation times."""
    from neweul_py.api import load_description
    from neweul_py.codegen import generate_module
    from neweul_py.codegen.c_module import write_c_module
    from neweul_py.description import description_hash
    from neweul_py.equations import newton_euler

    desc = directory / "chain.yaml"
    t0 = time.perf_counter()
    eq = newton_euler(load_description(desc))
    npath = generate_module(eq, description_hash(desc.read_bytes()),
                            directory / "gen" / "chain.py")
    t1 = time.perf_counter()
    wrapper = write_c_module(eq, npath)
    t2 = time.perf_counter()
    subprocess.run([sys.executable, "-c", f"import runpy; runpy.run_path({str(wrapper)!r})"],
                   check=True)                  # builds (and caches) the libraries
    return npath, wrapper, t1 - t0, t2 - t1


#: A fresh process: import the module at ``{path}`` and evaluate one rhs.
_LOAD = """
import importlib.util, numpy as np
spec = importlib.util.spec_from_file_location("m", {path!r})
m = importlib.util.module_from_spec(spec)
spec.loader.exec_module(m)
m.rhs(0.0, np.zeros(m.STATE_SIZE), m.default_parameters())
"""
_IMPORT = ("import time\nt0 = time.perf_counter()\n" + _LOAD
           + "print(time.perf_counter() - t0)\n")
#: Linux's ``VmHWM``: the process's own peak, where ``ru_maxrss`` keeps the parent's across
#: ``fork`` and ``exec``.
_PEAK = (_LOAD + 'print(next(line.split()[1] for line in open("/proc/self/status") '
         'if line.startswith("VmHWM")))\n')


def import_first_rhs(path: Path, bytecode: bool) -> float:
    """Median of three fresh processes: import the module and evaluate one rhs [s];
    ``bytecode``: with Python's bytecode cache (written by a first import), else compiling
    the module's source every time (``PYTHONDONTWRITEBYTECODE``, or a module imported from
    verified bytes, as the module cache does)."""
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    if not bytecode:
        env["PYTHONDONTWRITEBYTECODE"] = "1"
        shutil.rmtree(path.parent / "__pycache__", ignore_errors=True)
    times = []
    for _ in range(4 if bytecode else 3):
        out = subprocess.run([sys.executable, "-c", _IMPORT.format(path=str(path))],
                             capture_output=True, text=True, check=True, env=env)
        times.append(float(out.stdout.split()[-1]))
    return float(np.median(times[1:] if bytecode else times))


def peak_memory(path: Path) -> float:
    """Peak resident memory [MB] of a fresh process that imports the module and evaluates
    one rhs (:data:`_PEAK`)."""
    out = subprocess.run([sys.executable, "-c", _PEAK.format(path=str(path))],
                         capture_output=True, text=True, check=True)
    return float(out.stdout.split()[-1]) / 1024


def _per_call(fn, repeat: int = 5) -> float:
    fn()
    number = max(1, int(0.2 / max(timeit.timeit(fn, number=1), 1e-6)))
    return min(timeit.repeat(fn, number=number, repeat=repeat)) / number


def per_call(mods: dict, n: int) -> list[tuple[str, float, float]]:
    """Seconds per call of the NumPy and the compiled module (module docstring, 2)."""
    rng = np.random.default_rng(1)
    x = 1e-9 * rng.standard_normal(2 * n)
    y, a = x[:n], rng.standard_normal(n)
    rows = []
    for name, fn in (
        ("rhs, constant schedule", lambda m, p, t: m.rhs(0.0, x, p)),
        ("rhs, schedule moving", lambda m, p, t: m.rhs(t, x, p)),
        ("rhs_jacobian", lambda m, p, t: m.rhs_jacobian(t, x, p)),
        ("Newton matrix (fy, fyd, d(Ma)/dy, M)",
         lambda m, p, t: (m.force_jacobians(t, y, x[n:], p),
                          m.mass_matrix_times_derivative(t, y, p, a),
                          m.mass_matrix(t, y, p))),
    ):
        got = []
        for m in (mods["numpy"], mods["c"]):
            p = m.default_parameters()
            p[list(m.PARAMETERS).index("ds")] = 0.6
            clock = [0.0]

            def call(m=m, p=p, fn=fn, clock=clock):
                clock[0] += 1e-6           # a new schedule value at every call
                return fn(m, p, clock[0])

            got.append(_per_call(call, 3 if "Newton" in name or "jac" in name else 5))
        rows.append((name, *got))
    return rows


def integrate(mods: dict, periods: int, steps: int) -> list[tuple[str, float, int, Any]]:
    """Generalized-α over the tone under the ramp (module docstring, 3)."""
    from neweul_py.analysis import simulate

    out = []
    for key in ("numpy", "c"):
        m = mods[key]
        p = m.default_parameters()
        names = list(m.PARAMETERS)
        f = p[names.index("f_tone")]
        t_end = periods / f
        p[names.index("ds")], p[names.index("t_ramp")] = 0.6, t_end
        t0 = time.perf_counter()
        res = simulate(m, t_end, method="generalized-alpha", h=1.0 / (f * steps),
                       rho_inf=0.5, p=p, n_out=periods * 4 + 1, rtol=1e-6, atol=1e-12)
        out.append((key, time.perf_counter() - t0, int(getattr(res, "nfev", 0) or 0),
                    np.asarray(res.outputs)[:, 0]))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--modes", type=int, default=300)
    ap.add_argument("--samples", type=int, default=9)
    ap.add_argument("--periods", type=int, default=40, help="tone periods integrated")
    ap.add_argument("--steps-per-period", type=int, default=40)
    ap.add_argument("--dir", type=Path, default=None, help="keep body and modules here")
    args = ap.parse_args()
    from neweul_py.analysis import load_generated

    with tempfile.TemporaryDirectory() as tmp:
        d = args.dir or Path(tmp)
        d.mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        if not (d / "body.npz").exists():
            node = build_body(d, args.modes, args.samples)
            (d / "chain.yaml").write_text(DESCRIPTION.format(node=node))
        t_body = time.perf_counter() - t0
        npath, wrapper, g_np, g_c = _generate(d)
        data = next(npath.parent.glob("chain.*.npz"))
        mods = {"numpy": load_generated(npath), "c": load_generated(wrapper)}
        n = mods["numpy"].STATE_SIZE // 2
        print(f"parametric spring chain: {args.modes} modes, {args.samples} samples "
              f"(quintic Hermite), {n} coordinates; body built in {t_body:.0f} s")
        print(f"generation: NumPy module {g_np:.1f} s, C sources {g_c:.1f} s; backend "
              f"{mods['c'].BACKEND}")
        print("\n| file | size |\n|---|---|")
        for f in (data, npath, wrapper, wrapper.with_suffix(".c"),
                  wrapper.with_name(wrapper.stem + "_jac.c")):
            print(f"| {f.name} | {f.stat().st_size / 1e6:.3f} MB |")
        print("\n| module | import + first rhs (bytecode cached) | (source compiled) |\n"
              "|---|---|---|")
        for key, path in (("NumPy", npath), ("compiled", wrapper)):
            print(f"| {key} | {import_first_rhs(path, True):.2f} s | "
                  f"{import_first_rhs(path, False):.2f} s |")
        print("\n| per call | NumPy [ms] | C [ms] | NumPy / C |\n|---|---|---|---|")
        for name, a, b in per_call(mods, n):
            print(f"| {name} | {1e3 * a:.3f} | {1e3 * b:.3f} | {a / b:.1f} |")
        runs = integrate(mods, args.periods, args.steps_per_period)
        (_k, tn, fn, zn), (_k2, tc, fc, zc) = runs
        dev = float(np.abs(zc - zn).max() / max(np.abs(zn).max(), 1e-300))
        print(f"\ngeneralized-α, {args.periods} periods × {args.steps_per_period} steps, "
              "schedule ramp s = 0.2 → 0.8:")
        print("| backend | wall | rhs calls |\n|---|---|---|")
        print(f"| NumPy | {tn:.2f} s | {fn} |\n| C | {tc:.2f} s | {fc} |")
        print(f"ratio NumPy / C: {tn / tc:.1f}; largest difference of x_mass: "
              f"{dev:.1e} of its amplitude")


if __name__ == "__main__":
    main()
