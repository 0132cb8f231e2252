"""Fixtures of the codegen tests: hand-derived equations (see ``handmade.py``)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
