"""Loading generated modules (neweul_py/analysis/module.py, ``load_generated``).

Reference: each module's own twin. A compiled module is the same text wherever it is — it
finds its NumPy twin and its data next to itself — so two builds of one description that
differ in their default parameters have byte-identical wrappers; each load must still be
the module of its own directory (its twin's defaults and equations), not the first one
imported.
"""

from __future__ import annotations

import numpy as np
from compiler import needs_c_compiler

from neweul_py.analysis import load_generated
from neweul_py.codegen import generate_module
from neweul_py.codegen.c_module import write_c_module
from neweul_py.description import load_description_text
from neweul_py.equations import newton_euler

OSCILLATOR = """
name: oscillator
parameters: {{m: 2.0, k: {k}, c: 0.4}}
coordinates:
  z: {{initial: 1.1, velocity: 0.0}}
frames:
  mass: {{translation: [0, 0, z]}}
bodies:
  block: {{frame: mass, mass: m}}
forces:
  spring: {{type: generalized, coordinate: z, value: -k*(z - 1) - c*d_z}}
"""


@needs_c_compiler
def test_identical_compiled_wrappers_in_two_places_load_as_their_own_modules(tmp_path):
    """The oscillator built with k = 50 and with k = 80, each in its own directory: the two
    compiled wrappers are byte-identical, and each loads with its own twin's defaults and
    ``rhs`` (the NumPy twin of its directory)."""
    wrappers, twins = [], []
    for k in (50.0, 80.0):
        eq = newton_euler(load_description_text(OSCILLATOR.format(k=k)))
        npath = generate_module(eq, "0" * 64, tmp_path / f"k{k:g}" / "oscillator.py")
        wrappers.append(write_c_module(eq, npath))
        twins.append(load_generated(npath))
    assert wrappers[0].read_bytes() == wrappers[1].read_bytes()     # the case of this test
    x = np.array([1.3, 0.2])
    for wrapper, twin in zip(wrappers, twins, strict=True):
        mod = load_generated(wrapper)
        np.testing.assert_array_equal(mod.default_parameters(), twin.default_parameters())
        p = twin.default_parameters()
        np.testing.assert_allclose(mod.rhs(0.0, x, p), twin.rhs(0.0, x, p), rtol=1e-14)
    assert not np.array_equal(twins[0].default_parameters(), twins[1].default_parameters())
