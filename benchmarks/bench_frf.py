"""1000-point frequency response of a 20-DOF linearized chain: ours vs a loop of solves.

The chain (``_spring_chain.py``, cubic springs preloaded by gravity) is linearized about its static
equilibrium (``equilibrium`` + ``linearize``), then ``H(jω)`` of the last mass's displacement and
velocity to the force on it is evaluated at 1000 log-spaced frequencies by

- ``frequency_response(method="solve" | "hessenberg" | "eig")`` (vectorized over frequencies), and
- the peer: a Python loop of ``numpy.linalg.solve`` calls on the same second-order formula
  ``C (−ω² M0 + jω P + Q)⁻¹ B`` (and, for reference, on the first-order ``(jω I − A)⁻¹ B``).

Run: ``python benchmarks/bench_frf.py [N_DOF] [N_FREQ]``. Prints best-of-repeats times and ratios
measured in this run, and the largest relative deviation between the methods.
"""

from __future__ import annotations

import sys
import timeit
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _spring_chain import make_chain

from neweul_py.analysis.equilibrium import equilibrium
from neweul_py.analysis.frf import frequency_response
from neweul_py.analysis.linearize import linearize


def loop_second_order(lin, f):
    b = lin.B
    m = lin.n
    cy, cyd = lin.C[:, :m], lin.C[:, m:]
    out = np.empty((f.size, lin.C.shape[0], b.shape[1]), dtype=complex)
    for k, fk in enumerate(f):
        w = 2 * np.pi * fk
        x = np.linalg.solve(-(w**2) * lin.M0 + 1j * w * lin.P + lin.Q, b)
        out[k] = (cy + 1j * w * cyd) @ x + lin.D
    return out


def loop_first_order(lin, f):
    a, b, c, d = lin.to_first_order()
    eye = np.eye(a.shape[0])
    out = np.empty((f.size, c.shape[0], b.shape[1]), dtype=complex)
    for k, fk in enumerate(f):
        out[k] = c @ np.linalg.solve(2j * np.pi * fk * eye - a, b) + d
    return out


def best(fn, repeat=7):
    number = 1
    return min(timeit.repeat(fn, number=number, repeat=repeat)) / number


def main() -> None:
    n_dof = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    n_freq = int(sys.argv[2]) if len(sys.argv) > 2 else 1000
    chain = make_chain(n_dof)
    eq = equilibrium(chain)
    lin = linearize(chain, eq)
    f = np.logspace(-1, 3, n_freq)
    ref = loop_second_order(lin, f)
    print(f"FRF of a {n_dof}-DOF linearized chain, {n_freq} frequencies, outputs "
          f"{', '.join(lin.outputs)} / input {', '.join(lin.inputs)}")
    t_loop = best(lambda: loop_second_order(lin, f))
    t_loop1 = best(lambda: loop_first_order(lin, f))
    print(f"  peer: loop of numpy.linalg.solve, second order  {t_loop * 1e3:9.2f} ms")
    print(f"  peer: loop of numpy.linalg.solve, first order   {t_loop1 * 1e3:9.2f} ms")
    for method in ("solve", "hessenberg", "eig"):
        h = frequency_response(lin, f, method=method).H
        dev = np.abs(h - ref).max() / np.abs(ref).max()
        t = best(lambda method=method: frequency_response(lin, f, method=method))
        print(f"  ours: frequency_response(method={method!r:12}) {t * 1e3:9.2f} ms   "
              f"{t_loop / t:6.1f}x faster than the second-order loop   "
              f"max |ΔH|/max|H| = {dev:.1e}")


if __name__ == "__main__":
    main()
