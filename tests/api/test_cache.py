"""The trusted cache (neweul_py/cache.py, api.generated_module): nothing is imported from it
before its bytes match the SHA-256 recorded when it was written.

References: the shipped ``generated/pendulum.py`` (the module a cache hit must equal byte for
byte), POSIX file modes and owners, and a marker file that tampered code would create.
"""

from __future__ import annotations

import os
import stat
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from neweul_py import api
from neweul_py.cache import (
    CacheError,
    CacheWarning,
    import_verified,
    sha256_hex,
    trusted_dir,
    verified_bytes,
    write_cached,
)
from neweul_py.cli import main

ROOT = Path(__file__).resolve().parents[2]
PENDULUM = ROOT / "examples" / "pendulum.yaml"


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))


def test_cache_directory_is_created_private(tmp_path, monkeypatch):
    """The directory, the parents it creates, and every file are private whatever the umask
    (here 000, which made missing parents 0777)."""
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "home" / ".cache" / "neweul-py"))
    old = os.umask(0)
    try:
        path = api.generated_module(PENDULUM)
    finally:
        os.umask(old)
    for d in (path.parent, tmp_path / "home" / ".cache", tmp_path / "home"):
        assert stat.S_IMODE(d.stat().st_mode) == 0o700, d
    assert path.read_bytes() == (ROOT / "generated" / "pendulum.py").read_bytes()
    side = path.with_name(path.name + ".sha256")
    assert side.read_text().strip() == sha256_hex(path.read_bytes())
    assert {stat.S_IMODE(f.stat().st_mode) for f in path.parent.iterdir()} == {0o600}


@pytest.mark.skipif(not hasattr(os, "getuid") or os.getuid() != 0,
                    reason="changing the owner needs root")
@pytest.mark.parametrize("what", ["module", "digest", "module link", "digest link"])
def test_entry_or_digest_of_another_user_is_never_imported(tmp_path, what):
    """A module and a digest that match each other but that another user wrote (or links to
    their files) are not imported: the marker of the injected line stays absent and the
    entry is regenerated, one warning naming why."""
    path = api.generated_module(PENDULUM)
    side = path.with_name(path.name + ".sha256")
    marker = tmp_path / "ran"
    evil = path.read_bytes() + f"\nopen({str(marker)!r}, 'w').close()\n".encode()
    path.write_bytes(evil)
    side.write_text(sha256_hex(evil) + "\n")
    target = path if what.startswith("module") else side
    if what.endswith("link"):
        theirs = tmp_path / "theirs"
        theirs.mkdir()
        target.rename(theirs / target.name)
        target.symlink_to(theirs / target.name)
        target = theirs / target.name
    os.chown(target, 4242, -1)
    with pytest.warns(CacheWarning, match="another user|symbolic link"):
        api.load_description_module(PENDULUM)
    assert not marker.exists()
    assert path.read_bytes() == (ROOT / "generated" / "pendulum.py").read_bytes()
    assert not path.is_symlink() and not side.is_symlink()


def test_appended_line_never_runs_and_is_regenerated(tmp_path, capsys):
    """A line appended to a cached module must not run on the next simulate: the digest
    mismatch is seen before the import, the marker file is never created, and the module is
    regenerated (equal to the shipped one) with one warning."""
    path = api.generated_module(PENDULUM)
    marker = tmp_path / "ran"
    with open(path, "a") as fh:
        fh.write(f"\nopen({str(marker)!r}, 'w').close()\n")
    assert main(["simulate", str(PENDULUM), "--t-end", "0.1"]) == 0
    err = capsys.readouterr().err
    assert not marker.exists()
    assert err.count("warning:") == 1 and "does not match its recorded SHA-256" in err
    assert path.read_bytes() == (ROOT / "generated" / "pendulum.py").read_bytes()
    assert main(["simulate", str(PENDULUM), "--t-end", "0.1"]) == 0
    assert "warning" not in capsys.readouterr().err  # the regenerated entry verifies


def test_missing_sidecar_regenerates(tmp_path):
    """An entry without its digest is not trusted (written by someone else, or half)."""
    path = api.generated_module(PENDULUM)
    path.with_name(path.name + ".sha256").unlink()
    with pytest.warns(CacheWarning, match="no readable digest"):
        assert api.generated_module(PENDULUM) == path
    assert verified_bytes(path) == path.read_bytes()


@pytest.mark.parametrize("mode", [0o777, 0o770, 0o722])
def test_directory_writable_by_others_is_refused(tmp_path, mode):
    """Whoever can write into the cache could replace a module and its digest together."""
    directory = tmp_path / "shared"
    directory.mkdir()
    os.chmod(directory, mode)
    with pytest.raises(CacheError, match="writable by group or others"):
        api.generated_module(PENDULUM, cache=directory)
    assert list(directory.iterdir()) == []


@pytest.mark.skipif(not hasattr(os, "getuid") or os.getuid() != 0,
                    reason="changing the owner needs root")
def test_directory_of_another_user_is_refused(tmp_path):
    directory = tmp_path / "theirs"
    directory.mkdir(mode=0o700)
    os.chown(directory, 4242, -1)
    with pytest.raises(CacheError, match="owned by another user"):
        trusted_dir(directory)


