#!/usr/bin/env python3
"""Per-call cost of a parametric elastic body on a fixed frame.

Model: the middle-ear EMBS of ``neweul middle-ear build --dir DATA`` (the parametric TM + air
u–p body on ISYS, its samples in ``dp``; the ossicles; one TM–manubrium bushing per manubrium
node).

Ours: the generated module's ``rhs`` and ``rhs_jacobian`` at a ``dp`` between two samples.
Peer, in the same run: the same **linear** system ``M(σ) ÿ + D(σ) ẏ + K(σ) y = B u`` assembled
by hand with NumPy — ``M_i``, ``D_i``, ``K_i`` of the whole system (``mass_matrix``,
``−force_jacobians`` of the module at ``y = 0`` at each sample ``σ_i``), mixed per call with
the same cubic weights as one product ``w @ [M | D | K]``, then ``ÿ = M⁻¹ (B u − D ẏ − K y)``
and ``J = [[0, I], [−M⁻¹ K, −M⁻¹ D]]`` — the least work any implementation of this system
must do per call. Printed: median time per call and the ratio ours / peer, and the relative
difference of the two ``rhs`` at a tiny state (the module is nonlinear in the ossicles'
rotations only at second order). Nothing is asserted.

Usage (BLAS single-threaded, as on the shared machine)::

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_parametric.py --dir DATA [--module PATH]

``--module``: time another generated module of the description (e.g. one made with an older
kernel, for before/after); otherwise the build's own module.
"""

from __future__ import annotations

import argparse
import json
import os
import timeit
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from neweul_py.analysis import load_generated  # noqa: E402
from neweul_py.ffrf.parametric import weight_coefficients  # noqa: E402


def _module(data: Path, module: Path | None):
    record = json.loads((data / "build.json").read_text())
    return load_generated(module if module is not None else data / record["module"])


def _params(mod, dp: float) -> np.ndarray:
    p = np.array(mod.default_parameters(), dtype=float)
    names = list(mod.PARAMETERS)
    p[names.index("dp")] = dp
    if "dp_ramp" in names:
        p[names.index("dp_ramp")] = 0.0
    return p


class Peer:
    """The hand-assembled linear LPV system of the module (module docstring)."""

    def __init__(self, mod, samples: np.ndarray) -> None:
        n = mod.STATE_SIZE // 2
        z = np.zeros(n)
        blocks = []
        for s in samples:
            p = _params(mod, s)
            u = mod.default_inputs(0.0, p)
            fy, fyd, fu = mod.force_jacobians(0.0, z, z, p, u)
            blocks.append(np.concatenate([np.asarray(mod.mass_matrix(0.0, z, p, u)).ravel(),
                                          -np.asarray(fyd).ravel(), -np.asarray(fy).ravel()]))
        self.B = np.asarray(fu)
        self.stack = np.ascontiguousarray(np.array(blocks))
        self.samples = samples
        self.coeff = weight_coefficients(samples, "cubic")
        self.n = n

    def weights(self, sigma: float) -> np.ndarray:
        j = min(int(np.searchsorted(self.samples, sigma, side="right")) - 1,
                self.samples.size - 2)
        c, dx = self.coeff[:, j, :], sigma - self.samples[j]
        return ((c[0] * dx + c[1]) * dx + c[2]) * dx + c[3]

    def matrices(self, sigma: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = self.n
        mixed = self.weights(sigma) @ self.stack
        return (mixed[:n * n].reshape(n, n), mixed[n * n:2 * n * n].reshape(n, n),
                mixed[2 * n * n:].reshape(n, n))

    def rhs(self, sigma: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        n = self.n
        M, D, K = self.matrices(sigma)
        return np.concatenate((x[n:], np.linalg.solve(M, self.B @ u - D @ x[n:] - K @ x[:n])))

    def rhs_jacobian(self, sigma: float) -> np.ndarray:
        n = self.n
        M, D, K = self.matrices(sigma)
        J = np.zeros((2 * n, 2 * n))
        J[:n, n:] = np.eye(n)
        J[n:] = -np.linalg.solve(M, np.hstack((K, D)))
        return J


def _per_call(fn, repeat: int = 5) -> float:
    fn()
    number = max(1, int(0.3 / max(timeit.timeit(fn, number=1), 1e-6)))
    return min(timeit.repeat(fn, number=number, repeat=repeat)) / number


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", type=Path, required=True, help="a build of neweul middle-ear build")
    ap.add_argument("--module", type=Path, default=None, help="an already generated module")
    ap.add_argument("--dp", type=float, default=500.0, help="dp between samples [Pa]")
    args = ap.parse_args()
    mod = _module(args.dir, args.module)
    samples = np.array(json.loads((args.dir / "build.json").read_text())["samples_Pa"],
                       dtype=float)
    peer = Peer(mod, samples)
    n = peer.n
    p = _params(mod, args.dp)
    u = np.asarray(mod.default_inputs(0.0, p), dtype=float)
    rng = np.random.default_rng(1)
    x = 1e-12 * rng.standard_normal(2 * n)
    ours = np.asarray(mod.rhs(0.0, x, p, u))
    theirs = peer.rhs(args.dp, x, u)
    diff = np.abs(ours - theirs).max() / np.abs(theirs).max()
    print(f"middle-ear EMBS: {n} coordinates ({mod.STATE_SIZE} states), "
          f"{samples.size} samples, dp = {args.dp:g} Pa; rhs ours vs peer: rel. diff {diff:.1e}")
    # a new σ at every call (as along a ramp): alternate between two close dp
    other = _params(mod, args.dp * (1 + 1e-9) + 1e-9)
    turn = [p, other]

    def alternate(fn):
        turn.reverse()
        return fn(0.0, x, turn[0], u)

    rows = [("rhs", _per_call(lambda: alternate(mod.rhs)),
             _per_call(lambda: peer.rhs(args.dp, x, u))),
            ("rhs, same σ", _per_call(lambda: mod.rhs(0.0, x, p, u)),
             _per_call(lambda: peer.rhs(args.dp, x, u))),
            ("rhs_jacobian", _per_call(lambda: alternate(mod.rhs_jacobian), 3),
             _per_call(lambda: peer.rhs_jacobian(args.dp), 3))]
    print(f"{'function':<14} {'ours [ms]':>10} {'peer [ms]':>10} {'ours/peer':>10}")
    for name, a, b in rows:
        print(f"{name:<14} {1e3 * a:>10.2f} {1e3 * b:>10.2f} {a / b:>10.2f}")
    print("(rhs: a new σ at every call; 'same σ': repeated calls at one σ, as in the Newton "
          "iterations of an implicit step, where the module mixes the samples once)")


if __name__ == "__main__":
    main()
