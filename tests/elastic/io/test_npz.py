"""Reading ``.npz`` archives (elastic/io/npz.py).

Reference: the file rules of docs/reduced-body-format.md — arrays are numbers (or the
documented text and flag members); a member of dates, durations or records, which NumPy would
load without complaint, is one DataError naming the file and the array.
"""

from __future__ import annotations

import numpy as np
import pytest

from neweul_py.elastic.io.npz import load_npz
from neweul_py.errors import DataError


@pytest.mark.parametrize("bad", [
    np.array([1, 2], dtype="datetime64[s]"),
    np.array([1, 2], dtype="timedelta64[s]"),
    np.zeros(2, dtype=[("a", float), ("b", int)]),
])
def test_dates_durations_and_records_are_refused_naming_the_array(tmp_path, bad) -> None:
    path = tmp_path / "b.npz"
    np.savez(path, K=np.eye(2), M=bad)
    with pytest.raises(DataError, match="array 'M' has dtype") as info:
        load_npz(path)
    assert info.value.file == str(path) and info.value.item == "M"


def test_numbers_text_and_flags_are_read(tmp_path) -> None:
    path = tmp_path / "b.npz"
    np.savez(path, K=np.eye(2), kind=np.array(["ux", "p"]), two_sided=np.array(True))
    arrays = load_npz(path)
    assert arrays["kind"].tolist() == ["ux", "p"] and bool(arrays["two_sided"])
