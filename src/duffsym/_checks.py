"""Input checks shared by the boundary classes (records, simulation, loop measures)."""

from __future__ import annotations

import numpy as np

from duffsym.errors import DataError


def require_increasing(t: np.ndarray, label: str) -> None:
    """Raise DataError unless ``t`` is strictly increasing; ``label`` names it in the message (e.g. ``"t"``)."""
    steps = np.flatnonzero(np.diff(t) <= 0)
    if steps.size:
        i = int(steps[0] + 1)
        raise DataError(
            f"{label} must be strictly increasing: {steps.size} non-increasing step(s), first at index {i} "
            f"(t={t[i]:g} s); sort or de-duplicate the samples"
        )
