"""Top-level convenience API: description file → generated module → simulation.

This is the only module (besides the CLI) that sees every layer: it loads a description
(``description``), derives the equations (``equations``), writes the module (``codegen``) and
hands the module to ``analysis``.
"""

from __future__ import annotations

import atexit
import functools
import gc
import hashlib
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any, Literal

from .cache import (
    cache_dir,
    import_verified,
    trusted_dir,
    trusted_entry,
    verified_bytes,
    write_cached,
)
from .errors import DescriptionError, ModelError, NeweulError
from .files import MAX_DESCRIPTION_BYTES, read_checked
from .progress import StagedProgress
from .version import installed_version
from .yaml_tree import YamlTree, read_description

if TYPE_CHECKING:
    import numpy as np

    from .analysis.results import SimulationResult

__all__ = [
    "BACKENDS",
    "FORMS",
    "cache_dir",
    "derive",
    "export_fmu",
    "generate",
    "generated_module",
    "load_description",
    "load_description_module",
    "simulate_description",
]

Form = Literal["auto", "closed", "recursive"]
#: Forms of the equations: closed form or recursive (semi-symbolic), ``docs/architecture.md``.
FORMS: tuple[str, ...] = ("auto", "closed", "recursive")
Backend = Literal["numpy", "c"]
#: Backends of generated modules: the NumPy module, or the compiled one (codegen/c_module.py,
#: a C library behind the same protocol, falling back to its NumPy twin).
BACKENDS: tuple[str, ...] = ("numpy", "c")

#: FMU kinds of :func:`export_fmu` (= :data:`neweul_py.codegen.fmu_model.KINDS`).
FMU_KINDS: tuple[str, ...] = ("me", "cs", "both")

#: Packages whose source determines a generated module (``elastic`` reads elastic-body data).
_GENERATOR_PACKAGES = ("model", "description", "kinematics", "equations", "codegen", "elastic",
                       "ffrf")


@functools.cache
def _skip_collection_at_exit() -> None:
    """Once a process has derived equations, exempt its objects from the collector at exit
    (``atexit`` → :func:`gc.freeze`, as the ``neweul`` console script does): the
    interpreter's shutdown otherwise collects and frees sympy's classes, functions and
    caches one by one, ≈ 0.25 s CPU of the whole Hex20 pendulum benchmark process (1.36 →
    1.12 s; ``benchmarks/bench_hex_pendulum_process.py``), memory the operating system takes
    back anyway. Objects are still freed by reference counting; only reference cycles still
    alive at exit are left unfinalized (close files explicitly)."""
    atexit.register(gc.freeze)


def _read(path: str | os.PathLike[str]) -> bytes:
    """The bytes of a description, checked to be a regular file of sane size first."""
    try:
        return read_checked(path, "description", MAX_DESCRIPTION_BYTES)
    except NeweulError as exc:
        message = str(exc).removeprefix(f"{os.fspath(path)}: ")
        raise DescriptionError(message, "", os.fspath(path)) from None


def _sha256(raw: bytes) -> str:
    """SHA-256 of a description's bytes (= :func:`neweul_py.description.description_hash`,
    without importing the symbolic layers for a cache hit)."""
    return hashlib.sha256(raw).hexdigest()


def _check_form(form: str) -> None:
    if form not in FORMS:
        raise NeweulError(f"unknown form {form!r}; forms are: {', '.join(FORMS)}")


def read_elastic_data(path: Any, *args: Any, **kwargs: Any) -> Any:
    """:func:`neweul_py.elastic.io.reader.read_elastic_data`, imported at the first elastic body
    (the elastic layer pulls in ``scipy.sparse``, ≈ 0.3 s, which rigid models never need)."""
    from .elastic.io.reader import read_elastic_data as read

    return read(path, *args, **kwargs)


