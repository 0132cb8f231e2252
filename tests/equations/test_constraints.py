"""Holonomic constraints (equations.md §1): ``g``, ``G``, ``∂g/∂t``, ``γ``.

References: the slider–crank constraints, ``G`` and ``γ`` derived by hand (below, and the same as
``tests/analysis/fixtures/slider_crank.py``); finite differences of ``g`` (for ``G``) and of
``G(y) ẏ`` along ``ẏ`` (for ``γ`` at ``ÿ = 0``); a rheonomic constraint driven by an input.
"""

from __future__ import annotations

import pathlib

import numpy as np
import pytest
import sympy as sp

from neweul_py.description import load_description, load_description_text
from neweul_py.equations.constraints import dependent_rows, derive_constraints
from neweul_py.errors import ModelError
from neweul_py.model import time

ROOT = pathlib.Path(__file__).resolve().parents[2]
RNG = np.random.default_rng(7)


def _functions(system):
    ce = derive_constraints(system)
    args = (system.coordinate_symbols, system.velocity_symbols, system.parameter_symbols,
            system.input_symbols, time)
    lam = {k: sp.lambdify(args, list(getattr(ce, k)), "numpy") for k in ("g", "G", "g_t",
                                                                           "gamma")}
    nc, n = ce.G.shape

    def call(key, y, yd=None, p=None, u=None, t=0.0):
        yd = np.zeros(n) if yd is None else yd
        u = np.zeros(len(system.input_symbols)) if u is None else u
        p = np.array([q.default for q in system.parameters]) if p is None else p
        v = np.array(lam[key](y, yd, p, u, t), dtype=float)
        return v.reshape(nc, n) if key == "G" else v

    return ce, call


def _hand_slider_crank(y, yd, r, l):
    """g, G, γ of the slider–crank, by hand (x horizontal, z up; rod angle θ)."""
    phi, xr, zr, th, s = y
    dphi, _, _, dth, _ = yd
    g = np.array([xr - l / 2 * np.cos(th) - r * np.cos(phi),
                  zr - l / 2 * np.sin(th) - r * np.sin(phi),
                  xr + l / 2 * np.cos(th) - s,
                  zr + l / 2 * np.sin(th)])
    G = np.array([[r * np.sin(phi), 1, 0, l / 2 * np.sin(th), 0],
                  [-r * np.cos(phi), 0, 1, -l / 2 * np.cos(th), 0],
                  [0, 1, 0, -l / 2 * np.sin(th), -1],
                  [0, 0, 1, l / 2 * np.cos(th), 0]])
    gamma = np.array([r * np.cos(phi) * dphi**2 + l / 2 * np.cos(th) * dth**2,
                      r * np.sin(phi) * dphi**2 + l / 2 * np.sin(th) * dth**2,
                      -l / 2 * np.cos(th) * dth**2,
                      -l / 2 * np.sin(th) * dth**2])
    return g, G, gamma


