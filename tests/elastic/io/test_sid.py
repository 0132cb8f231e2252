"""SID reader/writer and Taylor objects.

References: the beam SID file of EMBS_ModelicaLib (``tests/data/beam.SID_FEM``, see
``tests/data/README.md``) with the eigenfrequencies printed in its ``ielastq`` names;
the SID block layout of Wallrapp 1994 / Schwertassek & Wallrapp 1999.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla

from neweul_py.elastic.bodies.taylor import Taylor
from neweul_py.elastic.io.sid import SIDBody, invariants_from_sid, read_sid, write_sid
from neweul_py.errors import DataError

BEAM = Path(__file__).resolve().parents[2] / "data" / "beam.SID_FEM"


@pytest.fixture(scope="module")
def beam() -> SIDBody:
    return read_sid(BEAM)


# ------------------------------------------------------------------------------ Taylor
def test_taylor_evaluate_vectorized():
    """X(q) = m0 + Σ m1[:, k, :] q_k, also for a batch of q."""
    rng = np.random.default_rng(0)
    m0, m1 = rng.normal(size=(4, 2)), rng.normal(size=(4, 3, 2))
    t = Taylor.from_arrays(m0, m1)
    q = rng.normal(size=(5, 3))
    ref = np.stack([m0 + sum(m1[:, k, :] * qi[k] for k in range(3)) for qi in q])
    np.testing.assert_allclose(t.evaluate(q), ref, rtol=1e-14)
    np.testing.assert_allclose(t.evaluate(q[0]), ref[0], rtol=1e-14)
    assert np.array_equal(Taylor.from_arrays(m0).evaluate(q).shape, (5, 4, 2))


def test_symmetric_both_triangles_listed():
    """Structure 2 with both triangles listed (some exporters do): the mean is taken."""
    t = Taylor.from_entries(0, 2, 2, 0, 0, 2, [(1, 1, 1.0), (1, 2, 2.0), (2, 1, 2.2)])
    assert t.m0.tolist() == [[1.0, 2.1], [2.1, 0.0]]


def test_taylor_structures():
    """Structure flags expand entries: 1 diagonal, 2 symmetric mirror, 4 identity, 0 zero."""
    sym = Taylor.from_entries(1, 2, 2, 1, 0, 2, [(2, 1, 3.0)], [(2, 1, 1, 5.0)])
    assert sym.m0.tolist() == [[0, 3], [3, 0]]
    assert sym.m1[:, 0, :].tolist() == [[0, 5], [5, 0]]
    assert Taylor.from_entries(0, 3, 3, 0, 0, 4).m0.tolist() == np.eye(3).tolist()
    assert not np.any(Taylor.from_entries(1, 2, 3, 4, 0, 0).m1)
    with pytest.raises(DataError, match="symmetric"):
        Taylor(0, 2, 2, 0, 0, 2, np.array([[0.0, 1.0], [2.0, 0.0]]))
    with pytest.raises(DataError, match="diagonal"):
        Taylor(0, 2, 2, 0, 0, 1, np.ones((2, 2)))
    assert Taylor.from_arrays(np.eye(3)).natural_structure() == 4
    assert Taylor.from_arrays(np.diag([1.0, 2.0])).natural_structure() == 1
    assert Taylor.from_arrays(np.zeros((2, 3)), np.zeros((2, 1, 3))).natural_structure() == 0


# ------------------------------------------------------------------------------ reader
def test_beam_frequencies_from_Ke_Me(beam):
    """eig(Ke, Me) of the beam file gives the frequencies named in its ielastq entries
    (51.626 … 1932.967 Hz) to the printed precision (3 decimals)."""
    named = beam.frequencies_from_names()
    assert named is not None and len(named) == 11
    assert named[0] == 51.626 and named[-1] == 1932.967
    f = np.sqrt(sla.eigvalsh(beam["Ke"].m0, beam["Me"].m0)) / (2 * np.pi)
    np.testing.assert_allclose(f, named, atol=5e-4 + 1e-9)


def test_beam_content(beam):
    """Sizes and a few values read by hand from the file."""
    assert beam.nq == 11 and beam.mass == 12.5604
    assert [n.id for n in beam.nodes] == [1860, 1861, 1862, 1892, 362, 1793]
    n = beam.node(1861)
    assert n.rframe == "body ref"
    assert n.origin.m0[:, 0].tolist() == [-0.25, 0.0, 0.520000010700]
    assert n.origin.m1[0, 9, 0] == 9.16161663355e-02          # m1( 1, 10, 1)
    np.testing.assert_array_equal(n.origin.m1[:, :, 0], n.phi.m0)
    assert beam.node(1860).AP.structure == 4
    assert np.array_equal(beam["Me"].m0, np.eye(11))
    assert beam["Ct"].structure == 0 and not np.any(beam["Ct"].m0)
    J = beam.J
    assert J.m0[0, 2] == J.m0[2, 0] == 4.32576496834e-06        # J row 5 = xz
    assert J.m1[1, 0, 2] == 8.61794476132e-04                   # J m1( 6, 1, 1) = yz


def test_beam_conventions_consistent(beam):
    """The file's blocks obey the identities of equations.md §2 under the documented layouts:
    J¹_k = sym(Gr_k) (Gr = [Gr_1|…|Gr_nq]), Oe⁰ = −½ J¹ in the column order
    ωx², ωy², ωz², ωxωy, ωyωz, ωxωz, and Cr¹ antisymmetric in (row, mode)."""
    nq = beam.nq
    J1 = beam.J.m1.transpose(1, 0, 2)
    Gr = beam["Gr"].m0.reshape(3, nq, 3).transpose(1, 0, 2)
    np.testing.assert_allclose(J1, 0.5 * (Gr + Gr.transpose(0, 2, 1)), atol=1e-10)
    Oe0 = beam["Oe"].m0
    pred = -np.stack([J1[:, 0, 0] / 2, J1[:, 1, 1] / 2, J1[:, 2, 2] / 2,
                      J1[:, 0, 1], J1[:, 1, 2], J1[:, 0, 2]], axis=1)
    np.testing.assert_allclose(Oe0, pred, atol=1e-10)
    Cr1 = beam["Cr"].m1
    np.testing.assert_allclose(Cr1, -Cr1.transpose(1, 0, 2), atol=1e-12)


def test_roundtrip_exact(beam, tmp_path):
    """read → write → read reproduces every number and name exactly."""
    out = tmp_path / "beam2.SID_FEM"
    write_sid(beam, out)
    again = read_sid(out)
    assert again.ielastq == beam.ielastq and again.mass == beam.mass
    assert list(again.taylors) == list(beam.taylors)
    for name, t in beam.taylors.items():
        u = again[name]
        assert (u.order, u.nrow, u.ncol, u.nq, u.structure) == \
            (t.order, t.nrow, t.ncol, t.nq, t.structure), name
        assert t.equals(u), name
    for a, b in zip(beam.nodes, again.nodes, strict=True):
        assert a.id == b.id and a.rframe == b.rframe
        for name in ("origin", "phi", "psi", "AP"):
            assert getattr(a, name).equals(getattr(b, name)), (a.id, name)
    write_sid(again, tmp_path / "beam3.SID_FEM")
    assert (tmp_path / "beam3.SID_FEM").read_text() == out.read_text()


# ----------------------------------------------------------------------- malformed files
def _broken(tmp_path, edit) -> Path:
    lines = BEAM.read_text().splitlines()
    lines = edit(lines)
    p = tmp_path / "broken.SID_FEM"
    p.write_text("\n".join(lines) + "\n")
    return p


def test_syntax_error_names_line(tmp_path):
    def edit(lines):
        lines[870 - 1] = "           J ( oops"
        return lines
    with pytest.raises(DataError) as exc:
        read_sid(_broken(tmp_path, edit))
    assert exc.value.line == 870 and "syntax" in exc.value.message
    assert "broken.SID_FEM:870" in str(exc.value)


def test_bad_number_names_line(tmp_path):
    def edit(lines):
        lines[5 - 1] = lines[5 - 1].replace("1.25604000000D+01", "1.2.5D+01")
        return lines
    with pytest.raises(DataError) as exc:
        read_sid(_broken(tmp_path, edit))
    assert exc.value.line == 5 and exc.value.item == "part.modal.refmod"


def test_size_mismatch_names_line(tmp_path):
    """Ke with nrow 10 although nelastq = 11: the nrow line is named."""
    def edit(lines):
        assert "nrow" in lines[2625 - 1]
        lines[2625 - 1] = lines[2625 - 1].replace("11", "10")
        return lines
    with pytest.raises(DataError) as exc:
        read_sid(_broken(tmp_path, edit))
    assert exc.value.line == 2625 and exc.value.item == "part.modal.Ke"
    assert "nrow = 10" in exc.value.message


@pytest.mark.parametrize("nq,ok", [("10", False), ("12", False), ("0", True)])
def test_order0_nq_must_be_nelastq_or_zero(tmp_path, nq, ok):
    """Ke (order 0) declaring nq = 10 or 12 while nelastq = 11 names the nq line; nq = 0
    (no q-dependence, as some exporters write order-0 objects) is accepted."""
    def edit(lines):
        assert lines[2623 - 1].strip() == "Ke" and "nq " in lines[2627 - 1]
        lines[2627 - 1] = lines[2627 - 1].replace("11", nq)
        return lines
    path = _broken(tmp_path, edit)
    if ok:
        assert read_sid(path)["Ke"].m0.shape == (11, 11)
        return
    with pytest.raises(DataError) as exc:
        read_sid(path)
    assert exc.value.line == 2627 and exc.value.item == "part.modal.Ke"
    assert f"nq = {nq} but nelastq = 11" in exc.value.message


def test_entry_out_of_range_names_line(tmp_path):
    def edit(lines):
        lines[29 - 1] = lines[29 - 1].replace("m0( 3, 1)", "m0( 4, 1)")
        return lines
    with pytest.raises(DataError) as exc:
        read_sid(_broken(tmp_path, edit))
    assert exc.value.line == 29 and exc.value.item == "part.modal.frame.node[1860].origin"


def test_missing_end_names_line(tmp_path):
    """A missing 'end origin' is found at the 'end node' that closes the wrong block."""
    def edit(lines):
        assert lines[100 - 1].strip() == "end origin"
        del lines[100 - 1]
        return lines
    with pytest.raises(DataError) as exc:
        read_sid(_broken(tmp_path, edit))
    assert "missing 'end origin'" in exc.value.message
    assert "opened at line 58" in exc.value.message
    assert exc.value.line is not None


def test_missing_end_at_eof(tmp_path):
    def edit(lines):
        return lines[:-1]                                   # drop 'end part'
    with pytest.raises(DataError) as exc:
        read_sid(_broken(tmp_path, edit))
    assert "missing 'end part'" in exc.value.message and exc.value.line == 2881


def test_mode_count_mismatch(tmp_path):
    """nelastq changed: the first Taylor object of order 1 reports nq ≠ nelastq."""
    def edit(lines):
        lines[6 - 1] = lines[6 - 1].replace("11", "10")
        return lines
    with pytest.raises(DataError) as exc:
        read_sid(_broken(tmp_path, edit))
    assert exc.value.line == 6 and "nelastq = 10" in exc.value.message


def test_not_a_file(tmp_path):
    with pytest.raises(DataError, match="cannot read"):
        read_sid(tmp_path / "nope.SID_FEM")
    p = tmp_path / "empty.SID_FEM"
    p.write_text("hello\n")
    with pytest.raises(DataError, match="no 'part'"):
        read_sid(p)


SMALL = """\
    1\t\t   2    :No. nodes, No. modes: hand-written variant
 part
      new modal =
           refmod
                mass = 2.0D+00
                nelastq = 2
                ielastq (   1) =first : 1.0 Hz
                ielastq (   2) =second : 2.0 Hz
           end refmod
           new frame
                new node = 7
                     rframe = body ref
                     origin
                          order = 0
                          nrow = 3
                          ncol = 1
                          nq = 2
                          nqn = 0
                          structure = 3
                          m0( 1, 1) = 5.0D-01
                     end origin
                     phi
                          order = 0
                          nrow = 3
                          ncol = 2
                          nq = 2
                          nqn = 0
                          structure = 3
                          m0( 3, 2) = 1.0E+00
                     end phi
                end node
           end frame
           J
                          order = 1
                          nrow = 3
                          ncol = 3
                          nq = 2
                          nqn = 0
                          structure = 2
                          m0( 1, 1) = 1.0D+00
                          m0( 2, 1) = 0.25D+00
                          m1( 3, 2, 1) = 3.0D+00
           end J
           Me
                          order = 0
                          nrow = 2
                          ncol = 2
                          nq = 0
                          nqn = 0
                          structure = 4
           end Me
           Ke
                          order = 0
                          nrow = 2
                          ncol = 2
                          nq = 2
                          nqn = 0
                          structure = 2
                          m0( 1, 1) = 39.47841760435743
                          m0( 1, 2) = 1.0D-09
                          m0( 2, 1) = 3.0D-09
                          m0( 2, 2) = 157.91367041742973
           end Ke
      end modal
 end part