def load_description(path: str | os.PathLike[str], *, elastic_reader: Any = None) -> Any:
    """Load the description file at ``path`` into a :class:`~neweul_py.model.System`.

    Unlike :func:`neweul_py.description.load_description` (which, by layering, does not know
    the elastic layer), ``data`` files of ``elastic_bodies`` are read by default with
    :func:`neweul_py.elastic.io.reader.read_elastic_data` (SID text or reduced-body ``.npz``).

    Parameters
    ----------
    path
        The YAML description.
    elastic_reader
        Another ``reader(path, modes) -> flat invariant arrays``; ``None``: the default.

    Returns
    -------
    System
        The validated model.

    Raises
    ------
    DescriptionError
        As :func:`neweul_py.description.load_description_text`.
    """
    from .description import load_description as _load

    return _load(path, elastic_reader=elastic_reader or read_elastic_data)


def derive(description_path: str | os.PathLike[str], form: Form = "auto",
           progress: StagedProgress = None) -> tuple[Any, str]:
    """Load a description and derive its equations (``progress``: as in :func:`generate`).

    Returns
    -------
    equations, source_hash
        The :class:`~neweul_py.equations.Equations` and the SHA-256 of the file's bytes.
    """
    _check_form(form)
    source = _parsed(description_path)
    return _derive_tree(source.tree, form, progress), _sha256(source.raw)


@dataclass(frozen=True)
class _Parsed:
    """A description's bytes and their YAML tree, read and parsed once (for the cache key,
    which needs the data files it names, and for the derivation alike)."""

    raw: bytes
    tree: YamlTree


def _parsed(description_path: str | os.PathLike[str]) -> _Parsed:
    """Read and parse the description at ``description_path``."""
    raw = _read(description_path)
    return _Parsed(raw, read_description(raw, os.fspath(description_path)))


def _derive_tree(tree: YamlTree, form: Form, progress: StagedProgress = None) -> Any:
    """The equations of a parsed description (errors name the tree's file)."""
    from .description import load_description_tree
    from .equations import newton_euler

    _skip_collection_at_exit()
    system = load_description_tree(tree, elastic_reader=read_elastic_data)
    if not system.coordinates and not system.elastic_bodies:
        raise DescriptionError(
            "the model has no coordinates to derive equations for: list its generalized "
            "coordinates under 'coordinates' (or add an elastic body)",
            "coordinates",
            tree.file,
        )
    try:
        return newton_euler(system, form=form, progress=progress)
    except DescriptionError:
        raise
    except ModelError as exc:  # found while deriving (e.g. coinciding spring points)
        raise DescriptionError(exc.message, exc.key_path, tree.file) from None


