"""Sub-commands of the ``neweul`` CLI, one module each (see :mod:`neweul_py.cli`).

Building the parser imports no symbolic layer (sympy): command modules import
:mod:`neweul_py.api` (which pulls in ``codegen``) only when they run on a description file.
"""

from __future__ import annotations

import argparse

#: Forms of the equations offered by ``--form``; the same as :data:`neweul_py.api.FORMS` (kept
#: here so that registering the sub-commands needs no symbolic layer; a test checks they agree).
FORMS: tuple[str, ...] = ("auto", "closed", "recursive")
#: Backends offered by ``--backend``; the same as :data:`neweul_py.api.BACKENDS`.
BACKENDS: tuple[str, ...] = ("numpy", "c")


def comma_floats(text: str) -> list[float]:
    """Argument type of comma-separated numbers (``--points 100,200``, ``--values -4000,0``)."""
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}"
                                         ) from None
