"""The data file of a generated module with elastic bodies (neweul_py/ffrf/data_file.py).

References: ``numpy.load`` (the file is a plain ``.npz`` whose arrays must read back equal to
those written), the zip format's central directory (the offsets of the members), the body
data the model was built from (the module's arrays come from the file, not from its text), and
the module's own evaluation before a file was touched (a changed file must be refused, not
evaluated).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from fe_builders import piston_duct

from neweul_py.analysis import load_generated
from neweul_py.api import generate
from neweul_py.elastic import reduce_modal
from neweul_py.elastic.io.body_files import save_parametric_body
from neweul_py.elastic.parametric.local_interpolation import interpolate
from neweul_py.elastic.reductors.invariants import attach_invariants
from neweul_py.errors import NeweulError
from neweul_py.ffrf.data_file import (
    ALIGN,
    ArrayStore,
    data_file_bytes,
    ffrf_decode,
    ffrf_encode,
    ffrf_members,
    ffrf_restore,
    ffrf_split,
    schema_of,
)

DESCRIPTION = """
name: scheduled_duct
parameters: {cs: 343.0, m2: 0.02, k2: 1.0e5}
coordinates: {z: {}}
frames:
  carrier: {translation: [z, 0, 0]}
elastic_bodies:
  duct: {frame: ISYS, data: duct.npz, nodes: {piston: 1}, schedule: cs}
bodies:
  mass: {frame: carrier, mass: m2}
forces:
  link:
    type: bushing
    between: [duct.piston, carrier]
    stiffness: {diag: [k2, 0, 0]}
"""


def test_bytes_are_deterministic_aligned_and_read_by_numpy(tmp_path: Path) -> None:
    """The same arrays in any insertion order give the same bytes; ``numpy.load`` reads them
    back equal (dtypes and shapes kept, big-endian input stored little-endian), and every
    array's data start at a multiple of 64 bytes of the file."""
    rng = np.random.default_rng(0)
    arrays = {
        "b/x": rng.normal(size=(7, 5)),
        "a": np.arange(11, dtype=np.int64),
        "b/empty": np.zeros((0, 3)),
        "c": rng.normal(size=4).astype(">f8"),
        "d": np.array(2.5),
    }
    raw = data_file_bytes(arrays)
    assert data_file_bytes(dict(reversed(list(arrays.items())))) == raw
    (tmp_path / "f.npz").write_bytes(raw)
    with np.load(tmp_path / "f.npz") as z:
        assert sorted(z.files) == sorted(arrays)
        for key, arr in arrays.items():
            assert z[key].shape == arr.shape
            np.testing.assert_array_equal(z[key], arr)
    members = ffrf_members(raw)
    for key, arr in arrays.items():
        offset, _size = members[f"{key}.npy"]
        header_len = int.from_bytes(raw[offset + 8 : offset + 10], "little")
        assert (offset + 10 + header_len) % ALIGN == 0
        little = arr.astype(arr.dtype.newbyteorder("<"))
        assert raw[offset + 10 + header_len :][: arr.nbytes] == little.tobytes()


def test_split_and_restore_keep_the_structure_and_store_equal_arrays_once() -> None:
    """Nested dicts, lists and tuples come back as they were; an array equal to one already
    stored is referenced by its key (reference: the original structure)."""
    a = np.arange(6.0).reshape(2, 3)
    tree = {"x": a, "y": [a.copy(), (1, 2.5, "s", None)], "z": {"w": np.ones(2), "n": np.int64(3)}}
    store = ArrayStore()
    skeleton = ffrf_split(tree, "body", store)
    assert sorted(store.arrays) == ["body/x", "body/z/w"]
    assert skeleton["y"][0] == {"@": "body/x"} and skeleton["z"]["n"] == 3
    back = ffrf_restore(skeleton, store.arrays)
    np.testing.assert_array_equal(back["y"][0], a)
    assert back["y"][1] == (1, 2.5, "s", None)
    with pytest.raises(TypeError, match="body/f"):
        ffrf_split({"f": object()}, "body", ArrayStore())


@pytest.fixture(scope="module")
def scheduled(tmp_path_factory) -> tuple[Path, Path]:
    """A scheduled piston-duct body (two-sided, 6 modes, three sound speeds) on ISYS with a
    rigid mass on its node, generated into ``gen/``."""
    tmp = tmp_path_factory.mktemp("datafile")
    bodies = []
    for c in (300.0, 343.0, 390.0):
        fe = piston_duct(n_el=40, c=c)
        body = reduce_modal(fe, modes=6, two_sided=True, keep_nodes=[1], store_bases=True)
        bodies.append(attach_invariants(body, fe, nodes=[1]))
    save_parametric_body(
        interpolate(bodies, [300.0, 343.0, 390.0], parameter="c"), tmp / "duct.npz"
    )
    (tmp / "model.yaml").write_text(DESCRIPTION)
    return tmp, generate(tmp / "model.yaml", tmp / "gen")


