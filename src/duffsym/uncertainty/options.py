"""The settings of :func:`~duffsym.uncertainty.sample` as an options object (:mod:`duffsym.options`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class SampleOptions:
    """Every setting of :func:`~duffsym.uncertainty.sample` (its docstring describes each), with its default."""

    n_walkers: int = 32
    n_steps: int = 5000
    burn: int | None = None
    thin: int | None = None
    noise: str = "gaussian"
    bounds: Mapping[str, tuple[float, float]] | None = None
    mask: Any = field(default=None, compare=False)
    rng: Any = None
    pool: Any = None
    vectorize: bool | None = None
    progress: bool = False
    init_spread: float = 1.0
    h_rho: float = 1.0
    hrho_max: float = 2.0
    on_short: str = "warn"
    recheck_draws: int = 16
    sigma_draws: int = 2000
    moves: Any = None
    threads: int | None = 1
    sample_x0: bool = True
    checkpoint: Any = None
    checkpoint_every: float = 30.0