"""


def test_format_variants(tmp_path):
    """Tabs in the header, 'new frame', J as symmetric 3×3, E and D exponents, both
    triangles of a symmetric block, order-0 origin, missing psi/AP (zero / identity),
    missing body blocks (zero when converted)."""

    p = tmp_path / "small.SID_FEM"
    p.write_text(SMALL)
    body = read_sid(p)
    assert body.nq == 2 and body.ielastq == ("first : 1.0 Hz", "second : 2.0 Hz")
    n = body.node(7)
    assert n.origin.order == 0 and n.phi.m0[2, 1] == 1.0
    assert not np.any(n.psi.m0) and np.array_equal(n.AP.m0, np.eye(3))
    assert body.J.m0[0, 1] == body.J.m0[1, 0] == 0.25
    assert body.J.m1[0, 1, 2] == body.J.m1[2, 1, 0] == 3.0
    assert body["Ke"].m0[0, 1] == body["Ke"].m0[1, 0] == 2.0e-9
    np.testing.assert_allclose(np.sqrt(np.diag(body["Ke"].m0)) / (2 * np.pi),
                               body.frequencies_from_names())
    inv = invariants_from_sid(body)
    assert inv.nq == 2 and not np.any(inv.Oe.m0) and inv.md.order == 1
    write_sid(body, tmp_path / "again.SID_FEM")                  # 12 digits
    again = read_sid(tmp_path / "again.SID_FEM")
    assert again["J"].equals(body["J"]) and again["Ke"].equals(body["Ke"], rtol=1e-11)
    assert not again["Ke"].equals(body["Ke"])
    write_sid(body, tmp_path / "exact.SID_FEM", digits=17)         # lossless
    exact = read_sid(tmp_path / "exact.SID_FEM")
    assert exact["Ke"].equals(body["Ke"]) and exact.node(7).origin.equals(n.origin)


def test_negative_or_non_finite_mass_is_refused(tmp_path):
    """A description refuses a negative mass (model/system.py); so does a SID file
   . Reference: the shipped beam.SID_FEM with its mass edited."""
    text = (Path(__file__).resolve().parents[2] / "data" / "beam.SID_FEM").read_text()
    import re

    for bad, message in (("-1.0", "mass must be positive"), ("nan", "not a finite number")):
        p = tmp_path / "neg.SID_FEM"
        p.write_text(re.sub(r"(?m)^(\s*mass\s*=\s*)\S+", rf"\g<1>{bad}", text, count=1))
        with pytest.raises(DataError, match=message):
            read_sid(p)
