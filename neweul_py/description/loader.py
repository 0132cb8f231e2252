"""Load a YAML description file into a validated :class:`~neweul_py.model.System`.

The key schema lives in the table :data:`SECTIONS` and the ``Schema`` constants below; a
later section (``constraints``, ``elastic_bodies``) is one more table row and one small
function. The keys of each force ``type`` are its element class's
(:attr:`~neweul_py.model.ForceElement.keys`, read by :mod:`.force_keys`). Every error is a
:class:`DescriptionError` naming the file, the key path and the line.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from ..errors import DescriptionError, ModelError
from ..model import INERTIAL, System
from ..yaml_tree import YamlTree, read_description
from .builder import SystemBuilder
from .elastic import DataFiles, load_elastic_bodies
from .schema import Schema, section_items
from .signals import load_table_input
from .values import constant_number

__all__ = [
    "SECTIONS",
    "Schema",
    "description_hash",
    "load_description",
    "load_description_text",
    "load_description_tree",
]


def description_hash(text: bytes | str) -> str:
    """SHA-256 (hex) of a description's bytes; generated modules store it as ``SOURCE_HASH``."""
    data = text.encode("utf-8") if isinstance(text, str) else bytes(text)
    return hashlib.sha256(data).hexdigest()


# ----------------------------------------------------------------------------- sections
_Loader = Callable[[SystemBuilder, Any, str], None]
_FileLoader = Callable[[SystemBuilder, Any, str, DataFiles], None]


#: Most parameters of a description (docs/limits.md): each is a symbol that is validated,
#: fingerprinted, printed and passed in ``p``; 200 000 of them took over a minute.
MAX_PARAMETERS = 10_000


PARAMETER = Schema(required=("value",), optional=("min", "max"))


def _parameters(b: SystemBuilder, section: Any, path: str) -> None:
    if isinstance(section, dict) and len(section) > MAX_PARAMETERS:
        raise ModelError(f"{len(section)} parameters, more than the cap of {MAX_PARAMETERS} "
                         "(docs/limits.md)", path)
    for name, spec in section_items(section, path, "name: default value"):
        if isinstance(spec, dict):  # {value: V, min: A, max: B}
            item = f"{path}.{name}"
            spec = PARAMETER.check(spec, item, "a parameter")
            b.parameter(name, spec["value"], spec.get("min"), spec.get("max"))
        else:
            b.parameter(name, spec)


COORDINATE = Schema(optional=("initial", "velocity"))


def _coordinates(b: SystemBuilder, section: Any, path: str) -> None:
    for name, spec in section_items(section, path, "name: initial value"):
        item = f"{path}.{name}"
        if isinstance(spec, dict):
            spec = COORDINATE.check(spec, item, "a coordinate")
            b.coordinate(name, spec.get("initial", 0.0), spec.get("velocity", 0.0))
        else:
            b.coordinate(name, constant_number(spec, item, "initial value"))


def _inputs(b: SystemBuilder, section: Any, path: str, files: DataFiles) -> None:
    for name, default in section_items(section, path, "name: expression of t and parameters"):
        if default is None:
            raise ModelError("an input needs a default excitation (e.g. 0)", f"{path}.{name}")
        if isinstance(default, dict):  # {table: signal.csv, interpolation: …}
            default = load_table_input(str(name), default, files.base, f"{path}.{name}")
        b.input(name, default)


def _gravity(b: SystemBuilder, value: Any, path: str) -> None:
    b.gravity(value)


def _loss_reference(b: SystemBuilder, value: Any, path: str) -> None:
    b.loss_reference_frequency(value)


FRAME = Schema(optional=("parent", "translation", "rotation"))


def _frames(b: SystemBuilder, section: Any, path: str) -> None:
    for name, spec in section_items(section, path, "frame definitions"):
        spec = FRAME.check(spec, f"{path}.{name}", "a frame")
        b.frame(name, spec.get("parent", INERTIAL), spec.get("translation"), spec.get("rotation"))


BODY = Schema(required=("frame", "mass"), optional=("center_of_mass", "inertia"))


def _bodies(b: SystemBuilder, section: Any, path: str) -> None:
    for name, spec in section_items(section, path, "body definitions"):
        spec = BODY.check(spec, f"{path}.{name}", "a body")
        b.body(name, spec["frame"], spec["mass"], spec.get("center_of_mass"), spec.get("inertia"))


def _forces(b: SystemBuilder, section: Any, path: str) -> None:
    for name, spec in section_items(section, path, "force definitions"):
        b.force_element(name, spec)


KINEMATIC_OUTPUT = Schema(optional=("position", "velocity", "point", "in", "component"))
FORCE_OUTPUT = Schema(required=("force",), optional=("component",))


