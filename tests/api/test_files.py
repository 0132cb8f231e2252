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
from neweul_py.files import check_npz, check_regular_file, read_checked

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
