"""Shared test set-up: the studies folder is importable (tests check the studies' computations)."""

import sys
from pathlib import Path

STUDIES = Path(__file__).resolve().parents[1] / "studies"
if str(STUDIES) not in sys.path:
    sys.path.insert(0, str(STUDIES))