def _data_file(module: Path) -> Path:
    files = [p for p in module.parent.iterdir() if p.suffix == ".npz"]
    assert len(files) == 1
    return files[0]


def test_module_names_its_data_file_and_regenerates_both_byte_identically(scheduled) -> None:
    """The module text holds no array literal (base64 or otherwise: it is far smaller than
    the arrays it uses) and names the one data file next to it with its SHA-256;
    regenerating writes the same bytes to both (reference: the first generation)."""
    tmp, path = scheduled
    data = _data_file(path)
    text = path.read_text()
    import hashlib

    digest = hashlib.sha256(data.read_bytes()).hexdigest()
    assert f"_DATA_FILE = {data.name!r}" in text and f"_DATA_SHA256 = {digest!r}" in text
    assert data.name == f"scheduled_duct.{digest[:16]}.npz"
    assert "base64" not in text and "zlib" not in text
    with np.load(data) as z:
        assert "duct/mixing/varying" in z.files and z["duct/mixing/varying"].shape[0] == 3
    first = (path.read_bytes(), data.read_bytes())
    again = generate(tmp / "model.yaml", tmp / "gen2")
    assert (again.read_bytes(), _data_file(again).read_bytes()) == first


def _copy(scheduled, tmp_path: Path) -> tuple[Path, Path]:
    _tmp, path = scheduled
    shutil.copy(path, tmp_path / path.name)
    shutil.copy(_data_file(path), tmp_path / _data_file(path).name)
    return tmp_path / path.name, tmp_path / _data_file(path).name


def test_module_evaluates_from_its_data_file(scheduled, tmp_path: Path) -> None:
    """Copied with its data file to another directory, the module loads and gives the
    same rhs (reference: the module where it was generated)."""
    _tmp, path = scheduled
    ref = load_generated(path)
    moved, _data = _copy(scheduled, tmp_path)
    x = 1e-4 * np.arange(ref.STATE_SIZE)
    p = ref.default_parameters()
    np.testing.assert_array_equal(load_generated(moved).rhs(0.0, x, p), ref.rhs(0.0, x, p))


def _refused(module: Path, *words: str) -> None:
    import sys

    for name in [n for n in sys.modules if n.startswith("neweul_generated_scheduled_duct")]:
        del sys.modules[name]  # the same module text, imported before with its data
    with pytest.raises(NeweulError) as info:
        load_generated(module)
    message = str(info.value)
    assert message.count("\n") == 0, message
    for w in words:
        assert w in message, message


def test_changed_data_file_is_refused_naming_body_file_and_array(scheduled, tmp_path: Path) -> None:
    """One value of the stacked samples changed after generation: the import fails with one
    line naming the body, the file and the array (reference: the schema's per-array
    digests, which the changed array no longer matches)."""
    module, data = _copy(scheduled, tmp_path)
    raw = bytearray(data.read_bytes())
    offset, _size = ffrf_members(bytes(raw))["duct/mixing/varying.npy"]
    header_len = int.from_bytes(raw[offset + 8 : offset + 10], "little")
    raw[offset + 10 + header_len + 3] ^= 0x40
    data.write_bytes(bytes(raw))
    _refused(
        module,
        "elastic body 'duct'",
        str(data),
        "changed after generation",
        "'duct/mixing/varying'",
        "holds other values",
    )


def test_missing_data_file_is_refused(scheduled, tmp_path: Path) -> None:
    """The module without its data file: one line naming the body and the missing file."""
    module, data = _copy(scheduled, tmp_path)
    data.unlink()
    _refused(module, "elastic body 'duct'", str(data), "is missing")


def test_a_data_file_that_is_no_regular_file_is_refused(scheduled, tmp_path: Path) -> None:
    """A FIFO in place of the data file: one line at once (opening it would block until a
    writer came), not a hang."""
    module, data = _copy(scheduled, tmp_path)
    data.unlink()
    os.mkfifo(data)
    _refused(module, "elastic body 'duct'", str(data), "is not a regular file")


