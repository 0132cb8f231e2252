"""The generated ``loss_matrix`` (docs/equations.md §1.1) in both backends: the compiled
module's equals the NumPy twin's, for a rigid model with loss factors and for an elastic body
with a hysteretic matrix (whose compiled module takes it from its twin, which reads the same
data file); models without loss factors have no ``loss_matrix`` (their text is
unchanged)."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from compiler import needs_c_compiler

from neweul_py.analysis.module import as_model
from neweul_py.api import generate
from neweul_py.cli import main

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "analysis"))
sys.path.insert(0, str(ROOT / "tests" / "support"))


def _pair(source, directory: Path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")      # a fallback to NumPy would make the test vacuous
        cpath = generate(source, directory, backend="c")
    c = as_model(cpath)
    assert c.BACKEND == "c"
    return as_model(cpath.with_name(cpath.name.replace("_c.py", ".py"))), c


@needs_c_compiler
def test_compiled_loss_matrix_equals_the_numpy_twin(tmp_path: Path) -> None:
    """Reference: the NumPy module of the same equations (same CSE'd program), at random
    states of a chain with bushings and a rotational spring carrying loss factors (the C
    printer has no table curves: a linear hinge here)."""
    from test_frf_loss_factors import CHAIN

    chain = CHAIN.replace("stiffness: {table: [[-1, -2], [0, 0], [0.5, 1.5], [1, 4]]}",
                          "stiffness: kr")
    assert chain != CHAIN
    mnp, mc = _pair(chain, tmp_path)
    p = mnp.default_parameters()
    rng = np.random.default_rng(3)
    for _ in range(3):
        x = rng.normal(scale=0.3, size=mnp.STATE_SIZE)
        G = mnp.loss_matrix(0.0, x, p)
        assert np.abs(G).max() > 0
        assert np.allclose(mc.loss_matrix(0.0, x, p), G, rtol=1e-12, atol=1e-12)
    assert mc.LOSS_REFERENCE_FREQUENCY == mnp.LOSS_REFERENCE_FREQUENCY == 200.0


@needs_c_compiler
def test_compiled_elastic_loss_matrix_equals_the_splice(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """Reference: the NumPy module's kernel splice (``S_Wᵀ G_s S_V`` plus the body's ``Le``),
    for the lossy piston–duct body with a lossy bushing at its node frame: the compiled
    module's ``loss_matrix`` (its twin's, on the same data file) is the same, not zero."""
    from lossy_duct import EXAMPLE, lossy_duct

    from neweul_py.elastic import write_fe_model

    monkeypatch.chdir(tmp_path)
    write_fe_model(lossy_duct(), "duct.npz")
    assert main(["reduce", "duct.npz", "--two-sided", "--modes", "6", "--keep-nodes", "1",
                 "--invariants", "-o", "body.npz"]) == 0
    text = (EXAMPLE / "model.yaml").read_text().replace(
        "    damping: {diag: [d2, 0, 0]}\n", "    damping: {diag: [d2, 0, 0]}\n"
        "    loss_factor: 0.1\n")
    Path("model.yaml").write_text("loss_reference_frequency: 300\n" + text)
    mnp, mc = _pair(tmp_path / "model.yaml", tmp_path / "gen")
    p = mnp.default_parameters()
    x = np.random.default_rng(5).normal(size=mnp.STATE_SIZE)
    G = mnp.loss_matrix(0.0, x, p)
    assert np.abs(G).max() > 0
    assert np.allclose(mc.loss_matrix(0.0, x, p), G, rtol=1e-10, atol=1e-10 * np.abs(G).max())


def test_models_without_loss_factors_have_no_loss_matrix(tmp_path: Path) -> None:
    """Reference: the generated-module protocol (docs/generated-module-protocol.md):
    ``loss_matrix`` and ``LOSS_REFERENCE_FREQUENCY`` only where the model has loss factors."""
    mod = as_model(generate(ROOT / "examples" / "pendulum.yaml", tmp_path)).module
    assert not hasattr(mod, "loss_matrix") and not hasattr(mod, "LOSS_REFERENCE_FREQUENCY")
