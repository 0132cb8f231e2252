"""Bounded reading of FE-model files (neweul_py/elastic/io/fe_files.py).

References: the Matrix Market format (header ``rows cols entries``; each entry is a line of at
least ``"i j\\n"``), a 1e9×1e9 header with one entry (which once ended in a
MemoryError), and the FE model the files were written from (a valid file reads back equal).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from fe_builders import piston_duct

from neweul_py.elastic import read_fe_model, write_fe_model
from neweul_py.errors import DataError


@pytest.fixture
def manifest(tmp_path):
    path = tmp_path / "pd.json"
    write_fe_model(piston_duct(10), path)
    return path


def _matrix_file(manifest, key="K"):
    return manifest.parent / json.loads(manifest.read_text())["matrices"][key]


@pytest.mark.parametrize(("header", "message"), [
    ("1000000000 1000000000 1", "more than the cap of"),
    ("10 10 100000", "more than a file of"),
])
def test_mtx_header_is_checked_against_the_file(manifest, header, message):
    path = _matrix_file(manifest)
    lines = path.read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if not line.startswith("%"))
    lines[first] = header
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=message) as info:
        read_fe_model(manifest)
    assert info.value.item == "K" and info.value.file == str(path)


def test_dense_array_header(manifest):
    path = _matrix_file(manifest)
    path.write_text("%%MatrixMarket matrix array real general\n100000 100000\n1.0\n")
    with pytest.raises(DataError, match="entries"):
        read_fe_model(manifest)


def test_matrix_file_that_is_not_regular(manifest):
    path = _matrix_file(manifest)
    path.unlink()
    path.symlink_to("/dev/zero")
    with pytest.raises(DataError, match="character device"):
        read_fe_model(manifest)


def test_valid_files_still_read(manifest):
    fe = read_fe_model(manifest)
    ref = piston_duct(10)
    assert fe.n_dofs == ref.n_dofs
    assert abs(fe.K - ref.K).max() == 0 and np.array_equal(fe.dof_kind, ref.dof_kind)
