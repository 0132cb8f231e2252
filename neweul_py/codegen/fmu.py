"""FMI 2.0 FMUs of a model: the compiled backend's C, an FMI layer, built for this platform.

:func:`write_fmu` writes ``NAME.fmu`` (a zip archive, FMI 2.0 §2.3) holding

* ``modelDescription.xml`` (:func:`.fmu_model.model_description`);
* ``sources/``: the model's C sources of the compiled backend (``model.c``, the equations of
  motion, outputs and constraints; ``model_jac.c``, their analytic derivatives, as
  :func:`.c_module.render_c_sources` prints them), ``model.h``
  (:func:`.fmu_model.model_header`), the FMI layer ``neweul_fmi2.c`` and the FMI 2.0 headers
  (Modelica Association, BSD 2-clause; ``sources/LICENSE_fmi2.txt``);
* ``resources/NAME.bin`` with elastic bodies: the float64 arrays the model's C is bound to at
  instantiation (``nw_bind``; :class:`.fmu_model.ElasticData`), the C being the kernel traced
  as the compiled backend traces it (:mod:`.c_splice`);
* ``binaries/<platform>/NAME.so`` (``.dylib`` on macOS), built from ``sources/`` by the
  system C compiler (``CC``, ``cc`` or ``gcc``) with the flags of the compiled backend and
  hidden visibility for everything but the ``fmi2…`` functions.

The archive is written atomically (nothing is left behind on an error) and is deterministic
but for the binary (fixed dates, sorted entries).
"""

from __future__ import annotations

import hashlib
import io
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic import atomic_write
from ..errors import GenerationError, NeweulError
from ..progress import StagedProgress, Steps
from .c_module import render_c_sources
from .c_runtime import C_FLAGS
from .c_splice import render_elastic_sources
from .fmu_model import ElasticData, FmuModel, model_description, model_header
from .writer import program_blocks

__all__ = ["binary_platform", "find_compiler", "write_fmu"]

_HERE = Path(__file__).resolve().parent / "fmi2"
#: The fixed files of every FMU's ``sources/`` (the FMI 2.0.5 headers and their license).
_FIXED = ("neweul_fmi2.c", "fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")


def find_compiler() -> str:
    """The system C compiler: ``$CC``, else ``cc`` or ``gcc`` on the ``PATH``.

    Raises
    ------
    NeweulError
        When there is none.
    """
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not cc or not (shutil.which(cc) or Path(cc).is_file()):
        raise NeweulError("no C compiler found to build the FMU's binary: install gcc (or "
                          "set CC to a C compiler)")
    return cc


def binary_platform() -> tuple[str, str]:
    """The FMI 2.0 platform folder and library suffix of this machine (FMI 2.0 §2.3:
    ``linux64``, ``darwin64``).

    Raises
    ------
    NeweulError
        On a platform FMI 2.0 names no folder for that the system compiler builds for.
    """
    bits = 64 if sys.maxsize > 2**32 else 32
    system = platform.system()
    if system == "Linux":
        return f"linux{bits}", ".so"
    if system == "Darwin":
        return f"darwin{bits}", ".dylib"
    raise NeweulError(f"FMUs are built on Linux and macOS (this is {system})")


def _guid(*texts: str) -> str:
    """A GUID-shaped digest (``{8-4-4-4-12}``) of the FMU's texts."""
    h = hashlib.sha256("\0".join(texts).encode()).hexdigest()
    return f"{{{h[:8]}-{h[8:12]}-{h[12:16]}-{h[16:20]}-{h[20:32]}}}"


def _compile(cc: str, src: Path, library: Path, c_files: Sequence[str]) -> None:
    # -pthread: the lock of neweul_fmi2.c (binaries are built on Linux and macOS only)
    cmd = [cc, *C_FLAGS, "-pthread", "-fvisibility=hidden", "-I", str(src),
           *(str(src / f) for f in c_files), "-o", str(library), "-lm"]
    try:
        proc = subprocess.run(cmd, capture_output=True, check=False)
    except OSError as exc:
        raise NeweulError(f"cannot run the C compiler {cc} ({exc.strerror})") from None
    if proc.returncode != 0:
        lines = proc.stderr.decode(errors="replace").strip().splitlines()
        lines = [ln for ln in lines if "error" in ln] or lines
        raise GenerationError(f"the C compiler {cc} failed to build the FMU: "
                              + " | ".join(lines[:5]))