def generate(
    source: Any,
    out_dir: str | os.PathLike[str] = "generated",
    form: Form = "auto",
    backend: Backend = "numpy",
    progress: StagedProgress = None,
    cache: bool | str | os.PathLike[str] = False,
    sensitivities: bool = False,
    reference_bodies: bool = False,
) -> Path:
    """Generate the NumPy module of a description: ``out_dir/<name>.py``.

    Parameters
    ----------
    source
        A YAML description file (path), YAML text (a ``str`` with a line break), or a
        :class:`~neweul_py.model.System` (e.g. from :class:`~neweul_py.SystemBuilder`); a
        module generated from a ``System`` carries ``SOURCE_HASH = system.fingerprint()``.
    out_dir
        Directory of the module (created if needed).
    form
        ``"closed"``, ``"recursive"`` or ``"auto"`` (closed for small models).
    backend
        ``"numpy"`` or ``"c"``: also ``<name>_c.c`` and the compiled module ``<name>_c.py``
        (built at once; see :func:`_with_backend`).
    progress
        A staged hook ``progress(stage, done, total)``, called after each frame
        (``"kinematics"``), each body, mass-matrix column and force element
        (``"equations"``) and each block of the module (``"code generation"``; with
        ``backend="c"`` also ``"C code"``): counts rise to ``total`` within a stage. A
        :class:`neweul_py.progress.Tracker` draws one bar per stage on a terminal; ``None``
        (default) is silent.
    cache
        Description files only: take the NumPy module from the content-hash cache of
        :func:`generated_module` (``True``: the default cache directory, or a directory),
        deriving and storing it there on a miss. The module written is byte for byte the one
        derivation would write (the key covers the description, its data files, the form and
        the generator's source); a hit imports neither sympy nor the symbolic layers.
    sensitivities
        Also the directional second derivatives of the parameter sensitivities of linear
        models (docs/sensitivity.md §1; rigid models). The first parameter derivatives are in
        every module.
    reference_bodies
        Parametric elastic bodies: the module reads their sample stacks from their body
        files, named relative to ``out_dir`` and checked by SHA-256 at import, instead of a
        copy in its data file (docs/generated-module-protocol.md); not with ``cache``, whose
        modules live elsewhere.

    Returns
    -------
    Path
        The module written (the compiled one for ``backend="c"``). Nothing is written when
        the description or derivation fails, so a previously generated module stays as it was.

    Examples
    --------
    >>> generate("examples/pendulum.yaml", "generated")  # doctest: +SKIP
    PosixPath('generated/pendulum.py')
    >>> generate(Path("examples/pendulum.yaml").read_text(), "out")  # doctest: +SKIP
    PosixPath('out/pendulum.py')
    """
    _check_backend(backend)
    is_text = isinstance(source, str) and "\n" in source
    if reference_bodies and cache is not False:
        raise NeweulError("generate: reference_bodies names body files relative to the "
                          "module, which a cached module cannot (give one of the two)")
    if reference_bodies and (is_text or not isinstance(source, str | os.PathLike)):
        raise NeweulError("generate: reference_bodies needs a description file (its "
                          "elastic bodies name their files)")
    if (isinstance(source, str | os.PathLike) and not is_text and cache is not False
            and backend == "numpy"):
        return _generate_cached(source, out_dir, form, None if cache is True else cache,
                                sensitivities)
    from .model import System

    if isinstance(source, System):
        from .equations import newton_euler

        _skip_collection_at_exit()
        _check_form(form)
        equations = newton_euler(source, form=form, progress=progress)
        source_hash = source.fingerprint()
    elif is_text:
        from .description import description_hash

        _check_form(form)
        raw = source.encode("utf-8")
        equations = _derive_tree(read_description(raw, "<description text>"), form, progress)
        source_hash = description_hash(raw)
    elif isinstance(source, str | os.PathLike):
        equations, source_hash = derive(source, form, progress)
    else:
        raise NeweulError(
            f"generate: expected a description path, YAML text or a System, got "
            f"{type(source).__name__}"
        )
    from .codegen import generate_module

    path = generate_module(equations, source_hash, Path(out_dir) / f"{equations.system.name}.py",
                           sensitivities=sensitivities, progress=progress,
                           body_files=_body_files(source) if reference_bodies else None)
    return _with_backend(path, backend, lambda: equations, rebuild=True, progress=progress)


def _body_files(description_path: str | os.PathLike[str]) -> dict[str, str]:
    """The file each elastic body of a description names, resolved as the loader resolves
    it (relative to the description's folder): the files themselves, not those of equations
    derived earlier from equal data, which the derivation cache may return."""
    tree = _parsed(description_path).tree
    bodies = tree.data.get("elastic_bodies") if isinstance(tree.data, dict) else None
    base = Path(description_path).parent
    out = {}
    for name, spec in (bodies or {}).items():
        data = spec.get("data") if isinstance(spec, dict) else None
        if isinstance(data, str):
            out[str(name)] = os.fspath(Path(data) if os.path.isabs(data) else base / data)
    return out


def _constant_of(source: bytes, name: str) -> Any:
    """The literal value of the protocol constant ``name = …`` (one line) of a module text
    (``ast.literal_eval``: a literal, never code), ``None`` when absent or malformed."""
    import ast

    prefix = f"\n{name} = ".encode()
    start = source.find(prefix)
    if start < 0:
        return None
    end = source.find(b"\n", start + len(prefix))
    try:
        return ast.literal_eval(source[start + len(prefix):end].decode("utf-8"))
    except (ValueError, SyntaxError, UnicodeDecodeError, MemoryError, RecursionError):
        return None


