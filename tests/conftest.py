"""Shared fixtures. ``tests/`` is on sys.path so that the independent SciPy reference
(``tests/reference.py``) can be imported as ``reference``."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
