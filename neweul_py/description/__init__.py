"""Description layer: the safe expression parser, the Python builder API and the YAML loader.

Imports only the ``model`` layer, ``errors`` and the YAML reader ``yaml_tree`` (plus
sympy and PyYAML).
"""

from .builder import SystemBuilder
from .expressions import ExpressionError, format_expression, parse_expression
from .loader import (
    description_hash,
    load_description,
    load_description_text,
    load_description_tree,
)

__all__ = [
    "ExpressionError",
    "SystemBuilder",
    "description_hash",
    "format_expression",
    "load_description",
    "load_description_text",
    "load_description_tree",
    "parse_expression",
]
