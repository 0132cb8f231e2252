"""``neweul reduce`` of a working-point FE file carries its static state into the body, and
``neweul body-info`` shows it.

Reference: the FE static solution of ``neweul fem middle-ear`` (refine 0, one working point):
``static.csv`` (umbo displacement, support force) and the file's ``static_*`` group.
"""

from __future__ import annotations

import numpy as np
import pytest
from fe_builders import piston_duct

from neweul_py.cli import main
from neweul_py.elastic.io.body_files import load_reduced_body, save_reduced_body
from neweul_py.elastic.io.working_point import read_static


@pytest.fixture(scope="module")
def working_point(tmp_path_factory):
    d = tmp_path_factory.mktemp("wp")
    assert main(["fem", "middle-ear", "--refine", "0", "--pressures", "2000:2000:1", "-o",
                 str(d / "fem"), "-q"]) == 0
    return d, d / "fem" / "model_dp+02000.npz"


def test_reduce_writes_the_static_state_of_the_working_point(working_point, capsys):
    """Node displacements and interface forces are the FE file's, bit for bit; the static
    umbo output is ``static.csv``'s umbo displacement; the forces sum to minus the support
    force the TM passes to the chain."""
    d, fe_file = working_point
    out = d / "b.npz"
    assert main(["reduce", str(fe_file), "--modes", "20", "--static-correction", "-o",
                 str(out)]) == 0
    body = load_reduced_body(out)
    st, fe_st = body.static, read_static(fe_file)
    assert body.V is None                       # bases used for the projection, not stored
    ids = [int(n) for n in body.nodes[:, 0]]
    tm = {int(n): u for n, u in zip(fe_st["node_id"], fe_st["u"], strict=True)}
    for i, nid in enumerate(ids):
        if nid in tm:
            assert np.array_equal(st.node_u[i], tm[nid]), nid
    for nid, f in zip(fe_st["manubrium_node_id"], fe_st["manubrium_force"], strict=True):
        assert np.array_equal(st.node_force[ids.index(int(nid))], f)
    row = np.genfromtxt(d / "fem" / "static.csv", delimiter=",", names=True)
    umbo = st.outputs[list(body.output_names).index("umbo_uz")]
    assert umbo == pytest.approx(float(row["umbo_uz_m"]), rel=1e-12)
    assert st.node_force[:, 2].sum() == pytest.approx(-float(row["support_force_z_N"]),
                                                      rel=1e-9)
    assert 0 < float(st.residual) < 1.0
    capsys.readouterr()
    assert main(["body-info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "static state: residual of V q_s" in text and "node      1: u_s" in text
    assert "sum of the interface forces" in text
    assert f"output umbo_uz: {umbo:+.6e}" in text


def test_body_info_of_a_body_without_static_state(tmp_path, capsys):
    """A body reduced from a plain FE model says it has none (reference: the file)."""
    from neweul_py.elastic import reduce_modal

    save_reduced_body(reduce_modal(piston_duct(30), modes=3), tmp_path / "p.npz")
    assert main(["body-info", str(tmp_path / "p.npz")]) == 0
    assert "no static state" in capsys.readouterr().out
    assert main(["body-info", str(tmp_path / "p.npz"), "--at", "p=1"]) == 1


def test_body_info_states_the_projection_from_the_data_and_the_bytes_by_part(tmp_path, capsys):
    """One-sided or two-sided from the node rows of the bases (reference: ``W_kept`` equal to
    ``V_kept`` or not), whatever the file claims; the bytes by part add up to the stored
    arrays (reference: the zip members of the file)."""
    import re
    import zipfile

    import numpy as np

    from neweul_py.elastic import reduce_modal

    fe = piston_duct(30)
    for two_sided, words in ((True, "two-sided (Petrov-Galerkin"),
                             (False, "one-sided (Galerkin, W = V)")):
        body = reduce_modal(fe, modes=3, two_sided=two_sided, store_bases=True)
        assert np.array_equal(body.V_kept, body.W_kept) != two_sided
        path = tmp_path / f"b{two_sided}.npz"
        save_reduced_body(body, path)
        assert main(["body-info", str(path)]) == 0
        out = capsys.readouterr().out
        assert words in out and "basis: modal" in out and "claims" not in out
        with zipfile.ZipFile(path) as z:
            total = sum(i.file_size for i in z.infolist() if i.filename != "meta.npy")
        parts = [float(x) for x in re.findall(r"^    [^:]+: ([\d.]+) MB$", out, re.M)]
        assert abs(sum(parts) - total / 1e6) <= 0.01 * len(parts) + 1e-9
    lying = reduce_modal(fe, modes=3, two_sided=False).with_(
        settings={"two_sided": True, "modes": 3})
    save_reduced_body(lying, tmp_path / "lying.npz")
    assert main(["body-info", str(tmp_path / "lying.npz")]) == 0
    assert "one-sided (Galerkin, W = V); basis: modal — the file claims two-sided" in (
        capsys.readouterr().out)