def _zip(entries: dict[str, bytes]) -> bytes:
    """A zip archive of ``entries`` with fixed dates, in name order (deterministic)."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for name in sorted(entries):
            info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            zf.writestr(info, entries[name])
    return buf.getvalue()


def _model_sources(equations: Any, model: FmuModel, progress: StagedProgress
                   ) -> tuple[str, str, ElasticData | None]:
    """The C sources of the model (``model.c``, ``model_jac.c``) and, with elastic bodies, the
    data they are bound to: the kernel traced as the compiled backend traces it
    (:func:`.c_splice.render_elastic_sources`), its arrays for ``resources/``."""
    if getattr(equations, "elastic", None) is None:
        blocks = program_blocks(equations, progress=progress)
        names = [str(s) for s in equations.coordinates]
        if names != [v.name for v in model.coordinates]:
            raise GenerationError(f"the FMU's coordinates {[v.name for v in model.coordinates]}"
                                  f" are not those of the compiled equations {names}")
        core, jac = render_c_sources(equations, blocks, model.name)
        return core, jac, None
    src = render_elastic_sources(equations, model.name)
    if src.sizes["n"] != len(model.coordinates):
        raise GenerationError(f"the FMU has {len(model.coordinates)} coordinates, the compiled "
                              f"equations {src.sizes['n']}")
    # one binary: the derivatives' translation unit is bound under its own name
    jac = src.jac.replace("int nw_bind(", "int nw_bind_jac(", 1)
    content = b"".join(np.ascontiguousarray(a, dtype="<f8").tobytes() for a in src.arrays)
    return src.core, jac, ElasticData(f"{model.name}.bin", content,
                                      tuple(int(a.size) for a in src.arrays))


def write_fmu(equations: Any, model: FmuModel, path: str | os.PathLike[str],
              kinds: Sequence[str] = ("me", "cs"), *, tool: str = "neweul-py",
              progress: StagedProgress = None) -> Path:
    """Build the FMU of ``equations`` and write it to ``path`` (atomically).

    Parameters
    ----------
    equations
        The symbolic equations of the model (elastic bodies are traced, as for the compiled
        backend, their arrays go to ``resources/``).
    model
        Its variables (:func:`.fmu_model.fmu_model`), in the coordinates of the compiled
        equations.
    path
        The ``.fmu`` file.
    kinds
        ``"me"`` (model exchange), ``"cs"`` (co-simulation), or both.
    tool
        The ``generationTool`` attribute.
    progress
        A staged hook: ``("C code", …)`` of :func:`.writer.program_blocks`, then
        ``("FMU", done, 3)`` (sources, compiler, archive).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    GenerationError
        Equations the compiled backend cannot print, a compiler error.
    NeweulError
        No compiler, a platform without an FMI 2.0 folder, an unwritable ``path``.
    """
    cc = find_compiler()
    folder, suffix = binary_platform()
    core, jac, data = _model_sources(equations, model, progress)
    step = Steps(progress, "FMU", 3)
    glue = (_HERE / "neweul_fmi2.c").read_text(encoding="utf-8")
    draft = model_description(model, "", kinds, (), tool)
    guid = _guid(core, jac, glue, draft, model_header(model, "", kinds, data),
                 *(() if data is None else (data.content.hex(),)))
    c_files = ("model.c", "model_jac.c", "neweul_fmi2.c")
    sources = {"model.c": core, "model_jac.c": jac,
               "model.h": model_header(model, guid, kinds, data)}
    entries = {f"sources/{k}": v.encode() for k, v in sources.items()}
    if data is not None:
        entries[f"resources/{data.name}"] = data.content
    for f in _FIXED:
        entries[f"sources/{f}"] = (_HERE / f).read_bytes()
    entries["sources/LICENSE_fmi2.txt"] = (_HERE / "LICENSE.txt").read_bytes()
    entries["modelDescription.xml"] = model_description(model, guid, kinds, c_files,
                                                        tool).encode()
    step()
    with tempfile.TemporaryDirectory(prefix="neweul_fmu_") as tmp:
        src = Path(tmp) / "sources"
        src.mkdir()
        for name, data in entries.items():
            if name.startswith("sources/"):
                (src / name.removeprefix("sources/")).write_bytes(data)
        library = Path(tmp) / f"{model.name}{suffix}"
        _compile(cc, src, library, c_files)
        entries[f"binaries/{folder}/{model.name}{suffix}"] = library.read_bytes()
    step()
    out = atomic_write(path, _zip(entries))
    step()
    return out
