#!/usr/bin/env python3
"""Energy of the free flexible pendulum vs mode count and stiffening form.

Model: the public planar Euler–Bernoulli beam (``neweul_py.fem.beam_model``, 20 elements,
L = 1, EI = 3 N m², ρA = 1) hinged at its root (coordinate ``a`` about z), gravity along −y,
released horizontally, undamped; in-plane clamped bending modes; stiffening of the 12 inertia
load cases either not at all, as the first-order terms (``Oe¹``, ``Ct¹``, ``−K_G`` in ``C2``)
or as the second-order displacement field (``docs/equations.md`` §2.3). Printed per case: the
largest change of the module's total ``energy()`` over 2 s (DOP853, rtol 1e-10) relative to
m g L/2, or where the run failed, and the hinge angle and tip deflection at t = 1 s. The
reference is conservation of energy itself (acceptance: < 1e-7 for every mode count).

Usage::

    python benchmarks/bench_pendulum_energy.py            # 2 4 10 20 modes
    python benchmarks/bench_pendulum_energy.py 10         # other mode counts
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.linalg as sla

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from neweul_py.analysis import load_generated, simulate  # noqa: E402
from neweul_py.api import generate  # noqa: E402
from neweul_py.elastic.reductors.invariants import compute_invariants  # noqa: E402
from neweul_py.elastic.reductors.second_order import with_second_order  # noqa: E402
from neweul_py.errors import NeweulError  # noqa: E402
from neweul_py.fem.beam import BeamSection, beam_model  # noqa: E402

YAML = """
name: {name}
parameters: {{g: 9.81}}
gravity: [0, -g, 0]
coordinates: {{a: {{}}}}
frames:
  arm: {{rotation: [[z, a]]}}
elastic_bodies:
  beam: {{frame: arm, data: {name}.npz, nodes: {{tip: 21}}}}
outputs:
  tip_y: {{position: beam.tip, in: arm, component: y}}
"""


def body(modes: int, form: str):
    """Invariants of the clamped in-plane bending modes with the stiffening ``form``."""
    b = beam_model(1.0, 20, BeamSection(E=3.0, G=1.0, A=1.0, Iy=1.0, Iz=1.0), planar=True)
    free = np.setdiff1d(np.arange(b.fe.n_dofs), b.node_dofs(0))
    _lam, X = sla.eigh(b.fe.K.toarray()[np.ix_(free, free)],
                       b.fe.M.toarray()[np.ix_(free, free)])
    V = np.zeros((b.fe.n_dofs, free.size))
    V[free] = X
    bend = [k for k in range(free.size)
            if np.abs(V[1::3, k]).max() > 1e3 * np.abs(V[0::3, k]).max()]
    V = V[:, bend[:modes]]
    if form == "none":
        return compute_invariants(b.fe, V, nodes=[21])
    KG = b.stiffening()
    inv = compute_invariants(b.fe, V, nodes=[21], geometric_stiffness=KG)
    return inv if form == "first" else with_second_order(inv, b.fe, V, KG, b.stiffening_responses())


def run(modes: int, form: str, tmp: Path) -> str:
    name = f"pend_{form}_{modes}"
    inv = body(modes, form)
    np.savez(tmp / f"{name}.npz", **inv.to_flat())
    (tmp / f"{name}.yaml").write_text(YAML.format(name=name))
    mod = load_generated(generate(tmp / f"{name}.yaml", tmp))
    t0 = time.perf_counter()
    try:
        res = simulate(mod, 2.0, method="DOP853", rtol=1e-10, atol=1e-13, n_out=201)
    except NeweulError as exc:
        return f"failed after {time.perf_counter() - t0:.1f} s: {str(exc)[:60]}"
    p = mod.default_parameters()
    x = np.hstack((res.y, res.yd))
    e = np.array([mod.energy(t, xi, p).sum() for t, xi in zip(res.t, x, strict=True)])
    drift = np.abs(e - e[0]).max() / (inv.m * 9.81 * 0.5)
    i = int(np.argmin(np.abs(res.t - 1.0)))
    return (f"drift {drift:9.2e}   a(1 s) {res.y[i, 0]:+.6f}   tip_y(1 s) "
            f"{res.outputs[i, 0]:+.3e}   {time.perf_counter() - t0:6.1f} s")


def main(argv: list[str]) -> int:
    counts = [int(a) for a in argv] or [2, 4, 10, 20]
    with tempfile.TemporaryDirectory() as d:
        for modes in counts:
            for form in ("none", "first", "field"):
                print(f"{modes:3d} modes  {form:6s} {run(modes, form, Path(d))}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
