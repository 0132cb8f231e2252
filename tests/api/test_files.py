"""Files validated before use (neweul_py/files.py).

References: POSIX file types (``/dev/zero`` is a character device, ``mkfifo`` makes a FIFO), the
zip format (declared member sizes bound what the reader returns) and the ``.npy`` header.
A FIFO without a writer would block ``open()`` for ever; every check here returns at once.
"""

from __future__ import annotations

import io
import os
import zipfile
from pathlib import Path

import numpy as np
import pytest

from neweul_py import api
from neweul_py.cli import main
from neweul_py.errors import DataError, DescriptionError
from neweul_py.files import (
    MAX_NPZ_RATIO,
    check_npz,
    check_regular_file,
    load_npz,
    read_checked,
    read_text,
)

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))


@pytest.fixture
def fifo(tmp_path):
    path = tmp_path / "pipe"
    os.mkfifo(path)
    return path


def test_special_files_are_refused(tmp_path, fifo):
    with pytest.raises(DataError, match="character device"):
        check_regular_file("/dev/zero")
    with pytest.raises(DataError, match="FIFO"):
        read_checked(fifo)  # non-blocking open: no writer needed
    with pytest.raises(DataError, match="directory"):
        read_checked(tmp_path)
    with pytest.raises(DataError, match="not found"):
        check_regular_file(tmp_path / "absent")


def test_size_cap(tmp_path):
    path = tmp_path / "big.txt"
    path.write_bytes(b"x" * 101)
    with pytest.raises(DataError, match="more than the cap of 100"):
        read_checked(path, max_bytes=100)
    assert read_checked(path, max_bytes=101) == b"x" * 101


@pytest.mark.parametrize("target", ["/dev/zero", "fifo"])
def test_elastic_data_file_of_a_description(tmp_path, capsys, fifo, target):
    """``simulate`` of a description whose ``data:`` is ``/dev/zero`` (reading it whole would fill
    memory) or a FIFO (would hang): one error line."""
    data = "/dev/zero" if target == "/dev/zero" else str(fifo)
    src = tmp_path / "m.yaml"
    src.write_text("name: m\ncoordinates: {x: 0}\nframes: {f: {parent: ISYS, translation: "
                   f"[x, 0, 0]}}}}\nelastic_bodies:\n  beam: {{frame: f, data: '{data}'}}\n")
    for command in (["simulate", str(src), "--t-end", "1"], ["generate", str(src), "-o",
                                                             str(tmp_path / "gen")]):
        assert main(command) == 1
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "not a regular file" in err
        assert "elastic_bodies.beam.data" in err


def test_description_that_is_not_a_file(fifo):
    with pytest.raises(DescriptionError, match="FIFO"):
        api.generated_module(fifo)
    with pytest.raises(DescriptionError, match="character device"):
        api.load_description("/dev/zero")


def _npz(members: dict[str, bytes]) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    return buf.getvalue()


def test_zip_bomb_is_refused_before_decompression(tmp_path):
    """A few kB of deflated zeros declaring 64 MiB: refused from the directory alone."""
    path = tmp_path / "bomb.npz"
    path.write_bytes(_npz({"a.npy": b"\0" * (64 * 2**20)}))
    assert path.stat().st_size < 200_000
    with pytest.raises(DataError, match="more than the cap"):
        check_npz(path, max_bytes=2**20)


def test_forged_array_header_is_refused(tmp_path):
    """An ``.npy`` header claiming 10¹² doubles in a tiny member (np.load would try to
    allocate them)."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": "<f8", "fortran_order": False, "shape": (10**6, 10**6)})
    path = tmp_path / "forged.npz"
    path.write_bytes(_npz({"K.npy": header.getvalue() + b"\0" * 64}))
    with pytest.raises(DataError, match="claims"):
        check_npz(path)
    from neweul_py.elastic.io.npz import load_npz

    with pytest.raises(DataError, match="claims"):
        load_npz(path)


def test_valid_npz_passes(tmp_path):
    path = tmp_path / "ok.npz"
    np.savez(path, a=np.arange(10.0), b=np.eye(3))
    check_npz(path)


def test_zip_bomb_below_the_size_cap_is_refused_by_its_ratio(tmp_path):
    """The bomb of a few hundred kB that inflated past 2 GB was within the 8 GiB size cap;
    its compression ratio (declared size / compressed size, about 1000 for zeros) is not:
    refused from the zip directory, before any member is inflated. Reference: the zip
    directory's sizes, computed here from the bytes written."""
    path = tmp_path / "bomb.npz"
    header = io.BytesIO()
    n = 80 * 2**20 // 8
    np.lib.format.write_array_header_1_0(
        header, {"descr": "<f8", "fortran_order": False, "shape": (n,)})
    path.write_bytes(_npz({"a.npy": header.getvalue() + bytes(8 * n)}))
    info = zipfile.ZipFile(path).infolist()[0]
    assert info.file_size / info.compress_size > MAX_NPZ_RATIO
    with pytest.raises(DataError, match="compression ratio") as exc:
        check_npz(path)
    assert "a.npy" in str(exc.value) and "docs/limits.md" in str(exc.value)
    with pytest.raises(DataError, match="compression ratio"):
        load_npz(path)
    small = tmp_path / "small.npz"        # below the floor, any ratio is fine
    np.savez_compressed(small, z=np.zeros(10_000))
    assert load_npz(small)["z"].shape == (10_000,)


def test_load_npz_checks_the_descriptor_it_reads(tmp_path, fifo):
    """Every check on the one open file: a FIFO, /dev/zero, a file that is not a zip, a
    pickled object array, a forged header — one DataError each; a valid file loads."""
    with pytest.raises(DataError, match="FIFO"):
        load_npz(fifo)
    with pytest.raises(DataError, match="character device"):
        load_npz("/dev/zero")
    (tmp_path / "text.npz").write_text("not a zip")
    with pytest.raises(DataError, match="not a zip archive"):
        load_npz(tmp_path / "text.npz")
    np.savez(tmp_path / "obj.npz", a=np.array([{"x": 1}], dtype=object))
    with pytest.raises(DataError, match=r"pickle|object"):
        load_npz(tmp_path / "obj.npz")
    np.savez(tmp_path / "ok.npz", a=np.arange(3.0), b=np.eye(2))
    arrays = load_npz(tmp_path / "ok.npz")
    assert sorted(arrays) == ["a", "b"] and arrays["b"].shape == (2, 2)


def test_read_text_names_the_first_byte_that_is_not_utf8(tmp_path, fifo):
    """Reference: the UTF-8 decoder's error position."""
    path = tmp_path / "latin1.csv"
    path.write_bytes("t,phi\n0,1\n# caf\u00e9\n".encode("latin-1"))
    with pytest.raises(DataError, match=r"not UTF-8 text \(byte 0xe9 at offset 15, line 3\)"):
        read_text(path, "reference")
    path.write_bytes(b"\xef\xbb\xbft,phi\n")     # a byte-order mark is dropped
    assert read_text(path) == "t,phi\n"
    with pytest.raises(DataError, match="FIFO"):
        read_text(fifo)
