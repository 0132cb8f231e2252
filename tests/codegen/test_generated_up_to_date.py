"""The modules shipped in generated/ are exactly what the current code generates.

If this fails after a change to the examples, the equations or the generator, refresh with::

    python examples/regenerate.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "examples"))

import regenerate  # noqa: E402
from make_chain import chain_description  # noqa: E402

from neweul_py.api import generate  # noqa: E402


@pytest.mark.parametrize("name", regenerate.DESCRIPTIONS)
def test_generated_module_is_up_to_date(name, tmp_path):
    fresh = generate(ROOT / "examples" / name, tmp_path)
    shipped = ROOT / "generated" / fresh.name
    assert shipped.is_file(), (
        f"generated/{fresh.name} is missing: run python examples/regenerate.py"
    )
    assert shipped.read_bytes() == fresh.read_bytes(), (
        f"generated/{fresh.name} is out of date: run python examples/regenerate.py"
    )


@pytest.mark.parametrize("name", sorted(regenerate.CHAINS))
def test_chain_descriptions_are_up_to_date(name):
    n, spatial = regenerate.CHAINS[name]
    text = (ROOT / "examples" / name).read_text(encoding="utf-8")
    assert text == chain_description(n, spatial), (
        f"examples/{name} is out of date: run python examples/regenerate.py"
    )
