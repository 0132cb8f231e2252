"""``api.generate`` from a path, YAML text or a ``System`` (neweul_py/api.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from neweul_py import api
from neweul_py.analysis import load_generated, simulate
from neweul_py.errors import DescriptionError, NeweulError

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_generate_accepts_text_and_system(tmp_path):
    """Reference: the module generated from the file itself — text gives a byte-identical
    module (same SOURCE_HASH), a System the same trajectory."""
    from_path = api.generate(EXAMPLES / "pendulum.yaml", tmp_path / "path")
    from_text = api.generate((EXAMPLES / "pendulum.yaml").read_text(), tmp_path / "text")
    assert from_text.read_bytes() == from_path.read_bytes()
    system = api.load_description(EXAMPLES / "pendulum.yaml")
    from_system = api.generate(system, tmp_path / "system")
    mod = load_generated(from_system)
    assert mod.SOURCE_HASH == system.fingerprint()
    a = simulate(mod, 1.0, n_out=5)
    b = simulate(load_generated(from_path), 1.0, n_out=5)
    np.testing.assert_array_equal(a.table, b.table)


def test_generate_rejects_other_objects_and_bad_text(tmp_path):
    """Reference: the documented errors (one line each, naming the source)."""
    with pytest.raises(NeweulError, match="expected a description path, YAML text or a System"):
        api.generate(42, tmp_path)
    with pytest.raises(DescriptionError, match="<description text>"):
        api.generate("name: x\ncoordinates: [\n", tmp_path)
    assert not any(tmp_path.iterdir())
