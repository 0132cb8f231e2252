"""Geometry of the tympanic-membrane mesh (:func:`neweul_py.fem.mesh.cone_membrane`).

References: plane geometry (the map of an off-centre cone keeps the rim polygon, so the
planar area is the rim polygon's; the rays from the umbo carry the centred cone's profile)
and Kassem et al. 2022 (*Laryngoscope Investig. Otolaryngol.*, doi:10.1002/lio2.861; 23
temporal bones): the posterior-superior quadrant, cut by the manubrium and by the line
through the umbo across it, is the largest, 31 % of the pars tensa.
"""

from __future__ import annotations

import numpy as np
import pytest

from neweul_py.errors import ModelError
from neweul_py.fem.mesh import cone_membrane, manubrium_section
from neweul_py.middle_ear.parameters import MiddleEarParameters


def _planar(mesh):
    x = mesh.points[mesh.triangles][:, :, :2]
    d1, d2 = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
    return 0.5 * (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]), x.mean(axis=1)


def _min_angle(mesh) -> float:
    x = mesh.points[mesh.triangles]
    worst = np.inf
    for i in range(3):
        a, b = x[:, (i + 1) % 3] - x[:, i], x[:, (i + 2) % 3] - x[:, i]
        cos = np.einsum("ij,ij->i", a, b) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
        worst = min(worst, float(np.degrees(np.arccos(cos)).min()))
    return worst


@pytest.mark.parametrize("rings", [4, 8, 16])
def test_off_centre_cone_keeps_rim_area_and_profile(rings):
    """Umbo at the origin, manubrium on +x from the umbo to the superior rim, the rim the
    same circle about ``rim_centre``, no folded triangle, the planar area of the centred
    mesh's polygon (1e-12), and the profile along the rays: ``z`` of every node is the
    centred cone's ``z`` of the same ring fraction."""
    a, h, bulge, e = 4.37e-3, 2e-3, 0.5e-3, 0.16
    ref = cone_membrane(a, h, rings, 1.0, bulge)
    tm = cone_membrane(a, h, rings, 1.0, bulge, umbo_offset=e)
    np.testing.assert_allclose(tm.points[tm.line[0]], [0.0, 0.0, h], atol=1e-15)
    assert np.abs(tm.points[tm.line, 1]).max() < 1e-15
    assert np.all(np.diff(tm.points[tm.line, 0]) > 0)
    np.testing.assert_allclose(tm.rim_centre, a * e * np.array([np.sin(np.arctan(e)),
                                                                  -np.cos(np.arctan(e))]))
    rim = np.hypot(*(tm.points[tm.boundary, :2] - tm.rim_centre).T)
    np.testing.assert_allclose(rim, a, rtol=1e-12)
    # the manubrium's tip: the last line node's fraction of the way to the rim point
    tip = tm.points[tm.line[-1], 0] / (a * np.hypot(1.0, e))
    assert tip == pytest.approx((rings - 1) / rings, rel=1e-12)
    area, _ = _planar(tm)
    assert np.all(area > 0)
    assert area.sum() == pytest.approx(_planar(ref)[0].sum(), rel=1e-12)
    np.testing.assert_array_equal(tm.points[:, 2], ref.points[:, 2])
    assert _min_angle(tm) > 35.0  # the centred mesh: 44–47°


def test_default_umbo_offset_gives_the_measured_quadrants():
    """With the default offset (0.16 of the radius) the posterior-superior quadrant holds
    31 ± 0.5 % of the TM's planar area (Kassem et al. 2022: 31 %), the largest of the four;
    the centred cone gives 25 %. Quadrants: the manubrium line (+x) and the line through the
    umbo across it; posterior is −y (+y anterior, docs/equations-middle-ear.md §1)."""
    p = MiddleEarParameters()
    area = {}
    for e in (0.0, p.umbo_offset):
        tm = cone_membrane(p.tm_radius, p.tm_depth, 32, 1.0, p.tm_bulge, umbo_offset=e)
        w, c = _planar(tm)
        sup, post = c[:, 0] > 0, c[:, 1] < 0
        area[e] = {q: w[m].sum() / w.sum() for q, m in
                   {"PS": sup & post, "AS": sup & ~post, "PI": ~sup & post,
                    "AI": ~sup & ~post}.items()}
    assert area[0.0]["PS"] == pytest.approx(0.25, abs=0.005)
    assert area[p.umbo_offset]["PS"] == pytest.approx(0.31, abs=0.005)
    assert max(area[p.umbo_offset], key=area[p.umbo_offset].get) == "PS"


@pytest.mark.parametrize("e", [-0.1, 0.5, float("nan")])
def test_bad_umbo_offset(e):
    """An offset outside [0, 0.5) of the radius is refused, naming the key."""
    with pytest.raises(ModelError, match="umbo_offset"):
        cone_membrane(1.0, 0.2, 4, umbo_offset=e)


@pytest.mark.parametrize("e", [0.0, 0.16])
def test_manubrium_section_runs_along_two_straight_rays(e):
    """The section runs from the inferior rim through the umbo to the superior rim along two
    straight rays (collinear points on each: zero cross product), distances increasing, and
    its superior part holds the manubrium nodes."""
    tm = cone_membrane(1.0, 0.3, 6, 1.0, 0.05, umbo_offset=e)
    nodes, s = manubrium_section(tm)
    assert np.all(np.diff(s) > 0) and s[6] == 0.0 and nodes[6] == tm.line[0]
    xy = tm.points[nodes, :2]
    for part in (xy[:7], xy[6:]):
        d = part - part[0]
        assert np.abs(d[:, 0] * d[-1, 1] - d[:, 1] * d[-1, 0]).max() < 1e-12
    np.testing.assert_array_equal(nodes[6:12], tm.line)
    assert set(nodes[[0, -1]]) <= set(tm.boundary)
