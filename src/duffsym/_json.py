"""JSON-safe values: numpy scalars and arrays to Python, non-finite floats to None (JSON has no NaN/inf)."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np


def finite_or_none(value) -> float | None:
    """``float(value)``, or None when it is NaN or infinite."""
    value = float(value)
    return value if math.isfinite(value) else None


def jsonable(obj):
    """``obj`` with mappings, sequences, numpy arrays and scalars made JSON-safe, recursively."""
    if isinstance(obj, Mapping):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (np.floating, float)):
        return finite_or_none(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    return obj
