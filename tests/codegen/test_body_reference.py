"""A parametric body's samples read from its body file (neweul_py/codegen/body_reference.py,
the loader in neweul_py/ffrf/data_file.py).

Reference: the module generated from the same equations with its own copy of the samples in
its data file: the module that reads them from the body file must give the same numbers bit
for bit, and refuse a changed or missing body file at import with one error.
"""

from __future__ import annotations

import importlib.util
import itertools
import shutil
from pathlib import Path

import numpy as np
import pytest
from fe_builders import piston_duct

from neweul_py.analysis import load_generated
from neweul_py.api import generate, load_description
from neweul_py.codegen import generate_module
from neweul_py.codegen.body_reference import body_sources
from neweul_py.elastic.io.body_files import save_parametric_body
from neweul_py.elastic.parametric.snapshot_basis import basis_parametric_body, snapshot_basis
from neweul_py.equations import newton_euler
from neweul_py.errors import NeweulError
from neweul_py.ffrf.data_file import ElasticDataError

SPEEDS = (300.0, 343.0, 390.0)
_COUNTER = itertools.count()
DESCRIPTION = """
name: duct_on_ground
parameters: {{cs: 343.0, m2: 0.02, k2: 1.0e5}}
coordinates: {{z: {{}}}}
frames:
  carrier: {{translation: [z, 0, 0]}}
elastic_bodies:
  duct: {{frame: ISYS, data: {data}, nodes: {{piston: 1}}, schedule: cs, inertia: sid}}
bodies:
  mass: {{frame: carrier, mass: m2}}
forces:
  link:
    type: bushing
    between: [duct.piston, carrier]
    stiffness: {{diag: [k2, 0, 0]}}
"""


@pytest.fixture(scope="module")
def ducts(tmp_path_factory) -> Path:
    """Piston ducts (damped piston) at three sound speeds projected on one snapshot basis, as
    the middle ear's body is (the samples vary in every matrix entry): with cubic weights
    (``duct.npz``), with the slopes of the models at ±0.5 m/s and cubic Hermite weights
    (``duct_h.npz``), and with quintic Hermite weights (``duct_q.npz``)."""
    tmp = tmp_path_factory.mktemp("body_reference")
    fes = [piston_duct(n_el=60, c=c, damping=3.0) for c in SPEEDS]
    V, energy = snapshot_basis(fes, [fe.B("force") for fe in fes], np.geomspace(20, 900, 6))
    near = tuple([piston_duct(n_el=60, c=c + sign * 0.5, damping=3.0) for c in SPEEDS]
                 for sign in (-1, 1))
    for name, kw in (("duct", {}),
                     ("duct_h", {"slope_models": near, "interpolation": "hermite"}),
                     ("duct_q", {"slope_models": near})):
        body = basis_parametric_body(fes, V, SPEEDS, parameter="c", keep_nodes=[1],
                                     energy=energy, slope_step=0.5 if kw else None, **kw)
        save_parametric_body(body, tmp / f"{name}.npz")
    return tmp