def _generate_cached(description_path: str | os.PathLike[str], out_dir: str | os.PathLike[str],
                     form: Form, cache: str | os.PathLike[str] | None,
                     sensitivities: bool = False) -> Path:
    """:func:`generate` through the content-hash cache: a verified hit is copied to
    ``out_dir`` without importing sympy or the analysis package; a miss derives and stores."""
    from .atomic import atomic_write

    _check_form(form)
    parsed = _parsed(description_path)
    raw = parsed.raw
    path = _cache_entry(parsed, description_path, form, cache, sensitivities)
    source = verified_bytes(path)
    name = data = None
    if source is not None and _constant_of(source, "SOURCE_HASH") == _sha256(raw):
        name = _constant_of(source, "MODEL_NAME")
        data = _cached_data(path, source)
    if not isinstance(name, str) or data is False:
        entry = _cached_source(description_path, form, cache, parsed=parsed,
                               sensitivities=sensitivities)
        source, name = entry.source, (entry.module.MODEL_NAME if entry.module is not None
                                      else entry.equations().system.name)
        data = _cached_data(entry.path, source)
        if data is False:
            raise NeweulError(f"{path}: the data file of the cached module does not verify")
    if data is not None:        # the data file first: the module names it (codegen/module.py)
        atomic_write(Path(out_dir) / data[0], data[1])
    return atomic_write(Path(out_dir) / f"{name}.py", source)


def _data_file_of(source: bytes) -> tuple[str, str] | None:
    """The data file a module text names (``_DATA_FILE``, ``_DATA_SHA256``), or ``None``."""
    name, digest = _constant_of(source, "_DATA_FILE"), _constant_of(source, "_DATA_SHA256")
    if not isinstance(name, str) or not isinstance(digest, str):
        return None
    return name, digest


def _cached_data(path: Path, source: bytes) -> tuple[str, bytes] | bool | None:
    """The name and verified bytes of the data file of the cached module ``path``
    (``source``: its verified text), ``None`` when it names none, ``False`` when the data file
    is missing or does not verify (:func:`~neweul_py.cache.verified_bytes`)."""
    named = _data_file_of(source)
    if named is None:
        return None
    if Path(named[0]).name != named[0]:
        return False
    content = verified_bytes(path.parent / named[0])
    if content is None or _sha256(content) != named[1]:
        return False
    return named[0], content


def _check_backend(backend: str) -> None:
    if backend not in BACKENDS:
        raise NeweulError(f"unknown backend {backend!r}; backends are: {', '.join(BACKENDS)}")


def _with_backend(path: Path, backend: str, equations: Any, rebuild: bool = False,
                  progress: StagedProgress = None, cached: bool = False) -> Path:
    """The module of ``backend`` for the NumPy module ``path``: ``path`` itself, or the
    compiled module next to it (written from ``equations()`` unless present, and loaded once,
    which builds its library). A model the C backend cannot print keeps the NumPy module,
    with one warning.

    ``cached``: ``path`` is a cache entry. The compiled module's files (wrapper, core and
    Jacobian C sources) then carry SHA-256 sidecars like the NumPy entry (:mod:`.cache`); a
    file that does not verify is rewritten (one :class:`~neweul_py.cache.CacheWarning`),
    and the wrapper is imported from its verified bytes (:func:`_load_cached_wrapper`)."""
    if backend == "numpy":
        return path
    import warnings

    from .codegen.c_module import c_module_path, write_c_module
    from .errors import GenerationError

    wrapper = c_module_path(path)
    files = _compiled_files(wrapper)
    if cached and not rebuild and all(f.is_file() for f in files):
        rebuild = any(verified_bytes(f) is None for f in files)
    if rebuild or not (wrapper.is_file() and wrapper.with_suffix(".c").is_file()):
        try:
            write_c_module(equations(), path, progress=progress)
        except GenerationError as exc:
            warnings.warn(f"{exc}; using the NumPy module {path}", RuntimeWarning, stacklevel=3)
            return path
        except OSError as exc:
            raise NeweulError(f"cannot write the compiled module next to {path}: "
                              f"{exc.strerror}") from None
        if cached:
            for f in files:     # the digests of what was just written (private cache dir)
                write_cached(f, f.read_bytes())
    if cached:
        _load_cached_wrapper(wrapper)
        return wrapper
    from .analysis.module import load_generated

    _compiled(lambda: load_generated(wrapper))  # builds (or verifies) the library now
    return wrapper


