"""Symbolic Jacobians through intermediates (equations/jacobians.py; equations.md §1), determinism
and caching of the derivation.

References: the forward-mode Jacobians of the recursive form are compared with sympy's own
``Matrix.jacobian`` of the closed form (fully substituted) at random states; determinism is
checked by deriving in subprocesses with different ``PYTHONHASHSEED``.
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from kane_systems import spatial_chain
from test_forces_outputs import _pendulum_forces

from neweul_py.equations import (
    Equations,
    force_jacobians,
    mass_matrix_times_derivative,
    newton_euler,
    output_jacobians,
)
from neweul_py.model import time

pendulum_forces = functools.cache(functools.partial(_pendulum_forces, kane=False))


def _numeric(eq: Equations, extra_inter, exprs, extra_args=()):
    args = [list(eq.coordinates), list(eq.velocities), list(eq.parameters), time,
            list(eq.inputs), *extra_args]
    inter = list(eq.intermediates) + list(extra_inter)
    fn = sp.lambdify(args, exprs, cse=lambda e: (inter, e))
    return lambda *x: [np.asarray(m, float) for m in fn(*x)]


def _closed_reference(eq: Equations, a):
    closed = eq.substituted()
    y = sp.Matrix(closed.coordinates)
    yd = sp.Matrix(closed.velocities)
    u = sp.Matrix(closed.inputs)
    f = closed.force_vector
    out = closed.outputs
    mats = [f.jacobian(y), f.jacobian(yd), f.jacobian(u) if u else sp.zeros(len(f), 0),
            (closed.mass_matrix * sp.Matrix(a)).jacobian(y),
            out.jacobian(sp.Matrix([*y, *yd])) if out else sp.zeros(0, 2 * len(y)),
            out.jacobian(u) if (out and u) else sp.zeros(len(out), len(u))]
    return closed, mats


@pytest.mark.parametrize("case", ["pendulum_forces",
                                  # 8 s of CPU; the generated spatial chain's Jacobians are
                                  # compared with lambdify of its equations by default
                                  pytest.param("spatial_chain2", marks=pytest.mark.slow)])
def test_symbolic_jacobians_match_sympy_jacobian_of_closed_form(case: str) -> None:
    """force_jacobians, mass_matrix_times_derivative, output_jacobians of both forms equal
    sympy's Matrix.jacobian of the fully substituted equations."""
    if case == "pendulum_forces":
        system = pendulum_forces()[0]
    else:
        system = spatial_chain(2, kane=False).system
    closed_eq = newton_euler(system, form="closed")
    a = sp.symbols(f"acc0:{closed_eq.n}", real=True)  # not a0…: those are coordinates
    closed, mats = _closed_reference(closed_eq, a)
    ref = _numeric(closed, (), mats, [list(a)])
    for form in ("closed", "recursive"):
        eq = newton_euler(system, form=form)
        fj = force_jacobians(eq)
        mj = mass_matrix_times_derivative(eq, a)
        oj = output_jacobians(eq)
        if form == "recursive":
            assert fj.intermediates  # derivatives went through intermediates, not substitution
        ours = [
            _numeric(eq, fj.intermediates, list(fj.matrices)),
            _numeric(eq, mj.intermediates, list(mj.matrices), [list(a)]),
            _numeric(eq, oj.intermediates, list(oj.matrices)),
        ]
        rng = np.random.default_rng(2)
        for _ in range(20):
            y, yd = rng.uniform(-np.pi, np.pi, eq.n), rng.uniform(-2, 2, eq.n)
            p = np.array([x.default for x in system.parameters]) * rng.uniform(
                0.8, 1.2, len(eq.parameters))
            t, u = rng.uniform(0, 3), rng.uniform(-1, 1, len(eq.inputs))
            av = rng.normal(size=eq.n)
            base = (list(y), list(yd), list(p), t, list(u))
            got = ours[0](*base) + ours[1](*base, list(av)) + ours[2](*base)
            want = ref(*base, list(av))
            for g, w in zip(got, want, strict=True):
                g = np.asarray(g, float).reshape(np.shape(w))
                tol = 1e-10 * max(1.0, np.abs(w).max(initial=0.0))
                np.testing.assert_allclose(g, w, rtol=1e-10, atol=tol, err_msg=form)


def test_cache_returns_the_same_object_for_equal_systems() -> None:
    s1 = spatial_chain(2, kane=False).system
    s2 = spatial_chain(2, kane=False).system
    assert s1 is not s2 and s1.fingerprint() == s2.fingerprint()
    assert newton_euler(s1, "recursive") is newton_euler(s2, "recursive")
    assert newton_euler(s1, "auto") is newton_euler(s1, "closed")  # n = 4 ≤ 6


_SCRIPT = textwrap.dedent(
    """
    import hashlib, sys
    import sympy as sp
    sys.path.insert(0, {tests!r})
    from kane_systems import spatial_chain
    from test_forces_outputs import _pendulum_forces
    from neweul_py.equations import newton_euler, force_jacobians
    h = hashlib.sha256()
    cases = [(spatial_chain(2, kane=False).system, "recursive")]
    cases += [(_pendulum_forces(kane=False)[0], form) for form in ("closed", "recursive")]
    for system, form in cases:
        eq = newton_euler(system, form=form)
        fj = force_jacobians(eq)
        for part in (eq.intermediates, eq.mass_matrix, eq.force_vector, eq.outputs,
                     fj.intermediates, fj.matrices):
            h.update(sp.srepr(part).encode())
    print(h.hexdigest())
    """
)


def test_derivation_is_independent_of_hash_randomization() -> None:
    """Same system → identical expressions (srepr), whatever PYTHONHASHSEED (two subprocesses
    with fixed seeds and this process with its own)."""
    tests = str(Path(__file__).parent)
    digests = set()
    script = _SCRIPT.format(tests=tests)
    namespace: dict = {}
    from contextlib import redirect_stdout
    from io import StringIO

    buf = StringIO()
    with redirect_stdout(buf):
        exec(compile(script, "<determinism>", "exec"), namespace)
    digests.add(buf.getvalue().strip())
    for seed in ("1", "4242"):
        env = {**os.environ, "PYTHONHASHSEED": seed}
        out = subprocess.run(
            [sys.executable, "-c", script], env=env, check=True,
            capture_output=True, text=True,
        )
        digests.add(out.stdout.strip())
    assert len(digests) == 1, digests