def test_cli_names_the_refused_directory(tmp_path, monkeypatch, capsys):
    directory = tmp_path / "open"
    directory.mkdir()
    os.chmod(directory, 0o777)
    monkeypatch.setenv("NEWEUL_CACHE", str(directory))
    assert main(["simulate", str(PENDULUM), "--t-end", "0.1"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(directory) in err and "chmod 700" in err


def test_entry_writable_by_others_is_regenerated():
    path = api.generated_module(PENDULUM)
    os.chmod(path, 0o666)
    with pytest.warns(CacheWarning, match="writable by group or others"):
        api.generated_module(PENDULUM)
    assert stat.S_IMODE(path.stat().st_mode) == 0o600


def test_verified_bytes_for_any_cached_file(tmp_path):
    """The helper a compiled library next to the module uses: the bytes come back only when
    they hash to the recorded (or the given) digest."""
    lib = trusted_dir(tmp_path / "c") / "model_abc.so"
    digest = write_cached(lib, b"\x7fELF binary")
    assert verified_bytes(lib) == b"\x7fELF binary"
    assert verified_bytes(lib, digest) == b"\x7fELF binary"
    with pytest.warns(CacheWarning):
        assert verified_bytes(lib, "0" * 64) is None
    lib.write_bytes(b"\x7fELF other")
    with pytest.warns(CacheWarning):
        assert verified_bytes(lib) is None
    assert verified_bytes(tmp_path / "c" / "absent.so") is None  # no entry: no warning


def test_import_uses_the_verified_bytes_not_the_path(tmp_path):
    """The module is executed from the bytes that were checked: changing the file after the
    check changes nothing."""
    path = tmp_path / "m.py"
    path.write_text("VALUE = 2\n")
    source = path.read_bytes()
    path.write_text("VALUE = 3\n")
    assert import_verified(path, source).VALUE == 2


def test_cache_hit_imports_no_symbolic_layer(tmp_path):
    """A cache hit needs no sympy: the module is loaded without deriving anything."""
    import subprocess
    import sys

    api.generated_module(PENDULUM)
    code = (
        "import sys; sys.modules['sympy'] = None\n"
        "from neweul_py.api import load_description_module\n"
        f"m = load_description_module({str(PENDULUM)!r})\n"
        "assert m.MODEL_NAME == 'pendulum'\n"
        "assert not any(k.startswith(('neweul_py.codegen', 'neweul_py.equations')) "
        "for k in sys.modules)\n"
        "print('ok')\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, check=True)
    assert out.stdout.strip() == "ok"


def test_no_warning_on_a_clean_hit():
    api.generated_module(PENDULUM)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        api.generated_module(PENDULUM)


def test_generate_through_the_cache_writes_the_same_bytes_without_sympy(tmp_path):
    """``neweul generate`` (cache on by default): the first run derives and stores, the
    second copies the verified entry without importing sympy; both outputs equal the shipped
    ``generated/pendulum.py`` byte for byte, and ``--no-cache`` derives the same bytes."""
    import subprocess
    import sys

    assert main(["generate", str(PENDULUM), "-o", str(tmp_path / "a")]) == 0
    code = (
        "import sys; sys.modules['sympy'] = None\n"
        "from neweul_py.cli import main\n"
        f"assert main(['generate', {str(PENDULUM)!r}, '-o', {str(tmp_path / 'b')!r}]) == 0\n"
        "assert not any(k.startswith(('neweul_py.codegen', 'neweul_py.equations', "
        "'neweul_py.analysis')) for k in sys.modules)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                   check=True)
    assert main(["generate", str(PENDULUM), "-o", str(tmp_path / "c"), "--no-cache"]) == 0
    shipped = (ROOT / "generated" / "pendulum.py").read_bytes()
    for d in "abc":
        assert (tmp_path / d / "pendulum.py").read_bytes() == shipped


def test_generate_regenerates_a_tampered_cache_entry(tmp_path):
    """A cached module whose bytes no longer match their digest is not copied: ``generate``
    derives again (one CacheWarning) and writes the shipped bytes."""
    path = api.generated_module(PENDULUM)
    path.write_bytes(path.read_bytes().replace(b"MODEL_NAME = 'pendulum'",
                                               b"MODEL_NAME = 'evil'"))
    with pytest.warns(CacheWarning):
        out = api.generate(PENDULUM, tmp_path / "out", cache=True)
    assert out.name == "pendulum.py"
    assert out.read_bytes() == (ROOT / "generated" / "pendulum.py").read_bytes()


def test_a_tampered_compiled_module_in_the_cache_is_rewritten_not_run(tmp_path, fresh_modules):
    """The compiled module of a cache entry (wrapper ``_c.py`` and its C sources) carries
    digests like the NumPy entry: a wrapper with an injected line is not executed (the marker
    file stays absent) but rewritten with one CacheWarning, and an edited C source is rebuilt
    instead of falling back to NumPy on every later run."""
    marker = tmp_path / "ran"
    api.load_description_module(PENDULUM, backend="c")
    cache = Path(os.environ["NEWEUL_CACHE"])
    (wrapper,) = cache.glob("pendulum_*_c.py")
    clean = wrapper.read_bytes()
    wrapper.write_bytes(f"open({str(marker)!r}, 'w').write('x')\n".encode() + clean)
    with pytest.warns(CacheWarning, match="_c.py does not match"):
        mod = api.load_description_module(PENDULUM, backend="c")
    assert not marker.exists()
    assert wrapper.read_bytes() == clean and mod.__file__ == str(wrapper)
    c_file = wrapper.with_suffix(".c")
    c_file.write_text(c_file.read_text() + "/* edited */\n")
    with pytest.warns(CacheWarning, match="_c.c does not match"):
        api.load_description_module(PENDULUM, backend="c")
    assert "edited" not in c_file.read_text()


_ELASTIC = """
name: duct_on_ground
parameters: {m2: 0.02, k2: 1.0e5}
coordinates: {z: {}}
frames:
  carrier: {translation: [z, 0, 0]}
elastic_bodies:
  duct: {frame: ISYS, data: duct.npz, nodes: {piston: 1}}
bodies:
  mass: {frame: carrier, mass: m2}
forces:
  link:
    type: bushing
    between: [duct.piston, carrier]
    stiffness: {diag: [k2, 0, 0]}
"""


@pytest.fixture
def elastic_description(tmp_path) -> Path:
    """A piston-duct body (4 modes) with a mass on its node: a module with a data file."""
    from fe_builders import piston_duct

    from neweul_py.elastic import reduce_modal, save_reduced_body
    from neweul_py.elastic.reductors.invariants import attach_invariants

    fe = piston_duct(n_el=30)
    body = reduce_modal(fe, modes=4, keep_nodes=[1], store_bases=True)
    save_reduced_body(attach_invariants(body, fe, nodes=[1]), tmp_path / "duct.npz")
    (tmp_path / "duct.yaml").write_text(_ELASTIC)
    return tmp_path / "duct.yaml"


def _data_files(directory: Path) -> list[Path]:
    return sorted(directory.glob("duct_on_ground.*.npz"))


def test_cached_data_file_carries_a_digest_like_the_module(elastic_description):
    """The data file a module with elastic bodies names is cached next to it, private
    (0600), with a sidecar holding the SHA-256 the module records (reference: hashlib of the
    file's bytes)."""
    path = api.generated_module(elastic_description)
    (data,) = _data_files(path.parent)
    digest = sha256_hex(data.read_bytes())
    assert data.with_name(data.name + ".sha256").read_text().strip() == digest
    assert f"_DATA_SHA256 = {digest!r}".encode() in path.read_bytes()
    assert stat.S_IMODE(data.stat().st_mode) == 0o600


def test_damaged_cached_data_file_is_regenerated_not_used(elastic_description):
    """A byte of the cached data file changed behind its sidecar: the module refuses it at
    import and the cache writes it again (reference: the bytes first written), so the
    loaded module evaluates the original data."""
    path = api.generated_module(elastic_description)
    (data,) = _data_files(path.parent)
    clean = data.read_bytes()
    ref = api.load_description_module(elastic_description)
    x, p = 1e-3 * np.arange(ref.STATE_SIZE), ref.default_parameters()
    expected = ref.rhs(0.0, x, p)
    for name in [n for n in sys.modules if n.startswith("neweul_generated_duct")]:
        del sys.modules[name]
    raw = bytearray(clean)
    raw[-200] ^= 0x01
    data.write_bytes(bytes(raw))
    mod = api.load_description_module(elastic_description)
    assert data.read_bytes() == clean
    np.testing.assert_array_equal(mod.rhs(0.0, x, p), expected)


def test_data_file_with_another_digest_is_not_handed_to_the_module(elastic_description):
    """A cached data file whose sidecar records another digest than its module names (a
    file of another entry under its name): one CacheWarning, and the entry is written again
    (reference: the first data file's bytes)."""
    path = api.generated_module(elastic_description)
    (data,) = _data_files(path.parent)
    clean = data.read_bytes()
    side = data.with_name(data.name + ".sha256")
    side.write_text("0" * 64 + "\n")
    with pytest.warns(CacheWarning, match="another SHA-256"):
        api.load_description_module(elastic_description)
    assert side.read_text().strip() == sha256_hex(clean) and data.read_bytes() == clean


def test_generate_through_the_cache_copies_the_data_file(elastic_description, tmp_path):
    """``generate(cache=...)`` writes the module and its data file, on a miss and on a hit,
    byte for byte as ``generate`` without the cache (reference: the uncached files)."""
    plain = api.generate(elastic_description, tmp_path / "plain")
    for out in ("miss", "hit"):
        got = api.generate(elastic_description, tmp_path / out, cache=True)
        assert got.read_bytes() == plain.read_bytes()
        assert [f.name for f in _data_files(got.parent)] == [
            f.name for f in _data_files(plain.parent)]
        assert _data_files(got.parent)[0].read_bytes() == _data_files(plain.parent)[0].read_bytes()
