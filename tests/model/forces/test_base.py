"""The schema of every force element (``neweul_py/model/forces/base.py``) fits its class.

Reference: the dataclass fields of each element (``dataclasses.fields``).
"""

from __future__ import annotations

import dataclasses

import pytest

from neweul_py.model import FORCE_ELEMENTS, FORCE_TYPES


@pytest.mark.parametrize("element", FORCE_ELEMENTS, ids=lambda e: e.__name__)
def test_every_key_fills_fields_and_every_field_without_default_has_a_required_key(
        element: type) -> None:
    """Keys name existing fields; a field without a default is filled by a required key (so
    every description that passes the key check builds the element)."""
    fields = {f.name: f for f in dataclasses.fields(element)}
    filled = {a for key in element.schema() for a in key.attrs}
    assert filled <= set(fields), filled - set(fields)
    required = {a for key in element.schema() if key.required for a in key.attrs}
    no_default = {n for n, f in fields.items() if n != "name"
                  and f.default is dataclasses.MISSING
                  and f.default_factory is dataclasses.MISSING}
    assert no_default <= required, no_default - required
    assert element.components


def test_type_names_are_unique() -> None:
    """One element class per description ``type``."""
    assert len(FORCE_TYPES) == len(FORCE_ELEMENTS)
