"""Top-level convenience API: description file → generated module → simulation.

This is the only module (besides the CLI) that sees every layer: it loads a description
(``description``), derives the equations (``equations``), writes the module (``codegen``) and
hands the module to ``analysis``.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any, Literal

import numpy as np

from .analysis.module import load_generated
from .analysis.results import SimulationResult
from .analysis.simulate import simulate
from .codegen import PROTOCOL_VERSION, generate_module
from .elastic.reader import read_elastic_data
from .errors import DescriptionError, NeweulError

__all__ = [
    "FORMS",
    "cache_dir",
    "derive",
    "generate",
    "generated_module",
    "load_description",
    "simulate_description",
]

Form = Literal["auto", "closed", "recursive"]
#: Forms of the equations (DESIGN.md: closed form or recursive/semi-symbolic).
FORMS: tuple[str, ...] = ("auto", "closed", "recursive")

#: Packages whose source determines a generated module (``elastic`` reads elastic-body data).
_GENERATOR_PACKAGES = ("model", "description", "kinematics", "equations", "codegen", "elastic")


def _read(path: str | os.PathLike[str]) -> bytes:
    try:
        return Path(path).read_bytes()
    except OSError as exc:
        raise DescriptionError(f"cannot read description: {exc.strerror}", "",
                               os.fspath(path)) from None


def _check_form(form: str) -> None:
    if form not in FORMS:
        raise NeweulError(f"unknown form {form!r}; forms are: {', '.join(FORMS)}")


def load_description(path: str | os.PathLike[str], *, elastic_reader: Any = None) -> Any:
    """Load the description file at ``path`` into a :class:`~neweul_py.model.System`.

    Unlike :func:`neweul_py.description.load_description` (which, by layering, does not know
    the elastic layer), ``data`` files of ``elastic_bodies`` are read by default with
    :func:`neweul_py.elastic.reader.read_elastic_data` (SID text or reduced-body ``.npz``).

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


def derive(description_path: str | os.PathLike[str], form: Form = "auto") -> tuple[Any, str]:
    """Load a description and derive its equations.

    Returns
    -------
    equations, source_hash
        The :class:`~neweul_py.equations.Equations` and the SHA-256 of the file's bytes.
    """
    from .description import description_hash

    _check_form(form)
    raw = _read(description_path)
    return _derive_text(raw, description_path, form), description_hash(raw)


def _derive_text(raw: bytes, description_path: str | os.PathLike[str], form: Form) -> Any:
    """The equations of a description's bytes (errors name ``description_path``)."""
    from .description import load_description_text
    from .equations import newton_euler
    from .errors import DescriptionError

    system = load_description_text(raw, os.fspath(description_path),
                                   elastic_reader=read_elastic_data)
    if not system.coordinates and not system.elastic_bodies:
        raise DescriptionError(
            "the model has no coordinates to derive equations for: list its generalized "
            "coordinates under 'coordinates' (or add an elastic body)",
            "coordinates",
            os.fspath(description_path),
        )
    return newton_euler(system, form=form)


def generate(
    description_path: str | os.PathLike[str],
    out_dir: str | os.PathLike[str] = "generated",
    form: Form = "auto",
) -> Path:
    """Generate the NumPy module of a description: ``out_dir/<name>.py``.

    Parameters
    ----------
    description_path
        A YAML description file.
    out_dir
        Directory of the module (created if needed).
    form
        ``"closed"``, ``"recursive"`` or ``"auto"`` (closed for small models).

    Returns
    -------
    Path
        The module written. Nothing is written when the description or derivation fails, so a
        previously generated module stays as it was.

    Examples
    --------
    >>> generate("examples/pendulum.yaml", "generated")  # doctest: +SKIP
    PosixPath('generated/pendulum.py')
    """
    equations, source_hash = derive(description_path, form)
    return generate_module(equations, source_hash, Path(out_dir) / f"{equations.system.name}.py")


