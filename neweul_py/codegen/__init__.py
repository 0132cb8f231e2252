"""Code generation: symbolic equations → standalone NumPy modules (``docs/architecture.md``).

:func:`generate_module` writes a module implementing the generated-module protocol
(docs/generated-module-protocol.md) atomically and deterministically; :func:`render_module`
returns its text. Imports ``equations`` and ``model`` only.
"""

from .module import generate_module, render_module
from .writer import PROTOCOL_VERSION

__all__ = ["PROTOCOL_VERSION", "generate_module", "render_module"]
