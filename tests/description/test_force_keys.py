"""Force elements read from their description keys (``neweul_py/description/force_keys.py``).

References: the same description without the key (an optional key given as ``null`` is the
same as an absent one: equal model fingerprints), and the message naming a required key
given as ``null``.
"""

from __future__ import annotations

import pytest

from neweul_py.description import load_description_text
from neweul_py.errors import DescriptionError

HEAD = """
name: nulls
parameters: {k: 10, c: 0.5}
coordinates: {x: 0.1, phi: 0.2}
frames:
  a: {translation: [x, 0, 0]}
  b: {parent: a, rotation: [[z, phi]]}
forces:
"""


@pytest.mark.parametrize(("given", "absent"), [
    ("{type: spring_damper, between: [ISYS, a], stiffness: k, damping: null, points: null}",
     "{type: spring_damper, between: [ISYS, a], stiffness: k}"),
    ("{type: rotational_spring_damper, coordinate: phi, between: null, axis: null, "
     "stiffness: k, loss_factor: null}",
     "{type: rotational_spring_damper, coordinate: phi, stiffness: k}"),
    ("{type: bushing, between: [a, b], stiffness: k, rotational_damping: null, enabled: null}",
     "{type: bushing, between: [a, b], stiffness: k}"),
    ("{type: force, frame: b, vector: [k, 0, 0], point: null, in: null, report: null}",
     "{type: force, frame: b, vector: [k, 0, 0]}"),
])
def test_an_optional_key_given_as_null_is_absent(given: str, absent: str) -> None:
    """``key: null`` on an optional key builds the same model as leaving the key out."""
    with_null = load_description_text(HEAD + f"  f: {given}\n")
    without = load_description_text(HEAD + f"  f: {absent}\n")
    assert with_null.fingerprint() == without.fingerprint()


def test_a_required_key_given_as_null_is_one_error_naming_it() -> None:
    """A required key cannot be left empty: the error names ``forces.f.stiffness``."""
    with pytest.raises(DescriptionError, match=r"forces\.f\.stiffness"):
        load_description_text(HEAD + "  f: {type: spring_damper, between: [ISYS, a], "
                                     "stiffness: null}\n")