def _outputs(b: SystemBuilder, section: Any, path: str) -> None:
    for name, spec in section_items(section, path, "output definitions"):
        item = f"{path}.{name}"
        if not isinstance(spec, dict):
            b.output(name, spec)
            continue
        if "force" in spec:
            spec = FORCE_OUTPUT.check(spec, item, "a force output")
            b.force_output(name, spec["force"], spec.get("component", "force"))
            continue
        spec = KINEMATIC_OUTPUT.check(spec, item, "a kinematic output")
        quantities = [q for q in ("position", "velocity") if q in spec]
        if len(quantities) != 1:
            raise ModelError(
                "a kinematic output needs exactly one of 'position: FRAME' or "
                "'velocity: FRAME'",
                item,
            )
        b.kinematic_output(
            name,
            quantities[0],
            spec[quantities[0]],
            spec.get("point"),
            spec.get("in", INERTIAL),
            spec.get("component", "x"),
        )


COINCIDE = Schema(required=("coincide",), optional=("points", "components", "in"))


def _constraints(b: SystemBuilder, section: Any, path: str) -> None:
    for name, spec in section_items(section, path, "constraint definitions"):
        item = f"{path}.{name}"
        if isinstance(spec, dict):
            spec = COINCIDE.check(spec, item, "a coincidence constraint")
            b.coincide(name, spec["coincide"], spec.get("points"),
                       spec.get("components", ["x", "y", "z"]), spec.get("in", INERTIAL))
        else:
            b.constraint(name, spec)


@dataclass(frozen=True)
class Section:
    """A top-level key: whether it is required and how it is loaded (``None``: by the
    builder's constructor); ``files``: the loader reads data files and takes the
    :class:`~neweul_py.description.elastic.DataFiles` as a fourth argument."""

    load: _Loader | _FileLoader | None
    required: bool = False
    files: bool = False


#: Top-level keys, in the order they are loaded.
SECTIONS: Mapping[str, Section] = {
    "name": Section(None, required=True),
    "description": Section(None),
    "gravity": Section(_gravity),
    "loss_reference_frequency": Section(_loss_reference),
    "parameters": Section(_parameters),
    "coordinates": Section(_coordinates),
    "inputs": Section(_inputs, files=True),
    "frames": Section(_frames),
    "elastic_bodies": Section(load_elastic_bodies, files=True),
    "bodies": Section(_bodies),
    "forces": Section(_forces),
    "outputs": Section(_outputs),
    "constraints": Section(_constraints),
}

_TOP = Schema(
    required=tuple(k for k, s in SECTIONS.items() if s.required),
    optional=tuple(k for k, s in SECTIONS.items() if not s.required),
)


# ----------------------------------------------------------------------------- loading
def _build(data: Any, files: DataFiles) -> System:
    top = _TOP.check(data, "", "a description")
    if not isinstance(top["name"], str):
        raise ModelError(f"the model name must be a string, got {top['name']!r}", "name")
    description = top.get("description") or ""
    b = SystemBuilder(top["name"], description)
    for key, section in SECTIONS.items():
        if section.load is not None and key in top:
            if section.files:
                section.load(b, top[key], key, files)
            else:
                section.load(b, top[key], key)
    return b.build()


def load_description_text(
    text: str | bytes, filename: str = "<description>", *, elastic_reader: Any = None
) -> System:
    """Load a description from YAML text.

    Parameters
    ----------
    text
        The YAML text (bytes are decoded as UTF-8).
    filename
        Shown in error messages; ``data`` files of elastic bodies are relative to it.
    elastic_reader
        ``reader(path, modes) -> flat invariant arrays`` for ``elastic_bodies``,
        e.g. :func:`neweul_py.elastic.io.reader.read_elastic_data`; the description layer does
        not import the elastic layer itself.

    Returns
    -------
    System
        The validated model.

    Raises
    ------
    DescriptionError
        With file, key path and line for every problem (``docs/description-format.md``,
        "Errors").
    """
    return load_description_tree(read_description(text, filename),
                                 elastic_reader=elastic_reader)


def load_description_tree(tree: YamlTree, *, elastic_reader: Any = None) -> System:
    """Load a description already parsed by :func:`neweul_py.yaml_tree.read_description`
    (its ``file`` names it in errors; ``elastic_reader`` as in :func:`load_description_text`).
    """
    filename = tree.file
    try:
        return _build(tree.data, DataFiles.of(filename, elastic_reader))
    except DescriptionError:
        raise
    except ModelError as exc:
        line = tree.line(exc.key_path)
        raise DescriptionError(exc.message, exc.key_path, filename, line) from None


def load_description(path: str | os.PathLike[str], *, elastic_reader: Any = None) -> System:
    """Load the description file at ``path`` (see :func:`load_description_text`)."""
    from ..files import MAX_DESCRIPTION_BYTES, read_checked

    filename = os.fspath(path)
    try:  # a regular file of sane size: /dev/zero or a FIFO is refused at once
        data = read_checked(filename, "description", MAX_DESCRIPTION_BYTES, DescriptionError)
    except DescriptionError as exc:
        raise DescriptionError(str(exc).removeprefix(f"{filename}: "), "", filename) from None
    return load_description_text(data, filename, elastic_reader=elastic_reader)
