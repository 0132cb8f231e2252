"""Modules generated from the real pipeline (description → newton_euler → codegen) against
direct ``lambdify`` of the same ``Equations`` (intermediates substituted) at random states,
in closed and recursive form; and byte-identical generation under different hash seeds."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from neweul_py.analysis.module import load_generated
from neweul_py.codegen import generate_module
from neweul_py.description import load_description
from neweul_py.equations import newton_euler
from neweul_py.model import time

ROOT = Path(__file__).resolve().parents[2]
CASES = [
    ("double_pendulum", "closed"),
    ("double_pendulum", "recursive"),
    ("cart_pendulum", "recursive"),
    ("heavy_top", "closed"),
    # 3.4 s of CPU; the recursive form is checked by default on the planar examples, and the
    # spatial chain's recursive equations against Kane's (tests/equations)
    pytest.param("chain3_spatial", "recursive", marks=pytest.mark.slow),
]


@pytest.mark.parametrize(("name", "form"), CASES)
def test_module_matches_lambdify_of_equations(name, form, tmp_path):
    eq = newton_euler(load_description(ROOT / "examples" / f"{name}.yaml"), form=form)
    mod = load_generated(generate_module(eq, "h", tmp_path / f"{name}.py"))
    full = eq.substituted()
    y, yd, p, u = eq.coordinates, eq.velocities, eq.parameters, eq.inputs
    n = len(y)
    args = (time, *y, *yd, *p, *u)
    f_m = sp.lambdify(args, full.mass_matrix)
    f_f = sp.lambdify(args, full.force_vector)
    f_o = sp.lambdify(args, full.outputs)
    rng = np.random.default_rng(7)
    p0 = mod.default_parameters()
    for _ in range(20):
        t = rng.uniform(0, 2)
        x = rng.uniform(-1.2, 1.2, 2 * n)
        uv = rng.uniform(-1, 1, len(u))
        vals = (t, *x, *p0, *uv)
        m_ref = np.array(f_m(*vals), dtype=float)
        f_ref = np.array(f_f(*vals), dtype=float).ravel()
        scale = np.max(np.abs(m_ref))
        np.testing.assert_allclose(mod.mass_matrix(t, x[:n], p0, uv), m_ref, rtol=1e-10,
                                   atol=1e-12 * scale)
        np.testing.assert_allclose(mod.force_vector(t, x[:n], x[n:], p0, uv), f_ref,
                                   rtol=1e-10, atol=1e-10 * max(1.0, np.max(np.abs(f_ref))))
        np.testing.assert_allclose(mod.outputs(t, x, p0, uv),
                                   np.array(f_o(*vals), dtype=float).ravel(),
                                   rtol=1e-10, atol=1e-12)
        # analytic rhs Jacobian against central differences
        jac = mod.rhs_jacobian(t, x, p0, uv)
        h = 1e-6
        fd = np.column_stack([(mod.rhs(t, x + h * e, p0, uv) - mod.rhs(t, x - h * e, p0, uv))
                              / (2 * h) for e in np.eye(2 * n)])
        np.testing.assert_allclose(jac, fd, rtol=1e-5, atol=1e-5 * max(1.0, np.max(np.abs(fd))))


def test_real_pipeline_is_byte_identical_across_hash_seeds(tmp_path):
    code = textwrap.dedent(f"""
        import hashlib, sys
        sys.path.insert(0, {str(ROOT / "examples")!r})
        from make_chain import chain_description
        from neweul_py.codegen import render_module
        from neweul_py.description import load_description, load_description_text
        from neweul_py.equations import newton_euler
        texts = [render_module(newton_euler(load_description({str(ROOT)!r} +
                 "/examples/heavy_top.yaml")), "h"),
                 render_module(newton_euler(load_description_text(chain_description(4, True)),
                                            form="recursive"), "h")]
        print(hashlib.sha256("".join(texts).encode()).hexdigest())
    """)
    digests = set()
    for seed in ("0", "123"):
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             check=True, env={**os.environ, "PYTHONHASHSEED": seed})
        digests.add(out.stdout.strip())
    assert len(digests) == 1