def _compiled(load: Callable[[], Any]) -> Any:
    """The compiled module ``load()`` imports (or its typed view,
    :class:`~neweul_py.analysis.module.GeneratedModel`), which must run its C library: asked
    for ``backend="c"``, a module that fell back to its NumPy twin (no cffi, no compiler, an
    untrusted library cache …) is one error naming why, never a warning and the NumPy
    module. Other warnings of the import (a rebuilt library) are passed on."""
    import sys
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        module = load()
    if getattr(module, "BACKEND", "c") != "c":
        imported = getattr(module, "module", module)   # the module behind a typed view
        sys.modules.pop(imported.__name__, None)       # a later call tries the library again
        why = getattr(module, "BACKEND_ERROR", "") or getattr(module, "BACKEND_NOTE", "")
        raise NeweulError(f"the compiled backend (backend 'c') is unavailable for the model "
                          f"{module.MODEL_NAME!r}: {why}; the NumPy backend needs none of it")
    for w in caught:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return module


def _compiled_files(wrapper: Path) -> tuple[Path, Path, Path]:
    """The files of a compiled module: wrapper ``<name>_c.py``, ``<name>_c.c``,
    ``<name>_c_jac.c`` (:func:`neweul_py.codegen.c_module.write_c_module`)."""
    return wrapper, wrapper.with_suffix(".c"), wrapper.with_name(f"{wrapper.stem}_jac.c")


def _load_cached_wrapper(wrapper: str | os.PathLike[str]) -> ModuleType:
    """Import the compiled module ``wrapper`` of a cache entry from its verified bytes (its
    sidecar digest; its C sources are verified by :func:`_with_backend` and again by the
    wrapper against the digests it carries) and check its protocol.

    Raises
    ------
    NeweulError
        The wrapper does not verify (regenerate it through :func:`generated_module`) or does
        not implement the protocol.
    """
    from .analysis.module import check_protocol

    source = verified_bytes(wrapper)
    if source is None:
        raise NeweulError(f"{wrapper}: the compiled module in the cache does not verify "
                          "against its recorded SHA-256")
    module = _compiled(lambda: import_verified(wrapper, source))
    check_protocol(module, str(wrapper))
    return module


@functools.cache
def _generator_fingerprint() -> str:
    """SHA-256 of the source of the symbolic layers (which include the protocol version in
    ``codegen``): a cached module is reused only if the code that would generate it again is
    unchanged."""
    root = Path(__file__).parent
    h = hashlib.sha256(b"neweul-py generator\n")
    for layer in _GENERATOR_PACKAGES:
        for f in sorted((root / layer).rglob("*.py")):
            h.update(f.relative_to(root).as_posix().encode())
            h.update(f.read_bytes())
    return h.hexdigest()


def _data_fingerprints(data: Any, description_path: str | os.PathLike[str]) -> list[str]:
    """SHA-256 of each data file the description refers to (``elastic_bodies.*.data``,
    ``inputs.*.table``, relative to the description), so that a cached module is regenerated
    when its data change.

    Each file is checked to be a regular file of sane size before it is read
    (:func:`neweul_py.files.read_checked`): ``data: /dev/zero`` or a FIFO is one clear error.
    A missing file is left to the loader, which reports it with its key path and line.
    ``data``: the parsed description (:attr:`neweul_py.yaml_tree.YamlTree.data`).
    """
    tree = data
    if not isinstance(tree, dict):
        return []
    base = Path(description_path).parent
    out = []
    for section, key in (("elastic_bodies", "data"), ("inputs", "table")):
        entries = tree.get(section)
        if isinstance(entries, dict):
            out += _file_fingerprints(entries, section, key, base, description_path)
    return out


