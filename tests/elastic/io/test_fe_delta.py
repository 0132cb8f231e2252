"""FE files stored as the difference from a base file (``neweul_py.elastic.io.fe_delta``).

References: the models written (built in ``fe_builders``), which a delta file must give back
bit for bit; a version-1 file written here with the layout of that version (int64 indices,
``numpy.savez``); the SHA-256 of the base's bytes (``hashlib``). Every bad or hostile delta must
be one ``DataError`` naming the delta (and the base where it is at fault).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil

import numpy as np
import pytest
from fe_builders import duct, piston_duct

from neweul_py.elastic import FEModel, read_fe_model, write_fe_model
from neweul_py.elastic.io.fe_delta import PATCH_POS, PATCH_VAL
from neweul_py.elastic.io.fe_files import fe_arrays, load_fe_arrays
from neweul_py.elastic.io.npz import json_from_uint8, json_to_uint8
from neweul_py.elastic.io.working_point import read_loss, read_static, write_working_point
from neweul_py.errors import DataError


def _bits(a) -> tuple:
    return None if a is None else (a.shape, a.data.tobytes(), a.indices.tolist(),
                                   a.indptr.tolist())


def _assert_identical(a: FEModel, b: FEModel) -> None:
    """Every array bit for bit (``-0.0`` and NaN payloads included), every table equal."""
    for key in ("M", "K", "D", "G"):
        assert _bits(getattr(a, key)) == _bits(getattr(b, key)), key
    assert a.nodes.tobytes() == b.nodes.tobytes()
    assert a.dof_node.tolist() == b.dof_node.tolist()
    assert a.dof_kind.tolist() == b.dof_kind.tolist()
    assert (a.inputs, a.outputs, a.kind, a.density, a.name, a.symmetric,
            a.loss_reference_frequency) == (b.inputs, b.outputs, b.kind, b.density, b.name,
                                            b.symmetric, b.loss_reference_frequency)


def _point(stiffness: float, mass: float = 0.05, zero: float = 0.0) -> FEModel:
    """A 'working point': the piston–duct with another piston; same pattern, the piston's
    entries differ, and the last entry of ``G`` is ``zero`` (``-0.0`` equals ``0.0`` but is
    another bit pattern, which a delta must keep)."""
    fe = piston_duct(stiffness=stiffness, mass=mass, damping=3.0)
    G = fe.K.copy() * 0.01
    G.data[-1] = zero
    return fe.with_(G=G, loss_reference_frequency=300.0)


@pytest.fixture
def pair(tmp_path):
    base, other = _point(2.0e5), _point(3.0e5, 0.07, -0.0)
    write_fe_model(base, tmp_path / "base.npz")
    write_fe_model(other, tmp_path / "delta.npz", base=tmp_path / "base.npz")
    return tmp_path, base, other


def test_round_trip_is_exact_and_small(pair):
    """The delta reads back the model written bit for bit (``-0.0`` included), and holds only
    the entries that differ (a fraction of the complete file)."""
    tmp, base, other = pair
    _assert_identical(read_fe_model(tmp / "delta.npz"), other)
    _assert_identical(read_fe_model(tmp / "base.npz"), base)
    written = fe_arrays(other)  # the arrays of the complete file, meta included
    got = load_fe_arrays(tmp / "delta.npz")
    assert got.keys() == written.keys() and all(
        got[k].dtype == written[k].dtype and got[k].tobytes() == written[k].tobytes()
        for k in got)
    with np.load(tmp / "delta.npz") as z:
        names = set(z.files)
        assert z[PATCH_VAL + "K_data"].size == 1 and z[PATCH_VAL + "M_data"].size == 1
        assert z[PATCH_POS + "loss_G_data"].tolist() == [0, other.G.nnz - 1]
    assert not names & {"K_indices", "nodes", "loss_G_indices", "D_data", "dof_kind"}
    assert os.path.getsize(tmp / "delta.npz") < 0.3 * os.path.getsize(tmp / "base.npz")


def test_writes_are_deterministic(pair):
    """The same model gives the same bytes (no time stamps in the archive)."""
    tmp, base, other = pair
    write_fe_model(other, tmp / "again.npz", base=tmp / "base.npz")
    assert (tmp / "again.npz").read_bytes() == (tmp / "delta.npz").read_bytes()
    write_fe_model(base, tmp / "base2.npz")
    assert (tmp / "base2.npz").read_bytes() == (tmp / "base.npz").read_bytes()


def test_other_patterns_and_dropped_arrays_are_exact(tmp_path):
    """A model of another size (every array differs) and one without ``D`` and ``G`` (the
    base's arrays are dropped) read back exactly as well."""
    write_fe_model(_point(2.0e5), tmp_path / "base.npz")
    for name, fe in (("other.npz", duct(n_el=37)), ("plain.npz", piston_duct())):
        write_fe_model(fe, tmp_path / name, base=tmp_path / "base.npz")
        _assert_identical(read_fe_model(tmp_path / name), fe)


def test_working_point_groups_and_a_sibling_base(tmp_path):
    """The static and loss groups read back exactly from a delta whose base is in a sibling
    directory (``../fem/…``), also after both directories were linked elsewhere (hard links,
    as a rebuild reuses them)."""
    base, other = _point(2.0e5), _point(3.0e5)
    static = {"x": np.linspace(0, 1, other.n_dofs), "dp": np.array(20.0)}
    write_working_point(base, tmp_path / "fem" / "a.npz", base.G, {"f_ref_Hz": 300.0},
                        {"x": np.zeros(base.n_dofs), "dp": np.array(0.0)})
    (tmp_path / "slopes").mkdir()
    write_working_point(other, tmp_path / "slopes" / "b.npz", other.G, {"f_ref_Hz": 300.0},
                        static, base=tmp_path / "fem" / "a.npz")
    meta = json_from_uint8(np.load(tmp_path / "slopes" / "b.npz")["meta"])
    assert meta["base"]["file"] == "../fem/a.npz"
    for d in ("fem", "slopes"):
        (tmp_path / "new" / d).mkdir(parents=True)
        for f in (tmp_path / d).iterdir():
            os.link(f, tmp_path / "new" / d / f.name)
    path = tmp_path / "new" / "slopes" / "b.npz"
    _assert_identical(read_fe_model(path), other)
    got = read_static(path)
    assert got.keys() == static.keys() and all(
        got[k].tobytes() == static[k].tobytes() for k in static)
    g, loss = read_loss(path)
    assert _bits(g) == _bits(other.G) and loss == {"f_ref_Hz": 300.0}


def test_a_changed_or_missing_base_is_refused(pair):
    """A base rewritten with another model, or removed, is one error naming the delta (file)
    and the base (message) — never a model mixed from two files."""
    tmp = pair[0]
    digest = hashlib.sha256((tmp / "base.npz").read_bytes()).hexdigest()
    meta = json_from_uint8(np.load(tmp / "delta.npz")["meta"])
    assert meta["base"]["sha256"] == digest
    write_fe_model(_point(2.5e5), tmp / "base.npz")
    with pytest.raises(DataError, match=r"base\.npz has changed") as exc:
        read_fe_model(tmp / "delta.npz")
    assert exc.value.file == str(tmp / "delta.npz") and exc.value.item == "base"
    (tmp / "base.npz").unlink()
    with pytest.raises(DataError, match=r"base .*base.npz is missing") as exc:
        read_fe_model(tmp / "delta.npz")
    assert exc.value.file == str(tmp / "delta.npz")


def test_a_base_changed_in_place_is_refused_and_reads_do_not_share_arrays(pair):
    """The base's arrays are kept between reads by the SHA-256 of its bytes: one byte of it
    changed in place (same file, same size) is refused, never read from the kept arrays,
    and a model read twice gives arrays that do not share memory."""
    tmp, _, other = pair
    first, second = read_fe_model(tmp / "delta.npz"), read_fe_model(tmp / "delta.npz")
    first.K.data[:] = 0.0
    np.testing.assert_array_equal(second.K.toarray(), other.K.toarray())
    np.testing.assert_array_equal(read_fe_model(tmp / "delta.npz").M.toarray(),
                                  other.M.toarray())
    raw = bytearray((tmp / "base.npz").read_bytes())
    raw[-30] ^= 0x01                  # in the central directory: the same size, other bytes
    with open(tmp / "base.npz", "r+b") as fh:
        fh.write(raw)
    with pytest.raises(DataError, match=r"base\.npz"):
        read_fe_model(tmp / "delta.npz")


def test_a_base_elsewhere_or_a_delta_base_is_refused_when_writing(pair):
    """The base must be complete and in the same or a sibling directory; the file itself
    cannot be its own base."""
    tmp, _, other = pair
    (tmp / "a" / "b").mkdir(parents=True)
    with pytest.raises(DataError, match="sibling directory"):
        write_fe_model(other, tmp / "a" / "b" / "x.npz", base=tmp / "base.npz")
    with pytest.raises(DataError, match="itself a delta"):
        write_fe_model(other, tmp / "x.npz", base=tmp / "delta.npz")
    with pytest.raises(DataError, match="base of itself"):
        write_fe_model(other, tmp / "base.npz", base=tmp / "base.npz")
    with pytest.raises(DataError, match=r"\.npz files only"):
        write_fe_model(piston_duct(), tmp / "x.json", base=tmp / "base.npz")


def test_version_1_files_read_and_newer_ones_are_refused(tmp_path):
    """A file in the layout of version 1 (int64 indices, written by ``numpy.savez``) reads
    unchanged; a file of a newer version is refused, saying so."""
    fe = _point(2.0e5)
    write_fe_model(fe, tmp_path / "new.npz")
    arrays = load_fe_arrays(tmp_path / "new.npz")
    meta = json_from_uint8(arrays["meta"])
    old = {k: (v.astype(np.int64) if k.endswith(("_indices", "_indptr")) else v)
           for k, v in arrays.items()}
    np.savez(tmp_path / "old.npz", **{**old, "meta": json_to_uint8({**meta, "version": 1})})
    _assert_identical(read_fe_model(tmp_path / "old.npz"), fe)
    np.savez(tmp_path / "future.npz", **{**old, "meta": json_to_uint8({**meta, "version": 3})})
    with pytest.raises(DataError, match="newer than this reader") as exc:
        read_fe_model(tmp_path / "future.npz")
    assert exc.value.item == "version"


def _edit(path, meta=None, **arrays):
    """Rewrite the delta ``path`` with its ``base`` record changed by ``meta`` and arrays
    replaced (``None``: removed)."""
    with np.load(path) as z:
        data = {k: z[k] for k in z.files}
    m = json_from_uint8(data["meta"])
    m["base"].update(meta or {})
    data["meta"] = json_to_uint8(m)
    for key, value in arrays.items():
        if value is None:
            data.pop(key, None)
        else:
            data[key] = value
    np.savez(path, **data)


@pytest.mark.parametrize(("meta", "arrays", "item"), [
    ({"file": "/etc/base.npz"}, {}, "meta.base.file"),
    ({"file": "../../base.npz"}, {}, "meta.base.file"),
    ({"file": "sub/base.npz"}, {}, "meta.base.file"),
    ({"file": "base.txt"}, {}, "meta.base.file"),
    ({"file": 3}, {}, "meta.base.file"),
    ({"sha256": "0" * 63}, {}, "meta.base.sha256"),
    ({"drop": "K_data"}, {}, "meta.base.drop"),
    ({"drop": ["nothing"]}, {}, "meta.base.drop"),
    ({"extra": 1}, {}, "meta.base"),
    ({}, {PATCH_POS + "K_data": np.array([10**6])}, "K_data"),
    ({}, {PATCH_POS + "K_data": np.array([-1])}, "K_data"),
    ({}, {PATCH_POS + "K_data": np.array([0.5])}, "K_data"),
    ({}, {PATCH_VAL + "K_data": np.array([1], dtype=np.int32)}, "K_data"),
    ({}, {PATCH_VAL + "K_data": np.array([1.0, 2.0])}, "K_data"),
    ({}, {PATCH_VAL + "K_data": None}, PATCH_VAL + "K_data"),
    ({}, {PATCH_POS + "K_data": None}, PATCH_VAL + "K_data"),
    ({}, {PATCH_POS + "nope": np.array([0]), PATCH_VAL + "nope": np.array([1.0])}, "nope"),
])
def test_a_bad_or_hostile_delta_is_one_error(pair, meta, arrays, item):
    """A base named outside the same or a sibling directory, a malformed hash or drop list,
    patches that do not fit the base's arrays: one ``DataError`` naming the delta and the
    item."""
    tmp = pair[0]
    _edit(tmp / "delta.npz", meta, **arrays)
    with pytest.raises(DataError) as exc:
        read_fe_model(tmp / "delta.npz")
    assert exc.value.file == str(tmp / "delta.npz") and exc.value.item == item


def test_a_delta_base_or_a_version_1_delta_is_refused(pair):
    """A base that is itself a delta (no chains) and a delta claiming version 1 (which had
    no deltas) are one error each."""
    tmp = pair[0]
    shutil.copy(tmp / "delta.npz", tmp / "d2.npz")
    digest = hashlib.sha256((tmp / "delta.npz").read_bytes()).hexdigest()
    _edit(tmp / "d2.npz", {"file": "delta.npz", "sha256": digest})
    with pytest.raises(DataError, match="itself a delta") as exc:
        read_fe_model(tmp / "d2.npz")
    assert exc.value.file == str(tmp / "delta.npz")
    with np.load(tmp / "delta.npz") as z:
        data = {k: z[k] for k in z.files}
    data["meta"] = json_to_uint8({**json.loads(data["meta"].tobytes()), "version": 1})
    np.savez(tmp / "v1.npz", **data)
    with pytest.raises(DataError, match="needs version 2") as exc:
        read_fe_model(tmp / "v1.npz")
    assert exc.value.item == "meta.base"
