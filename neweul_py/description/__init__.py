"""Description layer: the safe expression parser, the Python builder API and the YAML loader.

Imports only the ``model`` layer and ``errors`` (plus sympy and PyYAML).
"""

from .builder import SystemBuilder
from .expressions import ExpressionError, format_expression, parse_expression
from .loader import description_hash, load_description, load_description_text

__all__ = [
    "ExpressionError",
    "SystemBuilder",
    "description_hash",
    "format_expression",
    "load_description",
    "load_description_text",
    "parse_expression",
]