def _file_fingerprints(entries: dict, section: str, key: str, base: Path,
                       description_path: str | os.PathLike[str]) -> list[str]:
    """``name:sha256`` of the file ``entries[name][key]`` of each entry that names one."""
    out = []
    for name in sorted(entries, key=str):
        spec = entries[name]
        data = spec.get(key) if isinstance(spec, dict) else None
        if isinstance(data, str) and "\0" not in data:
            file = base / data
            if not file.exists():
                out.append(f"{name}:missing")
                continue
            try:
                digest = hashlib.sha256(read_checked(file, f"{section} data file")).hexdigest()
            except NeweulError as exc:
                raise DescriptionError(str(exc), f"{section}.{name}.{key}",
                                       os.fspath(description_path)) from None
            out.append(f"{name}:{digest}")
    return out


def _cache_entry(parsed: _Parsed, description_path: str | os.PathLike[str], form: str,
                 cache: str | os.PathLike[str] | None, sensitivities: bool = False) -> Path:
    """Path of the cached module of a description (in a trusted directory)."""
    material = [_sha256(parsed.raw), form, *(["sensitivities"] if sensitivities else []),
                _generator_fingerprint(), *_data_fingerprints(parsed.tree.data, description_path)]
    key = hashlib.sha256("\n".join(material).encode()).hexdigest()
    directory = trusted_dir(cache)
    stem = "".join(c if c.isalnum() or c == "_" else "_" for c in Path(description_path).stem)
    return directory / f"{stem}_{key[:24]}.py"


class _Entry:
    """A cache entry: its path, verified source, module (on a hit), and its equations
    (derived on first use; ``fresh``: derived now, the entry was (re)written)."""

    def __init__(self, path: Path, source: bytes, module: ModuleType | None,
                 derive: Any, equations: Any = None) -> None:
        self.path, self.source, self.module = path, source, module
        self._derive, self._equations = derive, equations
        self.fresh = equations is not None

    def equations(self) -> Any:
        if self._equations is None:
            self._equations = self._derive()
        return self._equations


def _cached_source(description_path: str | os.PathLike[str], form: Form,
                   cache: str | os.PathLike[str] | None,
                   progress: StagedProgress = None, parsed: _Parsed | None = None,
                   sensitivities: bool = False) -> _Entry:
    """The cache entry of a description, with its verified source and (on a hit) module
    (``parsed``: the description already read and parsed; ``sensitivities``: as
    :func:`generate`)."""
    _check_form(form)
    parsed = parsed or _parsed(description_path)
    raw = parsed.raw
    path = _cache_entry(parsed, description_path, form, cache, sensitivities)

    def derive_now() -> Any:
        return _derive_tree(parsed.tree, form, progress)

    source = verified_bytes(path)
    named = None if source is None else _data_file_of(source)
    if source is not None and (named is None or (
            Path(named[0]).name == named[0]
            and trusted_entry(path.parent / named[0], named[1]))):
        # here, not above: a miss derives and writes without the analysis layer (NumPy)
        from .analysis.module import check_protocol

        try:    # (a module with elastic bodies hashes its data file as it maps it)
            module = import_verified(path, source)
            check_protocol(module, str(path))
            if module.SOURCE_HASH == _sha256(raw):
                return _Entry(path, source, module, derive_now)
        except NeweulError:
            pass  # a damaged cache entry is regenerated
    from .codegen.module import render_files

    equations = derive_now()
    files = render_files(equations, _sha256(raw), sensitivities=sensitivities,
                         progress=progress)
    if files.data is not None:          # the data file first, with its sidecar like the module
        write_cached(path.parent / files.data.name, files.data.content)
    source = files.text.encode("utf-8")
    write_cached(path, source)
    return _Entry(path, source, None, derive_now, equations)


def generated_module(
    description_path: str | os.PathLike[str],
    form: Form = "auto",
    cache: str | os.PathLike[str] | None = None,
    backend: Backend = "numpy",
    sensitivities: bool = False,
) -> Path:
    """The generated module of a description, from the cache or freshly generated into it.

    The cache key is the SHA-256 of the description's bytes, of the data files it refers to
    (elastic bodies), the form and the generator's own source; a hit is reused without deriving
    anything. A cached module is trusted only after its bytes match the SHA-256 recorded when
    it was written (:mod:`neweul_py.cache`); a mismatch regenerates it with one
    :class:`~neweul_py.cache.CacheWarning`. Prefer :func:`load_description_module`, which
    imports the verified bytes themselves rather than the path. ``sensitivities``: as
    :func:`generate` (a cache entry of its own).

    Raises
    ------
    CacheError
        The cache directory is owned by another user or writable by others, or not writable.
    """
    _check_backend(backend)
    entry = _cached_source(description_path, form, cache, sensitivities=sensitivities)
    return _with_backend(entry.path, backend, entry.equations, rebuild=entry.fresh,
                         cached=True)


