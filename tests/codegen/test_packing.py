"""Packed fills, the factored mass matrix and the LAPACK solve of generated modules.

References: the closed-form module of the same description (``form="closed"``: the mass matrix
as the fully substituted sums ``Σ JᵀΘJ``, filled entry by entry) and ``numpy.linalg.solve``.
"""

from __future__ import annotations

import importlib.util
import sys

import numpy as np
import pytest

from neweul_py.analysis.module import load_generated
from neweul_py.codegen import generate_module
from neweul_py.description import load_description_text
from neweul_py.equations import newton_euler

#: Two links with full (off-diagonal) inertia tensors and offset centres of mass, so that the
#: factored form needs its ``J_a ± J_b`` rows.
TWO_LINKS = """
name: full_inertia
gravity: [0, 0, -g]
parameters: {m: 1.3, l: 0.4, g: 9.81, a: 0.02, b: 0.003, c: 0.001}
coordinates:
  q1: {initial: 0.3, velocity: 0.2}
  q2: {initial: -0.4, velocity: 0.1}
  q3: {initial: 0.2, velocity: -0.3}
frames:
  f1: {rotation: [[x, q1], [y, q2]]}
  f2: {parent: f1, translation: [0, 0, -l], rotation: [[z, q3]]}
bodies:
  b1: {frame: f1, mass: m, center_of_mass: [0.01, 0, -l/2],
       inertia: [[2*a, b, c], [b, 2*a, -b], [c, -b, 3*a]]}
  b2: {frame: f2, mass: 2*m, center_of_mass: [0.02, 0.01, -l/3],
       inertia: [[2*a, -c, 0], [-c, 2*a, b], [0, b, 3*a]]}
"""


def _modules(tmp_path):
    system = load_description_text(TWO_LINKS)
    rec = newton_euler(system, form="recursive")
    assert rec.mass_factors
    closed = newton_euler(system, form="closed")
    assert closed.mass_factors is None
    return (load_generated(generate_module(rec, "0" * 64, tmp_path / "rec.py")),
            load_generated(generate_module(closed, "0" * 64, tmp_path / "closed.py")))


def test_factored_mass_matrix_equals_the_closed_form(tmp_path) -> None:
    """``Gᵀ diag(w) G`` (recursive module, off-diagonal inertia included) equals the closed
    form's entry-by-entry mass matrix, and ``rhs`` equals ``numpy.linalg.solve`` of the closed
    form's M and q − k, at random states."""
    rec, closed = _modules(tmp_path)
    rng = np.random.default_rng(3)
    p = rec.default_parameters()
    for _ in range(5):
        x = rng.normal(size=6)
        M = closed.mass_matrix(0.0, x[:3], p)
        np.testing.assert_allclose(rec.mass_matrix(0.0, x[:3], p), M, rtol=1e-13, atol=1e-15)
        ydd = np.linalg.solve(M, closed.force_vector(0.0, x[:3], x[3:], p))
        np.testing.assert_allclose(rec.rhs(0.0, x, p), np.hstack((x[3:], ydd)), rtol=1e-12,
                                   atol=1e-13)
        np.testing.assert_allclose(closed.rhs(0.0, x, p), np.hstack((x[3:], ydd)),
                                   rtol=1e-12, atol=1e-13)


def test_numpy_only_fallback_gives_the_same_rhs(tmp_path, monkeypatch) -> None:
    """Without SciPy the module imports and solves with ``numpy.linalg.solve`` (reference:
    the same module with SciPy's LAPACK), to round-off."""
    rec, closed = _modules(tmp_path)
    x, p = np.linspace(-0.5, 0.7, 6), rec.default_parameters()
    ref_rec, ref_closed = rec.rhs(0.0, x, p), closed.rhs(0.0, x, p)
    monkeypatch.setitem(sys.modules, "scipy.linalg.lapack", None)  # import fails
    for name, ref in (("rec", ref_rec), ("closed", ref_closed)):
        spec = importlib.util.spec_from_file_location(f"_numpy_only_{name}",
                                                      tmp_path / f"{name}.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        assert mod._dposv is None  # imported at the first solve, not with the module
        np.testing.assert_allclose(mod.rhs(0.0, x, p), ref, rtol=1e-12, atol=1e-13)
        assert mod._dposv is False


def test_singular_mass_matrix_raises_linalg_error(tmp_path) -> None:
    """A massless model (M = 0) raises ``numpy.linalg.LinAlgError`` as ``numpy.linalg.solve``
    does (reference: numpy's behaviour), with and without the factored form."""
    text = TWO_LINKS.replace("m: 1.3", "m: 0.0").replace("a: 0.02, b: 0.003, c: 0.001",
                                                          "a: 0.0, b: 0.0, c: 0.0")
    system = load_description_text(text)
    for form in ("recursive", "closed"):
        mod = load_generated(generate_module(newton_euler(system, form=form), "0" * 64,
                                             tmp_path / f"{form}.py"))
        with pytest.raises(np.linalg.LinAlgError):
            mod.rhs(0.0, np.zeros(6), mod.default_parameters())
