"""Reduced-body file: exact round trip, atomic writes, bad files rejected.

Reference: the in-memory body; every array must come back bit for bit (``array_equal``,
same dtype) and the metadata unchanged (docs/reduced-body-format.md).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from body_arrays import explicit_arrays
from fe_builders import piston_duct

from neweul_py.elastic import ReducedBody, reduce_krylov, reduce_modal
from neweul_py.elastic.io.body_files import load_reduced_body, save_reduced_body
from neweul_py.elastic.io.npz import json_to_uint8
from neweul_py.errors import DataError


@pytest.fixture(scope="module")
def body():
    fe = piston_duct(60, damping=2.0)
    inv = {"m": np.array(1.5), "Ct": np.arange(12.0).reshape(6, 2) / 7, "Oe1": np.ones((6, 6, 3)),
           "node_ids": np.array([1, 61], dtype=np.int64)}
    return reduce_modal(fe, modes=6, static_correction=True, store_bases=True).with_(
        invariants=inv, parameters={"tension": 60.0, "thickness": 1e-4})


def _assert_same(a: ReducedBody, b: ReducedBody) -> None:
    for key in ("M", "D", "K", "B", "C", "nodes", "kept_dofs", "dof_node", "dof_kind",
                "V_kept", "W_kept", "V", "W", "eigenvalues", "full_dof_kind"):
        x, y = getattr(a, key), getattr(b, key)
        assert (x is None) == (y is None), key
        if x is not None:
            assert x.dtype == y.dtype and np.array_equal(x, y), key
    for key in ("input_names", "output_names", "method", "settings", "source", "parameters",
                "format_version"):
        assert getattr(a, key) == getattr(b, key), key
    assert (a.invariants is None) == (b.invariants is None)
    if a.invariants is not None:
        assert list(a.invariants) == list(b.invariants)
        for k in a.invariants:
            assert a.invariants[k].dtype == b.invariants[k].dtype
            assert np.array_equal(a.invariants[k], b.invariants[k])


def test_round_trip_is_exact(body, tmp_path):
    path = tmp_path / "b.npz"
    save_reduced_body(body, path)
    _assert_same(body, load_reduced_body(path))


def test_round_trip_without_optional_fields(tmp_path):
    b = reduce_krylov(piston_duct(40), points=[2j * np.pi * 200], order=2)
    assert b.V is None and b.invariants is None and b.eigenvalues is None
    save_reduced_body(b, tmp_path / "k.npz")
    _assert_same(b, load_reduced_body(tmp_path / "k.npz"))


def test_full_dof_kind_is_stored_with_the_full_bases(body, tmp_path):
    """The reductors record the DOF kind of every row of V, W whenever they store them (the
    FE model's DOF map is the reference); without full bases there is none; a file written
    before the field existed (no ``full_dof_kind`` array) still loads, with ``None``."""
    fe = piston_duct(60, damping=2.0)
    assert body.full_dof_kind.dtype == np.dtype("<U2")
    assert np.array_equal(body.full_dof_kind, fe.dof_kind) and body.V.shape[0] == fe.n_dofs
    kr = reduce_krylov(fe, points=[2j * np.pi * 200], order=2, store_bases=True)
    assert np.array_equal(kr.full_dof_kind, fe.dof_kind)
    assert reduce_modal(fe, modes=4).full_dof_kind is None
    assert reduce_krylov(fe, points=[2j * np.pi * 200], order=2).full_dof_kind is None
    path = tmp_path / "b.npz"
    save_reduced_body(body, path)
    data = explicit_arrays(path)
    assert data["full_dof_kind"].dtype == np.dtype("<U2")
    del data["full_dof_kind"]
    np.savez(path, **data)
    old = load_reduced_body(path)
    assert old.full_dof_kind is None and np.array_equal(old.V, body.V)


@pytest.mark.parametrize("kinds,text", [
    (np.array(["ux"] + ["p"] * 60), "61 DOF kinds for the 62 rows of V"),
    (np.array(["ux"] + ["q"] * 61), "unknown DOF kinds"),
    (np.array(["p"] + ["ux"] * 61), "kinds of the kept DOFs differ"),
    (np.arange(62.0), "1-D array of DOF kinds"),
])
def test_bad_full_dof_kind_is_refused(body, kinds, text):
    with pytest.raises(DataError, match=text) as exc:
        body.with_(full_dof_kind=kinds)
    assert exc.value.item == "full_dof_kind"


def test_file_has_no_pickles_and_json_metadata(body, tmp_path):
    path = tmp_path / "b.npz"
    save_reduced_body(body, path)
    with np.load(path, allow_pickle=False) as z:
        meta = json.loads(z["meta"].tobytes().decode())
        assert all(z[k].dtype != object for k in z.files)
    assert meta["format"] == "neweul-reduced-body" and meta["version"] == 2
    assert meta["invariants"] == ["m", "Ct", "Oe1", "node_ids"]


def test_interrupted_write_keeps_the_old_file(body, tmp_path, monkeypatch):
    path = tmp_path / "b.npz"
    save_reduced_body(body, path)
    before = path.read_bytes()

    def boom(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(np, "savez", boom)
    with pytest.raises(KeyboardInterrupt):
        save_reduced_body(body.with_(method="other"), path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["b.npz"]


def _rewrite(path, **changes):
    data = explicit_arrays(path)
    data.update(changes)
    np.savez(path, **data)


@pytest.mark.parametrize("change,item,text", [
    (lambda d: {"meta": json_to_uint8({**d, "format": "x"})}, "meta", "format"),
    (lambda d: {"meta": json_to_uint8({**d, "version": 9})}, "meta", "version"),
    (lambda d: {"meta": np.frombuffer(b"{oops", np.uint8)}, "meta", "JSON"),
    (lambda d: {"D": np.zeros((9, 9))}, "D", "must be"),
    (lambda d: {"K": np.full((9, 9), np.nan)}, "K", "NaN"),
])
def test_bad_files_are_rejected(body, tmp_path, change, item, text):
    path = tmp_path / "b.npz"
    save_reduced_body(body, path)
    meta = json.loads(explicit_arrays(path)["meta"].tobytes().decode())
    changes = change(meta)
    if item == "K":  # right shape, bad values
        changes = {"K": np.full_like(body.K, np.nan)}
    _rewrite(path, **changes)
    with pytest.raises(DataError, match=text) as exc:
        load_reduced_body(path)
    assert exc.value.file == str(path) and exc.value.item == item


@pytest.mark.parametrize(("item", "make", "text"), [
    ("M", lambda a: a.astype(bool), "is bool; the format holds float64"),
    ("M", lambda a: a.astype(np.int64), "is int64; the format holds float64"),
    ("M", lambda a: a.astype(str), "the format holds float64"),
    ("B", lambda a: a.astype(np.float32), "is float32; the format holds float64"),
    ("kept_dofs", lambda a: a.astype(bool), "the format holds integers"),
    ("dof_kind", lambda a: np.zeros(a.shape), "the format holds strings"),
    ("nodes", lambda a: np.zeros((2, 2)), r"must be \(nodes, 4\)"),
])
def test_members_of_another_type_are_refused_not_converted(body, tmp_path, item, make, text):
    """A matrix stored as bools, integers, strings or single precision, DOF numbers as
    bools, DOF kinds as numbers, nodes that are not rows of four: one DataError naming the
    file and the array, where ``numpy.asarray`` would have converted or reshaped them
    (reference: the format's member types, docs/reduced-body-format.md)."""
    path = tmp_path / "b.npz"
    save_reduced_body(body, path)
    data = explicit_arrays(path)
    _rewrite(path, **{item: make(data[item])})
    with pytest.raises(DataError, match=text) as exc:
        load_reduced_body(path)
    assert exc.value.file == str(path) and exc.value.item == item


def test_a_big_endian_file_reads(body, tmp_path):
    """A body file whose numbers are stored big-endian (another writer's ``>f8``, ``>i8``)
    reads as the same body (reference: the body written little-endian)."""
    path = tmp_path / "b.npz"
    save_reduced_body(body, path)
    data = explicit_arrays(path)
    swapped = {k: (v.astype(v.dtype.newbyteorder(">")) if k != "meta" and v.dtype.kind in "fi"
                   else v) for k, v in data.items()}
    assert swapped["M"].dtype.str == ">f8"
    np.savez(path, **swapped)
    back = load_reduced_body(path)
    assert np.array_equal(back.M, body.M) and np.array_equal(back.kept_dofs, body.kept_dofs)


def test_missing_array_and_not_an_npz(body, tmp_path):
    path = tmp_path / "b.npz"
    save_reduced_body(body, path)
    data = explicit_arrays(path)
    del data["C"]
    np.savez(path, **data)
    with pytest.raises(DataError, match="missing arrays") as exc:
        load_reduced_body(path)
    assert exc.value.item == "C"
    path.write_text("hello")
    with pytest.raises(DataError, match="npz"):
        load_reduced_body(path)
    with pytest.raises(DataError, match="not found"):
        load_reduced_body(tmp_path / "none.npz")


def test_object_arrays_are_refused(body, tmp_path):
    path = tmp_path / "b.npz"
    save_reduced_body(body, path)
    _rewrite(path, B=np.array([None, 1], dtype=object))
    with pytest.raises(DataError, match="unreadable array"):
        load_reduced_body(path)
    with pytest.raises(DataError, match="object arrays"):
        body.with_(invariants={"x": np.array([None], dtype=object)})


def test_projected_matrices_are_stored_once_with_the_invariants(tmp_path):
    """A body with invariants stores Me, Ke, De (= Wᵀ M V, Wᵀ K V, Wᵀ D V) once, as the body's
    own M, K, D (the compact layout's ``same``), and reads them back bit for bit (reference:
    the body before saving); the same body in the explicit layout of version 1 reads back
    equal."""
    from neweul_py.elastic.reductors.invariants import attach_invariants

    fe = piston_duct(n_el=40, damping=0.3)
    body = attach_invariants(reduce_modal(fe, modes=6, two_sided=True, keep_nodes=[1],
                                          store_bases=True), fe, nodes=[1])
    path = tmp_path / "b.npz"
    save_reduced_body(body, path)
    with np.load(path) as data:
        assert not any(k in data for k in ("invariants/Me.m0", "invariants/Ke.m0"))
        meta = json.loads(data["meta"].tobytes().decode())
    same = meta["layout"]["same"]
    assert {k: same[k] for k in ("invariants/Me.m0", "invariants/Ke.m0", "invariants/De.m0")
            } == {"invariants/Me.m0": "M", "invariants/Ke.m0": "K", "invariants/De.m0": "D"}
    back = load_reduced_body(path)
    for name, arr in body.invariants.items():
        np.testing.assert_array_equal(back.invariants[name], arr)
    data = explicit_arrays(path)
    data["meta"] = json_to_uint8({**json.loads(data["meta"].tobytes().decode()), "version": 1})
    np.savez(tmp_path / "v1.npz", **data)
    old = load_reduced_body(tmp_path / "v1.npz")
    for name, arr in body.invariants.items():
        np.testing.assert_array_equal(old.invariants[name], arr)


@pytest.mark.parametrize(("item", "change", "text"), [
    ("nodes", lambda b: {"nodes": np.where(np.arange(b.nodes.size).reshape(b.nodes.shape) == 1,
                                           np.nan, b.nodes)}, "NaN"),
    ("nodes", lambda b: {"nodes": np.column_stack([-b.nodes[:, :1], b.nodes[:, 1:]])},
     "non-negative whole numbers"),
    ("nodes", lambda b: {"nodes": np.column_stack([b.nodes[:, :1] + 0.5, b.nodes[:, 1:]])},
     "non-negative whole numbers"),
    ("dof_node", lambda b: {"dof_node": -b.dof_node}, "non-negative"),
    ("M", lambda b: {"M": b.M + 1e-3j * np.eye(len(b.M))}, "complex"),
    ("V", lambda b: {"V": b.V * (1 + 0j) + 1j}, "complex"),
    ("V", lambda b: {"V": np.where(b.V == b.V.max(), np.inf, b.V)}, "NaN/Inf"),
    ("eigenvalues", lambda b: {"eigenvalues": np.where(np.arange(b.eigenvalues.size) == 0, -1e6,
                                                       b.eigenvalues)}, "negative"),
    ("eigenvalues", lambda b: {"eigenvalues": b.eigenvalues * np.nan}, "NaN/Inf"),
])
def test_bodies_that_cannot_be_physical_are_refused(body, tmp_path, item, change, text):
    """A reduced body with NaN in its nodes or bases, negative or fractional node ids, complex
    matrices or bases (float64 by the format: their imaginary part was dropped) or a negative
    eigenvalue λ = ω² (beyond round-off: an unstable body) was loaded silently; each is one
    DataError naming the file and the array. ``M`` need not be symmetric (two-sided and u–p
    coupled bodies are not; docs/reduced-body-format.md), so that is no rule. Reference: the
    documented format."""
    path = tmp_path / "b.npz"
    save_reduced_body(body, path)
    _rewrite(path, **change(body))
    with pytest.raises(DataError, match=text) as exc:
        load_reduced_body(path)
    assert exc.value.file == str(path) and exc.value.item == item
    unsymmetric = body.with_(M=body.M + np.triu(np.full_like(body.M, 1e-3), 1))
    assert not np.allclose(unsymmetric.M, unsymmetric.M.T)      # accepted, as documented