def load_description_module(
    description_path: str | os.PathLike[str],
    form: Form = "auto",
    cache: str | os.PathLike[str] | None = None,
    backend: Backend = "numpy",
    progress: StagedProgress = None,
    sensitivities: bool = False,
) -> ModuleType:
    """The generated module of a description (``progress``: the derivation's on a cache
    miss, ``sensitivities``: as in :func:`generate`). The NumPy module is imported from the verified
    bytes of its cache entry (:func:`generated_module`), so that the file cannot change
    between check and import; the compiled one (``backend="c"``) is loaded through its
    wrapper, imported from its verified bytes as well (:func:`_load_cached_wrapper`), whose
    library :mod:`neweul_py.codegen.c_module` verifies by its hash.

    Examples
    --------
    >>> mod = load_description_module("examples/pendulum.yaml")  # doctest: +SKIP
    >>> mod.rhs(0.0, mod.INITIAL_STATE, mod.default_parameters())  # doctest: +SKIP
    """
    from .analysis.module import check_protocol

    _check_backend(backend)
    entry = _cached_source(description_path, form, cache, progress,
                           sensitivities=sensitivities)
    if backend != "numpy":
        wrapper = _with_backend(entry.path, backend, entry.equations, rebuild=entry.fresh,
                                cached=True)
        if wrapper != entry.path:           # else: the NumPy module, with one warning
            return _load_cached_wrapper(wrapper)
    module = entry.module
    if module is None:
        module = import_verified(entry.path, entry.source)
        check_protocol(module, str(entry.path))
    return module


def simulate_description(
    description_path: str | os.PathLike[str],
    t_end: float,
    *,
    form: Form = "auto",
    cache: str | os.PathLike[str] | None = None,
    p: Mapping[str, float] | Sequence[float] | np.ndarray | None = None,
    backend: Backend = "numpy",
    **kwargs: Any,
) -> SimulationResult:
    """Generate (cached) and simulate a description; ``kwargs`` go to
    :func:`neweul_py.analysis.simulate`.

    Examples
    --------
    >>> res = simulate_description("examples/double_pendulum.yaml", 10.0)  # doctest: +SKIP
    >>> res.to_csv("out/double_pendulum.csv")  # doctest: +SKIP
    """
    from .analysis.simulate import simulate

    module = load_description_module(description_path, form, cache, backend)
    return simulate(module, t_end, p=p, **kwargs)


def _check_fmu_target(out: str | os.PathLike[str], kind: str) -> Path:
    """The FMU's path, refused unless it ends in ``.fmu`` and names no directory."""
    out = Path(out)
    if out.suffix != ".fmu":
        raise NeweulError(f"{out}: an FMU is written to a file ending in .fmu")
    if out.is_dir():
        raise NeweulError(f"{out}: is a directory, not an FMU file")
    if kind not in FMU_KINDS:
        raise NeweulError(f"unknown FMU kind {kind!r}; kinds are: {', '.join(FMU_KINDS)}")
    return out


