"""Shared test configuration: the reference builders of ``tests/support`` are importable by name
(``from fe_builders import piston_duct``) from every test directory."""

import sys
from pathlib import Path

SUPPORT = Path(__file__).resolve().parent / "support"
if str(SUPPORT) not in sys.path:
    sys.path.insert(0, str(SUPPORT))
