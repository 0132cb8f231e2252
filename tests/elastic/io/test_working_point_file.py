"""The optional ``static`` and ``loss`` groups of a working-point FE file."""

from __future__ import annotations

import numpy as np
import pytest

from neweul_py.elastic.io.fe_files import read_fe_model
from neweul_py.elastic.io.working_point import read_loss, read_static, write_working_point
from neweul_py.errors import DataError
from neweul_py.middle_ear.model import build_middle_ear
from neweul_py.middle_ear.static import solve_static, static_summary
from neweul_py.middle_ear.working_point import hysteretic_damping, static_data, working_point_model


@pytest.fixture(scope="module")
def point():
    me = build_middle_ear(refine=0)
    (state,) = solve_static(me, [2000.0])
    return me, state


def test_round_trip_and_backward_compatible(point, tmp_path):
    """The file still reads as a plain ``neweul-fe`` model (the static group is ignored by the
    format reader; the loss group becomes the model's ``G`` with its reference frequency,
    docs/equations.md §1.1), and the groups come back unchanged; a loss group that does not
    name its reference frequency is one error naming ``loss_meta.f_ref_Hz``."""
    me, s = point
    fe, g, grp = working_point_model(me, s), hysteretic_damping(me, s), static_data(me, s)
    path = tmp_path / "wp.npz"
    write_working_point(fe, path, g, {"tm_loss": 0.1, "f_ref_Hz": 1000.0}, grp)
    fe2 = read_fe_model(path)
    assert fe2.n_dofs == fe.n_dofs and abs(fe2.K - fe.K).max() == 0
    assert abs(fe2.G - g).max() == 0 and fe2.loss_reference_frequency == 1000.0
    g2, meta = read_loss(path)
    assert abs(g2 - g).max() == 0 and meta == {"tm_loss": 0.1, "f_ref_Hz": 1000.0}
    write_working_point(fe, tmp_path / "bad.npz", g, {"tm_loss": 0.1})
    with pytest.raises(DataError) as exc:
        read_fe_model(tmp_path / "bad.npz")
    assert exc.value.item == "loss_meta.f_ref_Hz"
    st = read_static(path)
    for key, val in grp.items():
        np.testing.assert_array_equal(st[key], val)


def test_static_forces_balance_the_chain(point):
    """The static interface forces of the malleus on the manubrium sum to minus the chain's
    restoring force (equilibrium of the malleus, R_q = 0), and the static state vector holds
    the umbo displacement of the static table."""
    me, s = point
    grp = static_data(me, s)
    row = static_summary(me, s)
    fz = grp["manubrium_force"][:, 2].sum()
    assert -fz == pytest.approx(row["support_force_z_N"], rel=1e-12)
    assert row["support_force_z_N"] > 0  # Δp > 0 pushes the malleus medially
    # the chain force along z at the static malleus position, from the characteristic
    from neweul_py.middle_ear.chain import chain_force

    p = me.params
    f_chain = chain_force(
        grp["malleus_q"][2], p.k_chain, p.chain_limit_medial, p.chain_limit_lateral
    )[0]
    assert -fz == pytest.approx(f_chain, rel=1e-5)
    assert grp["u"][me.umbo, 2] == pytest.approx(row["umbo_uz_m"])
    assert np.count_nonzero(grp["x"][me.n_u :]) == 0


def test_no_groups_writes_plain_file(point, tmp_path):
    """Without groups the writer is the plain ``neweul-fe`` writer; readers return None."""
    me, s = point
    path = tmp_path / "plain.npz"
    write_working_point(working_point_model(me, s), path)
    assert read_loss(path) is None and read_static(path) is None
