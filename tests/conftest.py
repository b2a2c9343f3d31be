"""Shared test configuration."""

import os
import sys
from pathlib import Path

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
os.environ.setdefault("MPLBACKEND", "Agg")


# test modules import each other and the shared scenarios by name, as when
# tests/ was one flat folder: every folder of tests/ is importable (appended, so nothing in it
# shadows an installed module; test file names are unique).
for _folder in sorted({str(p.parent) for p in Path(__file__).parent.rglob("test_*.py")}):
    if _folder not in sys.path:
        sys.path.append(_folder)
