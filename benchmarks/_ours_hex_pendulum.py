#!/usr/bin/env python3
"""Our side of bench_compiled.py (d): the Hex20 flexible pendulum of ``_peer_exudyn.py``.

The same block (L = 1 m, a = 0.05 m, aluminium, ``nx × 2 × 2`` Hex20 elements of
``neweul_py.fem.solid_box``), reduced to ``modes`` fixed-interface modes with the hinge face
clamped to the floating frame (``reduce_craig_bampton(..., constraint_modes=False)``: the
interface mass stays in the invariants), consistent second-order inertia, on a revolute joint
about y at x = 0, gravity −z, released horizontally from rest, 1 s. Integrated with
``method`` (default Radau with the analytic Jacobian; the stiff elastic modes rule out explicit
steps; ``generalized-alpha`` with the step ``h`` and ``rho_inf`` as Exudyn: h = 1e-3,
ρ∞ = 0.9). Prints JSON on the last line: generation and simulation wall times, rhs calls, the
tip displacement at t = 1 s.

Usage: ``python benchmarks/_ours_hex_pendulum.py [NX] [MODES] [METHOD] [H] [RHO_INF]``.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def run(nx: int, modes: int, method: str = "Radau", rtol: float = 1e-6, h: float = 1e-3,
        rho_inf: float = 0.9, backend: str = "numpy") -> dict:
    from neweul_py.analysis import load_generated, simulate
    from neweul_py.api import generate
    from neweul_py.elastic.io.body_files import save_reduced_body
    from neweul_py.elastic.reductors.craig_bampton import reduce_craig_bampton
    from neweul_py.elastic.reductors.invariants import attach_invariants
    from neweul_py.fem.solid import SolidMaterial, solid_box

    t0 = time.perf_counter()
    a = 0.05
    s = solid_box(lengths=(1.0, a, a), divisions=(nx, 2, 2),
                  material=SolidMaterial(E=70e9, nu=0.3, rho=2700.0), element="hex20",
                  origin=(0.0, -a / 2, -a / 2))
    fe = s.fe
    xyz = np.asarray(fe.nodes)[:, 1:4]
    ids = np.asarray(fe.nodes)[:, 0].astype(int)
    hinge = ids[np.isclose(xyz[:, 0], 0.0)]
    tip = int(ids[np.argmin(np.linalg.norm(xyz - [1.0, 0, 0], axis=1))])
    body = reduce_craig_bampton(fe, hinge, modes, two_sided=False, constraint_modes=False,
                                keep_nodes=[tip], store_bases=True)
    body = attach_invariants(body, fe, nodes=[tip])
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        save_reduced_body(body, d / "block.npz")
        (d / "pendulum.yaml").write_text(f"""
name: hex_pendulum
parameters: {{g: 9.81}}
gravity: [0, 0, -g]
coordinates: {{phi: {{}}}}
frames:
  arm: {{rotation: [[y, phi]]}}
elastic_bodies:
  block: {{frame: arm, data: block.npz, nodes: {{tip: {tip}}}}}
outputs:
  tip_x: {{position: block.tip, component: x}}
  tip_z: {{position: block.tip, component: z}}
""")
        mod = load_generated(generate(d / "pendulum.yaml", d / "gen", backend=backend))
        t1, c1 = time.perf_counter(), time.process_time()
        extra = {"h": h, "rho_inf": rho_inf} if method == "generalized-alpha" else {}
        res = simulate(mod, 1.0, method=method, rtol=rtol, atol=1e-9, n_out=11, **extra)
        t2, c2 = time.perf_counter(), time.process_time()
    return {"dofs": int(fe.M.shape[0]), "modes": modes, "generate": t1 - t0,
            "backend": getattr(mod, "BACKEND", "numpy"),
            "simulate": t2 - t1, "simulate_cpu": c2 - c1,
            "rhs_calls": int(getattr(res, "nfev", -1)),
            "tip": [float(res.outputs[-1, 0]), float(res.outputs[-1, 1])]}


if __name__ == "__main__":
    args = sys.argv[1:]
    print(json.dumps(run(int(args[0]) if args else 16, int(args[1]) if len(args) > 1 else 10,
                         args[2] if len(args) > 2 else "Radau",
                         h=float(args[3]) if len(args) > 3 else 1e-3,
                         rho_inf=float(args[4]) if len(args) > 4 else 0.9,
                         backend=args[5] if len(args) > 5 else "numpy")))
