"""The compact layout of body files (neweul_py/elastic/io/layout.py).

Reference: the arrays before packing — the layout is exact, bit for bit — and the rules of
docs/reduced-body-format.md ("Compact layout") for what is stored.
"""

from __future__ import annotations

import numpy as np
import pytest

from neweul_py.elastic.io.layout import pack, unpack
from neweul_py.errors import DataError

K = 4


def _arrays() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(1)
    varying = rng.standard_normal((K, 3, 3))
    return {
        "M": varying,
        "invariants/Me.m0": varying.copy(),                  # the same as M
        "V_kept": np.broadcast_to(rng.standard_normal((5, 3)), (K, 5, 3)).copy(),
        "W_kept": np.broadcast_to(rng.standard_normal((5, 3)), (K, 5, 3)).copy(),
        "slope/V_kept": np.zeros((K, 5, 3)),                 # zero
        "T": np.broadcast_to(np.eye(3), (K, 3, 3)),          # constant (a view)
        "samples": np.arange(K, dtype=float),
        "nodes": np.ones((2, 4)),                            # not stacked
        "ids": np.arange(3),                                 # integers are never "zero"
        "m": np.array(1.5),                                  # a 0-d array keeps its shape
    }


def test_round_trip_is_exact_and_stores_each_array_once():
    """unpack(pack(a)) equals a, dtype and shape included; zero arrays, the repeated one and
    the samples of a constant stack are not stored, a matrix mostly zero as its nonzeros."""
    arrays = _arrays()
    stacked = {"M", "invariants/Me.m0", "V_kept", "W_kept", "slope/V_kept", "T"}
    stored, layout = pack(arrays, stacked, K)
    assert set(stored) == {"M", "V_kept", "W_kept", "T", "T@nonzero", "samples", "nodes",
                           "ids", "m"}
    assert layout["sparse"] == {"T": [3, 3]} and stored["T"].tolist() == [1.0, 1.0, 1.0]
    assert stored["V_kept"].shape == (5, 3)
    assert layout["zero"] == {"slope/V_kept": [[K, 5, 3], "<f8"]}
    assert layout["same"] == {"invariants/Me.m0": "M"}
    assert sorted(layout["constant"]) == ["T", "V_kept", "W_kept"]
    back = unpack(stored, layout, K)
    for key, a in arrays.items():
        assert back[key].dtype == a.dtype and back[key].shape == a.shape, key
        assert np.array_equal(back[key], a), key
    for key in ("T", "V_kept", "W_kept", "slope/V_kept"):   # one copy in memory, read-only
        assert not back[key].flags.writeable and back[key].strides[0] == 0, key


def test_a_constant_stack_equal_to_another_is_stored_once():
    """A stack that is both constant and the same as another (the one-sided W_kept = V_kept)
    is one stored array: the layout names it ``same``, not ``constant``."""
    arrays = _arrays()
    arrays["W_kept"] = arrays["V_kept"].copy()
    stored, layout = pack(arrays, {"V_kept", "W_kept"}, K)
    assert "W_kept" not in stored and layout["same"]["W_kept"] == "V_kept"
    assert "W_kept" not in layout["constant"]
    assert np.array_equal(unpack(stored, layout, K)["W_kept"], arrays["V_kept"])


@pytest.mark.parametrize(("layout", "text"), [
    ({"zero": {}, "constant": ["absent"], "same": {}}, "constant array 'absent'"),
    ({"same": {"x": "absent"}}, "which the file lacks"),
    ({"zero": {"x": [[2, -1], "<f8"]}}, "needs [shape, float dtype]"),
    ({"zero": {"x": [[2], "<U2"]}}, "needs [shape, float dtype]"),
    ({"zero": {"x": "nonsense"}}, "needs [shape, float dtype]"),
    ({"varying": ["M"]}, "varying array 'M', whose members"),
    ({"sparse": {"M": [2]}}, "sparse array 'M' needs its shape"),
    ({"sparse": {"M": "x"}}, "sparse array 'M' needs its shape"),
    ({"varying": "M"}, "constant and varying lists of names"),
    ({"other": []}, "layout must be an object"),
    ([1, 2], "layout must be an object"),
])
def test_a_bad_layout_is_one_error_naming_the_array(layout, text):
    """A layout of another form, or naming arrays the file lacks: one DataError."""
    with pytest.raises(DataError, match=text.replace("[", r"\[").replace("]", r"\]")):
        unpack({"M": np.ones(2)}, layout, K, "body.npz")