def export_fmu(
    description_path: str | os.PathLike[str],
    out: str | os.PathLike[str],
    kind: str = "both",
    *,
    form: Form = "auto",
    independent: Sequence[str] | None = None,
    cache: str | os.PathLike[str] | None = None,
    progress: StagedProgress = None,
) -> Path:
    """Export a description as an FMI 2.0 FMU (docs/fmu-export.md).

    Everything that would make the export fail is checked before any derivation: the path
    (``.fmu``), the kind, a C compiler and this platform, inputs without a numeric default
    (:func:`neweul_py.codegen.fmu_model.export_problems`). Elastic bodies (parametric ones
    too) are compiled as the compiled backend traces them, their arrays in the FMU's
    ``resources/``.

    Parameters
    ----------
    description_path
        The YAML description.
    out
        The ``.fmu`` file (written atomically: an existing file stays as it was on any error).
    kind
        ``"me"`` (model exchange), ``"cs"`` (co-simulation) or ``"both"``.
    form
        Form of the equations (as :func:`generate`).
    independent
        Models with constraints: the coordinates that are the FMU's states (default: the first
        ones the constraints leave free, as :func:`neweul_py.analysis.simulate` keeps them).
    cache
        The module cache (:func:`generated_module`).
    progress
        A staged hook (:func:`generate`; then the ``"FMU"`` stage).

    Returns
    -------
    Path
        The FMU written.

    Raises
    ------
    DescriptionError
        An input without a numeric default (naming its key).
    NeweulError
        A path that is not ``.fmu``, no compiler, an unsupported platform, constraints whose
        reactions differ from their Jacobian (two-sided elastic node frames), no regular
        partition of the coordinates.

    Examples
    --------
    >>> export_fmu("examples/double_pendulum.yaml", "double_pendulum.fmu")  # doctest: +SKIP
    PosixPath('double_pendulum.fmu')
    """
    import numpy as np

    from .codegen.fmu import binary_platform, find_compiler, write_fmu
    from .codegen.fmu_model import KINDS, export_problems, fmu_model
    from .description import load_description_text

    out = _check_fmu_target(out, kind)
    _check_form(form)
    find_compiler()
    binary_platform()
    raw = _read(description_path)
    system = load_description_text(raw, os.fspath(description_path),
                                   elastic_reader=read_elastic_data)
    problems = export_problems(system)
    if problems:
        key, message = problems[0]
        raise DescriptionError(f"cannot export an FMU: {message}", key,
                               os.fspath(description_path))
    entry = _cached_source(description_path, form, cache, progress)
    module = entry.module if entry.module is not None else import_verified(entry.path,
                                                                            entry.source)
    constants = {k: getattr(module, k) for k in dir(module) if k.isupper()}
    p0 = module.default_parameters()
    x0, dependent = np.asarray(module.INITIAL_STATE, dtype=float), ()
    if module.CONSTRAINTS:
        x0, dependent = _consistent_start(module, independent)
    elif independent is not None:
        raise NeweulError(f"independent coordinates apply to models with constraints; "
                          f"{module.MODEL_NAME} has none")
    model = fmu_model(system, constants, x0, module.default_inputs(0.0, p0), dependent)
    return write_fmu(entry.equations(), model, out, KINDS[kind],
                     tool=f"neweul-py {installed_version()}", progress=progress)


def _consistent_start(module: Any, independent: Sequence[str] | None) -> tuple[Any, tuple]:
    """The consistent start state of a constrained module and its dependent coordinates
    (the partition of :func:`neweul_py.analysis.dae.consistent_initial_state`)."""
    import numpy as np

    from .analysis.dae import consistent_initial_state, default_partition
    from .analysis.protocol import partition

    p0 = module.default_parameters()
    y, yd = consistent_initial_state(module, p=p0, independent=independent)
    g = np.asarray(module.constraint_jacobian(0.0, y, p0), dtype=float)
    names = list(module.COORDINATES)
    if independent is not None:
        dep = partition(g, names, independent)[1]
    else:
        dep = default_partition(g)
        if dep is None:
            raise NeweulError(
                "the constraints " + ", ".join(module.CONSTRAINTS) + " leave no "
                "well-conditioned set of dependent coordinates at the start: name the FMU's "
                "states with --independent")
    reaction = getattr(module, "constraint_reaction_jacobian", None)
    if callable(reaction) and not np.array_equal(
            np.asarray(reaction(0.0, y, p0), dtype=float), g):
        raise NeweulError(
            "cannot export an FMU: the reactions of the constraints "
            + ", ".join(module.CONSTRAINTS) + " act through the left basis of a two-sided "
            "elastic body (G_R differs from G), which the FMU's augmented system does not "
            "hold")
    return np.concatenate([y, yd]), tuple(int(j) for j in dep)
