"""Description layer: the safe expression parser, the Python builder API and the YAML loader.

Imports only the ``model`` layer and ``errors`` (plus sympy and PyYAML).
"""

from .builder import SystemBuilder
from .expressions import ExpressionError, format_expression, parse_expression

__all__ = [
    "ExpressionError",
    "SystemBuilder",
    "format_expression",
    "parse_expression",
]
