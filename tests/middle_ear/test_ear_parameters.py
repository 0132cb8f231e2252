"""Reading the middle ear's data from a file (``parameters.read_parameters``).

References: the file-reading rules every user file follows here — one error naming the file
and the key (or line), never a partial result — and the model's own validation of each field.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from neweul_py.errors import DataError
from neweul_py.middle_ear.parameters import (
    MAX_PARAMETER_FILE_BYTES,
    MiddleEarParameters,
    read_parameters,
)


def _file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "ear.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def test_a_mapping_of_fields_reads_as_floats_and_builds_parameters(tmp_path) -> None:
    """Integers and floats of known fields; the result makes a valid parameter set."""
    got = read_parameters(_file(tmp_path, "k_chain: 944\npf_compliance: 1.8e-12\n"
                                          "chain_limit_lateral: 410e-6\n"))
    assert got == {"k_chain": 944.0, "pf_compliance": 1.8e-12, "chain_limit_lateral": 410e-6}
    assert MiddleEarParameters(**got).k_chain == 944.0


def test_the_shipped_identified_set_reads() -> None:
    """``examples/middle_ear/identified.yaml`` is a valid parameter file with a pars flaccida."""
    path = Path(__file__).parents[2] / "examples" / "middle_ear" / "identified.yaml"
    assert read_parameters(path)["pf_compliance"] > 0


@pytest.mark.parametrize(("text", "item", "words"), [
    ("k_chian: 900\n", "k_chian", "unknown middle-ear parameter"),
    ("k_chain: stiff\n", "k_chain", "finite number"),
    ("k_chain: true\n", "k_chain", "finite number"),
    ("k_chain: .nan\n", "k_chain", "finite number"),
    ("k_chain: inf\n", "k_chain", "finite number"),
    ("tm_thickness: -1e-5\n", "middle_ear.tm_thickness", "positive"),
    ("pf_compliance: -1e-12\n", "middle_ear.pf_compliance", "0: no pars flaccida"),
])
def test_bad_entries_name_the_file_and_the_key(tmp_path, text, item, words) -> None:
    """Each bad entry is one :class:`DataError` with the file and the key."""
    path = _file(tmp_path, text)
    with pytest.raises(DataError) as info:
        read_parameters(path)
    assert info.value.file == str(path) and info.value.item == item
    assert words in info.value.message


@pytest.mark.parametrize("text", ["- k_chain\n- 900\n", "k_chain: [1, 2\n", "42\n"])
def test_a_file_that_is_not_a_mapping_is_refused(tmp_path, text) -> None:
    """A list, broken YAML (with its line) or a scalar: refused, naming the file."""
    path = _file(tmp_path, text)
    with pytest.raises(DataError) as info:
        read_parameters(path)
    assert info.value.file == str(path)


def test_missing_and_oversized_files_are_refused(tmp_path) -> None:
    """No file, or one larger than a parameter file can be: refused before parsing."""
    with pytest.raises(DataError, match="cannot read"):
        read_parameters(tmp_path / "none.yaml")
    big = _file(tmp_path, "#" * (MAX_PARAMETER_FILE_BYTES + 1))
    with pytest.raises(DataError, match="larger than"):
        read_parameters(big)

