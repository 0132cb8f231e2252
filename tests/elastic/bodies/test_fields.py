"""The fields a reduced and a parametric body share, and their one check.

Reference: the format's rules (docs/reduced-body-format.md, "Checks of a body"): the same
bad value of a shared field is refused by a single body and by a parametric body alike,
naming the field; a valid body passes unchanged (the arrays it was given, bit for bit).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from fe_builders import piston_duct

from neweul_py.elastic import ParametricBody, ReducedBody, reduce_modal
from neweul_py.elastic.bodies.fields import BodyFields, check_body_fields
from neweul_py.elastic.parametric.local_interpolation import interpolate
from neweul_py.errors import DataError


@pytest.fixture(scope="module")
def bodies() -> list[ReducedBody]:
    return [reduce_modal(piston_duct(30, stiffness=k), modes=4, store_bases=True)
            .with_(parameters={"k": k}) for k in (1.5e5, 2.5e5)]


@pytest.fixture(scope="module")
def pbody(bodies) -> ParametricBody:
    return interpolate(bodies, parameter="k", row_scaling="none")


def test_both_bodies_hold_the_one_field_block(bodies, pbody):
    """Every field of BodyFields is a field of both body types, keyword-only."""
    shared = {f.name for f in dataclasses.fields(BodyFields)}
    for cls in (ReducedBody, ParametricBody):
        assert issubclass(cls, BodyFields)
        fields = {f.name: f for f in dataclasses.fields(cls)}
        assert shared <= set(fields)
        assert all(f.kw_only for f in fields.values())
    with pytest.raises(TypeError):
        ReducedBody(bodies[0].M)            # positional: refused by the dataclass


def test_a_valid_body_keeps_its_arrays(bodies):
    """The check normalizes in place: float64 arrays come back as the same objects."""
    b = bodies[0]
    copy = b.with_()
    for key in ("M", "D", "K", "V_kept", "W_kept", "V", "W"):
        assert copy[key] is b[key], key
    assert check_body_fields(copy, None) == b.order


@pytest.mark.parametrize(("key", "bad", "text"), [
    ("nodes", lambda a: a * np.array([-1.0, 1, 1, 1]), "non-negative whole numbers"),
    ("kept_dofs", lambda a: a + 0.5, "non-negative whole numbers"),
    ("dof_node", lambda a: -a - 1, "non-negative whole numbers"),
    ("dof_kind", lambda a: a[:-1], "must match kept_dofs"),
    ("M", lambda a: a + 1j, "complex"),
    ("V_kept", lambda a: np.where(a == a.flat[0], np.nan, a), "NaN/Inf"),
])
def test_both_bodies_refuse_the_same_bad_field(bodies, pbody, key, bad, text):
    """One rule, two body types: a single body and the parametric body built from such
    bodies name the same field (the parametric value is the single one stacked where the
    field varies over the samples)."""
    with pytest.raises(DataError, match=text) as single:
        bodies[0].with_(**{key: bad(bodies[0][key])})
    with pytest.raises(DataError, match=text) as stacked:
        pbody.with_(**{key: bad(pbody[key])})
    assert single.value.item == stacked.value.item


def test_names_must_fit_the_matrices(bodies, pbody):
    for body in (bodies[0], pbody):
        with pytest.raises(DataError, match="inputs") as exc:
            body.with_(input_names=(*body.input_names, "extra"))
        assert exc.value.item == "B"