def cache_dir() -> Path:
    """Where :func:`generated_module` keeps modules: ``$NEWEUL_CACHE``, else
    ``$XDG_CACHE_HOME/neweul-py``, else ``~/.cache/neweul-py``."""
    if os.environ.get("NEWEUL_CACHE"):
        return Path(os.environ["NEWEUL_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "neweul-py"


def _generator_fingerprint() -> str:
    """SHA-256 of the source of the symbolic layers: a cached module is reused only if the
    code that would generate it again is unchanged."""
    root = Path(__file__).parent
    h = hashlib.sha256(f"protocol {PROTOCOL_VERSION}\n".encode())
    for layer in _GENERATOR_PACKAGES:
        for f in sorted((root / layer).rglob("*.py")):
            h.update(f.relative_to(root).as_posix().encode())
            h.update(f.read_bytes())
    return h.hexdigest()


def _data_fingerprints(raw: bytes, description_path: str | os.PathLike[str]) -> list[str]:
    """SHA-256 of each data file the description refers to (``elastic_bodies.*.data``,
    ``inputs.*.table``, relative to the description), so that a cached module is regenerated
    when its data change."""
    import yaml

    try:
        tree = yaml.safe_load(raw)
    except yaml.YAMLError:
        return []  # the loader reports the error when the module is generated
    if not isinstance(tree, dict):
        return []
    base = Path(description_path).parent
    out = []
    for section, key in (("elastic_bodies", "data"), ("inputs", "table")):
        entries = tree.get(section)
        if isinstance(entries, dict):
            out += _file_fingerprints(entries, key, base)
    return out


def _file_fingerprints(entries: dict, key: str, base: Path) -> list[str]:
    """``name:sha256`` of the file ``entries[name][key]`` of each entry that names one."""
    out = []
    for name in sorted(entries, key=str):
        spec = entries[name]
        data = spec.get(key) if isinstance(spec, dict) else None
        if isinstance(data, str):
            try:
                out.append(f"{name}:{hashlib.sha256((base / data).read_bytes()).hexdigest()}")
            except OSError:
                out.append(f"{name}:unreadable")
    return out


def generated_module(
    description_path: str | os.PathLike[str],
    form: Form = "auto",
    cache: str | os.PathLike[str] | None = None,
) -> Path:
    """The generated module of a description, from the cache or freshly generated into it.

    The cache key is the SHA-256 of the description's bytes, of the data files it refers to
    (elastic bodies), the form and the generator's own source; a hit is reused without deriving
    anything.
    """
    from .description import description_hash

    _check_form(form)
    raw = _read(description_path)
    material = [description_hash(raw), form, _generator_fingerprint(),
                *_data_fingerprints(raw, description_path)]
    key = hashlib.sha256("\n".join(material).encode()).hexdigest()
    directory = Path(cache) if cache is not None else cache_dir()
    stem = "".join(c if c.isalnum() or c == "_" else "_" for c in Path(description_path).stem)
    path = directory / f"{stem}_{key[:24]}.py"
    if path.is_file():
        try:
            module = load_generated(path)
            if module.SOURCE_HASH == description_hash(raw):
                return path
        except NeweulError:
            pass  # a damaged cache entry is regenerated
    equations = _derive_text(raw, description_path, form)
    try:
        return generate_module(equations, description_hash(raw), path)
    except OSError as exc:
        raise NeweulError(f"cannot write to the cache {directory}: {exc.strerror}") from None


def simulate_description(
    description_path: str | os.PathLike[str],
    t_end: float,
    *,
    form: Form = "auto",
    cache: str | os.PathLike[str] | None = None,
    p: Mapping[str, float] | Sequence[float] | np.ndarray | None = None,
    **kwargs: Any,
) -> SimulationResult:
    """Generate (cached) and simulate a description; ``kwargs`` go to
    :func:`neweul_py.analysis.simulate`.

    Examples
    --------
    >>> res = simulate_description("examples/double_pendulum.yaml", 10.0)  # doctest: +SKIP
    >>> res.to_csv("out/double_pendulum.csv")  # doctest: +SKIP
    """
    module: ModuleType = load_generated(generated_module(description_path, form, cache))
    return simulate(module, t_end, p=p, **kwargs)