def test_a_huge_data_file_is_refused_before_it_is_hashed(scheduled, tmp_path: Path) -> None:
    """A sparse file of 8 GB in place of the data file: refused by its size, which the
    schema bounds (the arrays' bytes with their headers), not after hashing 8 GB."""
    module, data = _copy(scheduled, tmp_path)
    data.unlink()
    with open(data, "wb") as fh:
        fh.truncate(8 << 30)
    _refused(module, "elastic body 'duct'", str(data), "is not the data file of this module",
             "8589934592 bytes")


def test_a_schedule_leaving_the_samples_during_a_run_is_one_error(scheduled, tmp_path: Path
                                                                   ) -> None:
    """The sound speed ramped past the last sample (390 m/s) while simulating: one
    SolverError naming the schedule value, not the integrator's traceback."""
    from neweul_py.analysis.simulate import simulate
    from neweul_py.errors import SolverError

    tmp, _path = scheduled
    text = (tmp / "model.yaml").read_text()
    assert "schedule: cs}" in text
    (tmp_path / "duct.npz").symlink_to(tmp / "duct.npz")
    (tmp_path / "model.yaml").write_text(text.replace("schedule: cs}",
                                                      "schedule: cs + 1.0e5*t}"))
    mod = load_generated(generate(tmp_path / "model.yaml", tmp_path / "gen"))
    with pytest.raises(SolverError, match="outside the sampled range"):
        simulate(mod, 0.01)


def test_data_file_of_another_schema_is_refused(scheduled, tmp_path: Path) -> None:
    """A data file whose node maps have another shape (as another model's would): one line
    naming what the array belongs to, the file and the shapes (reference: the schema the
    module was generated with)."""
    module, data = _copy(scheduled, tmp_path)
    with np.load(data) as z:
        arrays = {k: z[k] for k in z.files}
    stored = arrays["_splice/SV"].shape        # its nonzeros (ffrf_encode)
    arrays["_splice/SV"] = np.zeros((3, 8))
    data.write_bytes(data_file_bytes(arrays))
    _refused(
        module,
        "the node maps of the elastic body 'duct'",
        str(data),
        "'_splice/SV'",
        f"shape (3, 8), the module expects <f8 and {stored}",
    )


def test_foreign_file_is_refused(scheduled, tmp_path: Path) -> None:
    """A file that is no uncompressed ``.npz`` (here a compressed one with the same arrays)
    under the data file's name: one line saying it is not this module's data file."""
    module, data = _copy(scheduled, tmp_path)
    with np.load(data) as z:
        arrays = {k: z[k] for k in z.files}
    with open(data, "wb") as fh:
        np.savez_compressed(fh, **arrays)
    _refused(module, "elastic body 'duct'", str(data), "not the data file of this module")


def test_schema_names_dtype_shape_and_digest() -> None:
    """``schema_of``: descr, shape and the first 16 hex digits of the SHA-256 of the bytes
    (reference: hashlib on the same bytes)."""
    import hashlib

    a = np.arange(4.0)
    assert schema_of({"k": a}) == {"k": ("<f8", (4,), hashlib.sha256(a.tobytes()).hexdigest()[:16])}


def test_compact_encodings_give_the_arrays_back_bit_for_bit() -> None:
    """``ffrf_encode`` stores a mostly-zero float array as its nonzeros and a mask, 64-bit
    integers that fit as int32, the rest as they are; ``ffrf_decode`` gives every array
    back bit for bit, −0 and NaN included, read-only (reference: the arrays encoded)."""
    sel = np.zeros((40, 30))
    sel[np.arange(30), np.arange(30)] = 1.0
    sel[35, 3], sel[36, 4] = -0.0, np.nan
    arrays = {"S": sel, "i": np.array([0, 7, 2**31 - 1]), "big": np.array([2**31, 0]),
              "dense": np.arange(1.0, 9.0), "u": np.arange(3, dtype=np.uint8),
              "x": np.zeros((4, 4)), "x@nonzero": np.zeros(2)}
    stored, enc = ffrf_encode(arrays)
    assert enc == {"S": ["nonzero", [40, 30]], "i": ["narrow", "<i8"]}
    assert stored["S"].size == 32 and stored["i"].dtype == np.int32
    assert stored["big"].dtype == np.int64 and "x@nonzero" in stored     # left as they are
    back = ffrf_decode(stored, enc)
    assert set(back) == set(arrays)
    for key, a in arrays.items():
        assert back[key].dtype == a.dtype and back[key].tobytes() == a.tobytes(), key
    assert not back["S"].flags.writeable and not back["i"].flags.writeable