def test_slider_crank_constraints_match_the_hand_derivation_and_finite_differences() -> None:
    system = load_description(ROOT / "examples" / "slider_crank.yaml")
    ce, call = _functions(system)
    assert ce.names == ("pin_x", "pin_z", "slide_x", "slide_z")
    r, l = 0.1, 0.3
    for _ in range(20):
        y = RNG.normal(size=5)
        yd = RNG.normal(size=5)
        g, G, gamma = _hand_slider_crank(y, yd, r, l)
        np.testing.assert_allclose(call("g", y), g, atol=1e-14)
        np.testing.assert_allclose(call("G", y), G, atol=1e-14)
        np.testing.assert_allclose(call("gamma", y, yd), gamma, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(call("g_t", y), 0.0)
        h = 1e-6
        fd = np.column_stack([(call("g", y + h * e) - call("g", y - h * e)) / (2 * h)
                              for e in np.eye(5)])
        np.testing.assert_allclose(call("G", y), fd, atol=1e-8)
        # γ = d/dt (G ẏ) at ÿ = 0 (scleronomic): a central difference along ẏ
        fd_gamma = (call("G", y + h * yd) @ yd - call("G", y - h * yd) @ yd) / (2 * h)
        np.testing.assert_allclose(call("gamma", y, yd), fd_gamma, atol=1e-7)


def test_rheonomic_constraint_through_an_input_uses_its_derivatives() -> None:
    """g = x − u sin(φ)… with u an input: ∂g/∂t = −u̇ sin φ, and γ from the chain rule."""
    system = load_description_text("""
name: driven
parameters: {a: 0.5}
coordinates: {x: 0, phi: 0}
inputs: {u: a*sin(t)}
constraints:
  drive: x = u*sin(phi)
""")
    assert system.input_names == ("u", "d_u", "dd_u")
    _, call = _functions(system)
    for _ in range(10):
        (x, phi), (xd, phid) = RNG.normal(size=2), RNG.normal(size=2)
        u, du, ddu = RNG.normal(size=3)
        args = dict(y=[x, phi], yd=[xd, phid], u=[u, du, ddu])
        np.testing.assert_allclose(call("g", **args), [x - u * np.sin(phi)])
        np.testing.assert_allclose(call("G", **args), [[1, -u * np.cos(phi)]])
        np.testing.assert_allclose(call("g_t", **args), [-du * np.sin(phi)])
        # g̈ = ẍ − ü sin φ − 2 u̇ cos φ φ̇ + u sin φ φ̇² − u cos φ φ̈ = G ÿ + γ
        gamma = -ddu * np.sin(phi) - 2 * du * np.cos(phi) * phid + u * np.sin(phi) * phid**2
        np.testing.assert_allclose(call("gamma", **args), [gamma], rtol=1e-12, atol=1e-14)


BASE = """
name: redundant
parameters: {l: 1}
coordinates: {x: 0.5, z: 0.1}
frames:
  b: {translation: [x, 0, z]}
constraints:
"""


def test_redundant_constraints_are_named() -> None:
    text = BASE + "  first: x - 0.5\n  again: 2*x - 1\n  other: z - 0.1\n"
    with pytest.raises(ModelError, match=r"again \(redundant: its Jacobian row is a combination "
                                         r"of first\)"):
        from neweul_py.equations import newton_euler

        newton_euler(load_description_text(text))


def test_inconsistent_constraints_are_named() -> None:
    text = BASE + "  first: x - 0.5\n  clash: x - 0.7\n"
    with pytest.raises(ModelError, match=r"clash \(inconsistent: its Jacobian row is a "
                                         r"combination of first\)"):
        from neweul_py.equations import newton_euler

        newton_euler(load_description_text(text))


def test_constraint_errors_name_the_key() -> None:
    with pytest.raises(ModelError, match=r"constraints\.c1\.coincide\[1\]: unknown frame 'nope'"):
        load_description_text(BASE + "  c1: {coincide: [b, nope], components: [x]}\n")
    with pytest.raises(ModelError, match=r"constraints\.c1\.components\[0\]: component must be"):
        load_description_text(BASE + "  c1: {coincide: [b, ISYS], components: [w]}\n")
    with pytest.raises(ModelError, match=r"constraints\.c1: .*unknown name 'q'"):
        load_description_text(BASE + "  c1: x - q\n")


def _svd_reference(G: np.ndarray, rtol: float = 1e-9) -> list[tuple[int, list | None]]:
    """The rank test ``dependent_rows`` replaced: a row is independent when the smallest
    singular value of it stacked under the independent rows exceeds ``rtol · max|G|``;
    combinations by ``numpy.linalg.lstsq``."""
    scale = max(float(np.abs(G).max()), 1e-300)
    independent: list[int] = []
    out: list[tuple[int, list | None]] = []
    for i in range(G.shape[0]):
        sv = np.linalg.svd(G[[*independent, i]], compute_uv=False)
        if sv.size and sv[-1] > rtol * scale:
            independent.append(i)
            continue
        if not independent or not np.any(np.abs(G[i]) > rtol * scale):
            out.append((i, None))
            continue
        coef, *_ = np.linalg.lstsq(G[independent].T, G[i], rcond=None)
        out.append((i, list(zip(independent, coef, strict=True))))
    return out


@pytest.mark.parametrize("seed", range(20))
def test_dependent_rows_match_the_svd_rank_test(seed: int) -> None:
    """Plain-Python ``dependent_rows`` (Gram–Schmidt) against the SVD / least-squares test it
    replaced: random m × n matrices (1 ≤ m ≤ n ≤ 8) whose rows are random, zero, or random
    combinations of earlier rows (scaled from 1e-6 to 1e6) — the same rows found dependent,
    the same combinations (to 1e-8 relative)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 9))
    m = int(rng.integers(1, n + 1))
    rows: list[np.ndarray] = []
    for _ in range(m):
        kind = rng.random()
        if rows and kind < 0.35:
            pick = rng.choice(len(rows), size=min(len(rows), 2), replace=False)
            rows.append(sum(rng.normal() * rows[k] for k in pick))
        elif kind < 0.45:
            rows.append(np.zeros(n))
        else:
            rows.append(rng.normal(size=n))
    G = np.array(rows) * 10.0 ** rng.integers(-6, 7)
    ours, ref = dependent_rows(G.tolist()), _svd_reference(G)
    assert [i for i, _ in ours] == [i for i, _ in ref]
    for (_, c1), (_, c2) in zip(ours, ref, strict=True):
        if c1 is None or c2 is None:
            assert c1 is None and c2 is None
            continue
        assert [k for k, _ in c1] == [k for k, _ in c2]
        a, b = np.array([c for _, c in c1]), np.array([c for _, c in c2])
        np.testing.assert_allclose(a, b, rtol=1e-8, atol=1e-8 * np.abs(b).max())


def test_more_rows_than_columns_are_dependent() -> None:
    """Three rows in the plane: the third is a combination of the first two (the SVD test
    took the singular values of the 3 × 2 stack, two of them, and accepted it)."""
    out = dependent_rows([[1.0, 0.0], [1.0, 1.0], [2.0, 3.0]])
    assert [i for i, _ in out] == [2]
    np.testing.assert_allclose([c for _, c in out[0][1]], [-1.0, 3.0], rtol=1e-12)


def test_a_closed_loop_is_derived_without_numpy() -> None:
    """The rank check is plain Python: deriving the four-bar (a closed loop) in a fresh
    process imports no NumPy."""
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    code = ("import sys; from neweul_py.api import derive; "
            f"derive({str(root / 'examples' / 'four_bar.yaml')!r}); "
            "print('numpy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=root)
    assert out.stdout.strip() == "False"


@pytest.mark.parametrize("default", ["t", "ma", "0.5*t + ma"])
def test_constrained_model_with_an_input_of_t_or_a_bare_parameter(default, tmp_path) -> None:
    """``sed 's/^  Md: 0 .*/  Md: t/' examples/four_bar.yaml``: the input default ``t`` (or a
    bare parameter) evaluated at the initial state to a Python float, which has no
    ``evalf`` (AttributeError in generate). The model derives and generates; reference: the
    module's default input equals the description's expression, and the constraint check
    still refuses a redundant constraint of such a model."""
    from neweul_py.analysis.module import load_generated
    from neweul_py.api import generate
    from neweul_py.equations import newton_euler

    text = (ROOT / "examples" / "four_bar.yaml").read_text()
    lines = [f"  Md: {default}" if line.startswith("  Md: 0") else line
             for line in text.splitlines()]
    desc = tmp_path / "four_bar_t.yaml"
    desc.write_text("\n".join(lines) + "\n")
    module = load_generated(generate(desc, tmp_path / "gen"))
    p = module.default_parameters()
    ma = p[list(module.PARAMETERS).index("ma")]
    expected = {"t": 0.7, "ma": ma, "0.5*t + ma": 0.35 + ma}[default]
    assert module.default_inputs(0.7, p)[list(module.INPUTS).index("Md")] == pytest.approx(
        expected, rel=1e-15)
    redundant = BASE.replace("coordinates:", "inputs: {u: t}\ncoordinates:") + \
        "  first: x - 0.5\n  again: 2*x - 1\n  other: z - 0.1\n"
    with pytest.raises(ModelError, match=r"again \(redundant"):
        newton_euler(load_description_text(redundant))
