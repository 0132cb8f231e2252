"""Implicit integration of a stiff spring chain with and without the analytic Jacobian.

The chain (``_spring_chain.py``) alternates stiff, strongly damped springs (``k_stiff``,
``d_stiff``) and soft, lightly damped ones (``k_soft``) with a cubic term: the fast modes decay
quickly while the slow ones oscillate, so the eigenvalues spread over several decades.
``scipy.integrate.solve_ivp`` (Radau and BDF) integrates it from rest under gravity, once with
``jac=rhs_jacobian`` (the module's analytic Jacobian, as ``neweul_py.analysis.simulate`` passes
it) and once with SciPy's finite-difference Jacobian. Every call of ``rhs`` is counted
(including those made to build a finite-difference Jacobian); the time is the best of three runs.

Run: ``python benchmarks/bench_stiff.py [N_MASSES] [STIFFNESS_RATIO]``.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

sys.path.insert(0, str(Path(__file__).parent))
from _spring_chain import make_chain


def run(chain, method, analytic, t_end=1.0):
    p = chain.default_parameters()
    calls = [0]

    def f(t, x):
        calls[0] += 1
        return chain.rhs(t, x, p)

    kw = {"jac": lambda t, x: chain.rhs_jacobian(t, x, p)} if analytic else {}
    x0 = np.zeros(chain.STATE_SIZE)
    best = np.inf
    for _ in range(3):
        calls[0] = 0
        t0 = time.perf_counter()
        sol = solve_ivp(f, (0.0, t_end), x0, method=method, rtol=1e-6, atol=1e-9, **kw)
        best = min(best, time.perf_counter() - t0)
    assert sol.success, sol.message
    return calls[0], sol.njev, best, sol.y[:, -1]


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 40
    ratio = float(sys.argv[2]) if len(sys.argv) > 2 else 1.0e4
    chain = make_chain(n, k_soft=1.0e2, k_stiff=1.0e2 * ratio, k3=1.0e4, d=0.02,
                       d_stiff=0.2 * np.sqrt(1.0e2 * ratio))
    lam = np.linalg.eigvals(chain.rhs_jacobian(0.0, np.zeros(2 * n), chain.default_parameters()))
    print(f"stiff spring chain: {n} masses, k_stiff/k_soft = {ratio:g}, "
          f"|λ| from {np.abs(lam).min():.3g} to {np.abs(lam).max():.3g} 1/s, t = 0 … 1 s, "
          f"rtol 1e-6, atol 1e-9")
    for method in ("Radau", "BDF"):
        ca, ja, ta, xa = run(chain, method, True)
        cf, jf, tf, xf = run(chain, method, False)
        dev = np.abs(xa - xf).max() / np.abs(xa).max()
        print(f"  {method:5}  analytic Jacobian: {ca:6d} rhs calls, {ja:4d} Jacobians, "
              f"{ta * 1e3:8.1f} ms")
        print(f"  {method:5}  finite differences: {cf:6d} rhs calls, {jf:4d} Jacobians, "
              f"{tf * 1e3:8.1f} ms   -> {cf / ca:5.1f}x the rhs calls, {tf / ta:5.1f}x the time"
              f"  (final states agree to {dev:.1e})")


if __name__ == "__main__":
    main()
