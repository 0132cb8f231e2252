"""Loss factors of FE models and reduced bodies (docs/equations.md §1.1): the hysteretic
matrix ``G`` of ``K + iG`` read from an FE file's loss group, projected two-sidedly like
``K`` into reduced and parametric bodies (``Le.m0`` of the invariants), and the frequency
responses in the loss-factor form, on a lossy version of the ``examples/elastic_up_body``
piston–duct u–p model."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sps
import scipy.sparse.linalg as spla
from lossy_duct import EXAMPLE, F_REF, lossy_duct, make_fe

from neweul_py import api
from neweul_py.analysis import linearize
from neweul_py.analysis.frf import frequency_response
from neweul_py.analysis.module import as_model
from neweul_py.cli import main
from neweul_py.elastic import read_fe_model, write_fe_model
from neweul_py.elastic.io.body_files import load_reduced_body
from neweul_py.elastic.parametric.samples import stacked_loss
from neweul_py.elastic.parametric.snapshot_basis import basis_parametric_body
from neweul_py.elastic.quality.measures import frf_full, frf_reduced
from neweul_py.elastic.reductors.modal import reduce_modal
from neweul_py.errors import DataError, NeweulError

M2, K2, D2, ETA2 = 0.02, 5.0e4, 2.0, 0.1


@pytest.fixture(scope="module")
def reduced(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("lossy")
    write_fe_model(lossy_duct(), d / "duct.npz")
    assert main(["reduce", str(d / "duct.npz"), "--two-sided", "--modes", "12",
                 "--keep-nodes", "1", "--invariants", "-o", str(d / "body.npz")]) == 0
    return d


def test_fe_file_round_trip_of_the_loss_group(tmp_path: Path) -> None:
    """Reference: the arrays written (``G`` bit for bit, ``f_ref``); the file's ``D`` is
    ``G/ω_ref`` (so nothing is added when the body is reduced)."""
    fe = lossy_duct()
    write_fe_model(fe, tmp_path / "duct.npz")
    back = read_fe_model(tmp_path / "duct.npz")
    assert (back.G != fe.G).nnz == 0 and back.loss_reference_frequency == F_REF
    assert abs(back.D - back.G / (2 * np.pi * F_REF)).max() == 0.0


def test_reduced_body_projects_g_like_k(reduced: Path) -> None:
    """Reference: the two-sided projection ``Wᵀ G V`` with the body's stored bases; ``D``
    stays the projection of the FE model's own ``D`` (= ``G_r/ω_ref`` here), the invariants
    carry ``Le.m0`` and ``loss.f_ref`` (stored once, as the body's ``G``)."""
    body = load_reduced_body(reduced / "body.npz")
    fe = read_fe_model(reduced / "duct.npz")
    assert body.loss_reference_frequency == F_REF
    w_ref = 2 * np.pi * F_REF
    assert np.allclose(body.D, body.G / w_ref, rtol=1e-12, atol=1e-12 * np.abs(body.D).max())
    assert np.array_equal(body.invariants["Le.m0"], body.G)
    assert float(body.invariants["loss.f_ref"]) == F_REF
    full = reduce_modal(fe, modes=12, two_sided=True, store_bases=True)
    assert np.allclose(full.G, full.W.T @ (fe.G @ full.V), rtol=1e-12,
                       atol=1e-12 * np.abs(full.G).max())
    assert np.allclose(full.K, full.W.T @ (fe.K @ full.V), rtol=1e-12,
                       atol=1e-12 * np.abs(full.K).max())


def test_reduced_body_frf_against_the_unreduced_fe_model_with_k_plus_ig(
        reduced: Path, tmp_path: Path) -> None:
    """Reference: the unreduced FE model solved as ``K + iG − ω²M`` (= ``K + iG + jω(D −
    G/ω_ref) − ω²M``) by SciPy's sparse direct solver, one frequency at a time: the reduced
    body alone (12 modes, below the retained band) matches it to the accuracy the same
    reduction has on the lossless model against its own unreduced FE model; the FE-side
    solvers (direct, checked sweep) equal the reference, the viscous form does not."""
    fe = read_fe_model(reduced / "duct.npz")
    body = load_reduced_body(reduced / "body.npz")
    write_fe_model(make_fe().piston_duct(), tmp_path / "plain.npz")
    assert main(["reduce", str(tmp_path / "plain.npz"), "--two-sided", "--modes", "12",
                 "--keep-nodes", "1", "-o", str(tmp_path / "plain_body.npz")]) == 0
    plain, plain_body = read_fe_model(tmp_path / "plain.npz"), load_reduced_body(
        tmp_path / "plain_body.npz")
    f = np.linspace(20.0, 900.0, 23)
    w = 2 * np.pi * f
    b = fe.B("force")[:, 0]
    c = fe.C("x_piston")[0]

    def exact(K):
        return np.array([c @ spla.spsolve(sps.csc_matrix(K - wi**2 * fe.M), b) for wi in w])

    ref = exact(fe.K + 1j * fe.G)
    err = np.abs(frf_reduced(body, f, "force", "x_piston")[:, 0, 0] / ref - 1)
    err0 = np.abs(frf_reduced(plain_body, f, "force", "x_piston")[:, 0, 0]
                  / exact(plain.K) - 1)
    assert np.median(err) < 0.03 and np.median(err) < 1.5 * np.median(err0)
    full = frf_full(fe, f, "force", "x_piston", method="direct")[:, 0, 0]
    assert np.allclose(full, ref, rtol=1e-10)
    visc = frf_full(fe, f, "force", "x_piston", method="direct", damping="viscous")[:, 0, 0]
    assert np.max(np.abs(visc / ref - 1)) > 1e-2
    sweep = frf_full(fe, f, "force", "x_piston", method="sweep")[:, 0, 0]
    assert np.allclose(sweep, ref, rtol=1e-6)


def test_embs_with_a_lossy_body_and_a_lossy_bushing(reduced: Path, tmp_path: Path) -> None:
    """Reference: the unreduced FE model with the same bushing ``k₂(1 + iη₂)``, damper and
    mass assembled directly and solved with ``K + iG`` by SciPy's sparse solver — the
    generated EMBS (body ``Le`` + bushing loss factor through ``loss_matrix``) matches it to
    the reduction's accuracy (the lossless example's bounds: max < 3 %, median < 1e-3), and
    the viscous form does not."""
    for name in ("duct.npz", "body.npz"):
        shutil.copy(reduced / name, tmp_path / name)
    text = (EXAMPLE / "model.yaml").read_text()
    text = text.replace("parameters: {m2: 0.02, k2: 5.0e4, d2: 2.0}",
                        f"loss_reference_frequency: {F_REF}\n"
                        f"parameters: {{m2: {M2}, k2: {K2}, d2: {D2}, eta2: {ETA2}}}")
    text = text.replace("    damping: {diag: [d2, 0, 0]}\n",
                        "    damping: {diag: [d2, 0, 0]}\n    loss_factor: eta2\n")
    assert "loss_factor: eta2" in text
    (tmp_path / "model.yaml").write_text(text)
    mod = as_model(api.generate(tmp_path / "model.yaml", tmp_path / "gen"))
    fe = read_fe_model(tmp_path / "duct.npz")
    n = fe.n_dofs
    M = sps.block_diag([fe.M, sps.csr_matrix([[M2]])]).tolil()
    K = sps.block_diag([fe.K + 1j * fe.G, sps.csr_matrix([[0.0]])]).tolil()
    D = sps.lil_matrix((n + 1, n + 1))
    for A, cval in ((K, K2 * (1 + 1j * ETA2)), (D, D2)):
        A[0, 0] += cval
        A[n, n] += cval
        A[0, n] -= cval
        A[n, 0] -= cval
    rhs = np.zeros(n + 1)
    rhs[n] = 1.0
    f = np.linspace(20.0, 900.0, 45)
    w = 2 * np.pi * f
    ref = np.array([spla.spsolve(sps.csc_matrix(K - wi**2 * M + 1j * wi * D), rhs)[n]
                    for wi in w])
    lin = linearize(mod)
    assert lin.G is not None and lin.loss_reference_frequency == F_REF
    err = np.abs(frequency_response(lin, f, "F", "mass_x").H[:, 0, 0] / ref - 1)
    assert err.max() < 0.03 and np.median(err) < 1e-3
    visc = frequency_response(lin, f, "F", "mass_x", damping="viscous").H[:, 0, 0]
    assert np.median(np.abs(visc / ref - 1)) > 10 * np.median(err)


def test_compare_frf_and_frf_body_commands_use_the_loss_form(reduced: Path, capsys) -> None:
    """Reference: :func:`frf_full` and :func:`frf_reduced` above (the loss form on both
    sides); ``--damping viscous`` changes the answer."""
    args = ["compare-frf", str(reduced / "duct.npz"), str(reduced / "body.npz"), "--input",
            "force", "--response", "x_piston", "--f", "20:400:20", "-q", "--full-method",
            "direct"]
    assert main(args) == 0
    loss = capsys.readouterr().out
    assert main([*args, "--damping", "viscous"]) == 0
    assert capsys.readouterr().out != loss
    out = reduced / "body_frf.csv"
    assert main(["frf-body", str(reduced / "body.npz"), "--input", "force", "--response",
                 "x_piston", "--f", "20:400:5", "-o", str(out)]) == 0
    data = np.genfromtxt(out, delimiter=",", names=True)
    H = data["x_piston_real"] + 1j * data["x_piston_imag"]
    body = load_reduced_body(reduced / "body.npz")
    assert np.allclose(H, frf_reduced(body, data["frequency_hz"], "force", "x_piston")[:, 0, 0],
                       rtol=1e-12)


def test_parametric_body_interpolates_g(reduced: Path) -> None:
    """Reference: at a sample the parametric body returns that sample's ``G`` bit for bit,
    between two samples the weighted sum (linear weights); the invariants of every sample
    carry ``Le.m0``."""
    fe = read_fe_model(reduced / "duct.npz")
    fe2 = fe.with_(G=2 * fe.G, D=2 * fe.D)
    V = np.linalg.qr(np.random.default_rng(0).normal(size=(fe.n_dofs, 6)))[0]
    pb = basis_parametric_body([fe, fe2], V, [0.0, 1.0], parameter="s",
                               interpolation="linear", keep_nodes=[1])
    assert pb.loss_reference_frequency == F_REF and pb.G.shape == (2, 6, 6)
    assert np.allclose(pb.G[0], V.T @ (fe.G @ V), rtol=1e-12)
    assert np.allclose(pb.G[1], V.T @ (fe2.G @ V), rtol=1e-12)
    assert np.array_equal(pb.at(0.0).G, pb.G[0])
    assert np.allclose(pb.at(0.25).G, 0.75 * pb.G[0] + 0.25 * pb.G[1], rtol=1e-12)
    assert np.array_equal(pb.invariants["Le.m0"], pb.G)


def test_samples_with_different_loss_reference_frequencies_are_refused(reduced: Path) -> None:
    """Reference: one reference frequency per body (and per model): the error names the key."""
    body = load_reduced_body(reduced / "body.npz")
    other = body.with_(loss_reference_frequency=500.0)
    with pytest.raises(DataError) as exc:
        stacked_loss([body, other])
    assert exc.value.item == "loss_reference_frequency"
    with pytest.raises(DataError) as exc:
        stacked_loss([body, body.with_(G=None, loss_reference_frequency=None)])
    assert exc.value.item == "G"


def test_model_with_another_reference_frequency_than_its_body_is_refused(
        reduced: Path, tmp_path: Path) -> None:
    """Reference: the rule of docs/description-format.md — one loss reference frequency per
    model; a body whose data hold another is one error naming the body."""
    shutil.copy(reduced / "body.npz", tmp_path / "body.npz")
    text = (EXAMPLE / "model.yaml").read_text()
    (tmp_path / "model.yaml").write_text("loss_reference_frequency: 1000\n" + text)
    with pytest.raises(NeweulError, match=r"elastic_bodies\.duct.*300 Hz.*1000 Hz"):
        api.generate(tmp_path / "model.yaml", tmp_path / "gen")
    (tmp_path / "default.yaml").write_text(text)      # the default, 1000 Hz, differs too
    with pytest.raises(NeweulError, match="loss_reference_frequency"):
        api.generate(tmp_path / "default.yaml", tmp_path / "gen")


def test_nearly_equal_reference_frequencies_are_printed_apart(reduced: Path) -> None:
    """A body whose ``loss.f_ref`` is 1000.0000000000001 Hz (one ulp above the model's
    1000 Hz) is refused with both values printed to the digits that tell them apart (it
    said "1000 Hz … is 1000 Hz"). Reference: the two floats given."""
    from neweul_py.elastic.io.reader import read_elastic_data
    from neweul_py.errors import ModelError
    from neweul_py.model import ElasticBody, System

    data = read_elastic_data(reduced / "body.npz", None)
    data["loss.f_ref"] = np.array(np.nextafter(1000.0, 2000.0))
    body = ElasticBody("duct", "ISYS", data)
    with pytest.raises(ModelError, match=r"f_ref = 1000\.0000000000001 Hz, the model's "
                       r"loss_reference_frequency is 1000 Hz") as exc:
        System(name="nearly", elastic_bodies=(body,), loss_reference_frequency=1000.0)
    assert exc.value.key_path == "elastic_bodies.duct"
