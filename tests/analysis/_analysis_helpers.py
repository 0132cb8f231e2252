"""Helpers of the analysis tests: hand-written protocol modules (see fixtures/README.md)."""

from __future__ import annotations

import types
from pathlib import Path

from neweul_py.analysis.module import load_generated

FIXTURES = Path(__file__).parent / "fixtures"


def load_fixture(name: str) -> types.ModuleType:
    """Import ``fixtures/<name>.py`` through the protocol loader."""
    return load_generated(FIXTURES / f"{name}.py")


def variant(module: types.ModuleType, **overrides: object) -> types.SimpleNamespace:
    """A copy of ``module``'s namespace with some attributes replaced (for bad-input cases)."""
    ns = {k: getattr(module, k) for k in dir(module) if not k.startswith("__")}
    ns.update(overrides)
    return types.SimpleNamespace(**ns)