def _import(path: Path):
    """Import a module file afresh (``load_generated`` reuses a module of the same text)."""
    spec = importlib.util.spec_from_file_location(f"body_reference_{next(_COUNTER)}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _modules(root: Path, data: str, tag: str):
    desc = root / f"{tag}.yaml"
    desc.write_text(DESCRIPTION.format(data=data))
    eq = newton_euler(load_description(desc))
    copy = generate_module(eq, "h", root / f"copy_{tag}" / "duct_on_ground.py")
    ref = generate_module(eq, "h", root / f"ref_{tag}" / "duct_on_ground.py",
                          body_files={"duct": str(root / data)})
    return copy, ref


@pytest.mark.parametrize("data", ["duct.npz", "duct_h.npz"])
def test_the_module_reading_the_body_file_equals_the_copying_one(ducts, data: str) -> None:
    """Cubic and cubic Hermite weights: the right-hand side, mass matrix and outputs at
    schedules between and at the samples are those of the module with its own copy, bit for
    bit; its data file no longer holds the samples, and it names the body file relative to
    itself."""
    copy, ref = _modules(ducts, data, data.removesuffix(".npz"))
    a, b = load_generated(copy), load_generated(ref)
    assert f"'../{data}'" in ref.read_text()
    size = {p.parent.name: p.stat().st_size for p in (copy, ref)
            for p in p.parent.glob("*.npz")}
    assert size[ref.parent.name] < size[copy.parent.name]
    rng = np.random.default_rng(3)
    p = np.asarray(a.default_parameters(), dtype=float)
    for cs in (300.0, 321.0, 343.0, 389.0):
        p[list(a.PARAMETERS).index("cs")] = cs
        x = 1e-4 * rng.standard_normal(a.STATE_SIZE)
        for f in ("rhs", "outputs"):
            np.testing.assert_array_equal(getattr(a, f)(0.0, x, p), getattr(b, f)(0.0, x, p))
        n = a.STATE_SIZE // 2
        np.testing.assert_array_equal(a.mass_matrix(0.0, x[:n], p),
                                      b.mass_matrix(0.0, x[:n], p))


def test_a_changed_or_missing_body_file_is_one_error_at_import(ducts, tmp_path) -> None:
    """The module checks the body file's SHA-256 before reading it: a changed byte or a
    missing file is one ElasticDataError naming the body and the file."""
    shutil.copy(ducts / "duct_h.npz", tmp_path / "duct_h.npz")
    _copy, ref = _modules(tmp_path, "duct_h.npz", "changed")
    body = tmp_path / "duct_h.npz"
    raw = bytearray(body.read_bytes())
    raw[-100] ^= 1
    body.write_bytes(bytes(raw))
    for words in ("changed after generation", "is missing"):
        with pytest.raises(ValueError, match=rf"elastic body 'duct': the body file "
                                             rf"{tmp_path}/duct_h\.npz {words}") as exc:
            _import(ref)
        assert type(exc.value).__name__ == ElasticDataError.__name__  # the module's own copy
        body.unlink(missing_ok=True)


def test_a_huge_body_file_is_refused_before_it_is_hashed(ducts, tmp_path) -> None:
    """A sparse file of 8 GB in place of the body file: refused by the size the module
    recorded, naming both sizes, not after hashing 8 GB (reference: the body file's size
    at generation)."""
    shutil.copy(ducts / "duct_h.npz", tmp_path / "duct_h.npz")
    _copy, ref = _modules(tmp_path, "duct_h.npz", "huge")
    body = tmp_path / "duct_h.npz"
    size = body.stat().st_size
    body.unlink()
    with open(body, "wb") as fh:
        fh.truncate(8 << 30)
    with pytest.raises(ValueError, match=rf"the body file {tmp_path}/duct_h\.npz changed after "
                                         rf"generation \(8589934592 bytes, it had {size}\)"):
        _import(ref)


def test_a_body_file_without_the_exact_stack_is_not_referenced(ducts) -> None:
    """A stack that the file's members do not give bit for bit stays in the data file
    (reference: the module's own stack, changed in its last bit; and the quintic body, whose
    curvatures vary in entries where its values do not, so that no member holds its
    columns)."""
    copy, _ref = _modules(ducts, "duct_h.npz", "exact")
    with np.load(next(copy.parent.glob("*.npz"))) as z:
        stack = np.array(z["duct/mixing/varying"])
    file = str(ducts / "duct_h.npz")
    assert body_sources([("duct", file)], {"duct/mixing/varying": stack}, copy.parent)
    stack[-1, -1] = np.nextafter(stack[-1, -1], np.inf)
    assert body_sources([("duct", file)], {"duct/mixing/varying": stack}, copy.parent) == {}
    _copy, ref = _modules(ducts, "duct_q.npz", "quintic")
    assert "_DATA_SOURCES = {}" in ref.read_text()


def test_a_cached_module_cannot_reference_body_files(ducts) -> None:
    """A cached module lives elsewhere than its output directory: asking for both is one
    error before anything is derived."""
    with pytest.raises(NeweulError, match="reference_bodies"):
        generate(ducts / "duct_q.yaml", ducts / "out", cache=True, reference_bodies=True)
