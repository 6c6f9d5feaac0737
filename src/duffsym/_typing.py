"""Array aliases used in signatures (time is always the first axis)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Union

import numpy as np
import numpy.typing as npt

Float1D = npt.NDArray[np.float64]
Float2D = npt.NDArray[np.float64]
ParamVector = npt.NDArray[np.float64]
ParamLike = Union[Mapping[str, float], "npt.ArrayLike"]
