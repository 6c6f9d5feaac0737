"""The settings of :func:`~duffsym.diagnose.diagnose` and :func:`~duffsym.diagnose.ladder` as options objects
(:mod:`duffsym.options`), and the decision rules' defaults they start from."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

BIC_THRESHOLD = -10.0
MIN_IMPROVEMENT = 0.10
MIN_EXPLAINED = 0.50
#: near the noise, the held-out fall a candidate must reach is at most this share of the fall the noise leaves
#: possible (:func:`required_improvement`)
POSSIBLE_SHARE = 0.5


def required_improvement(min_improvement: float, mse_held: float, noise: float, measurable: bool = True) -> float:
    """The held-out RMSE fall a candidate must reach: ``min_improvement``, or ``POSSIBLE_SHARE`` of the fall the
    noise leaves possible when that is less. A base whose held-out error is 1.1x the noise can fall at most 9 %:
    a fixed 10 % would refuse an effect that removes all of its excess error (measured on independent records: a
    stroke-dependent friction term removing 79 % of the excess, ΔBIC -71, a held-out fall of 8.8 %); at 1.5x the
    noise and above the rule is ``min_improvement`` itself. A ``noise`` that is not ``measurable`` (a floor: the
    best fitted model's own held-out error) leaves the fixed rule: the fall it leaves possible would be measured by
    the candidate itself."""
    if not (measurable and mse_held > 0 and noise > 0):
        return min_improvement
    possible = 1.0 - min(1.0, noise / mse_held**0.5)
    return min(min_improvement, POSSIBLE_SHARE * possible)


#: IPOPT iterations for a candidate's fit (see :func:`diagnose`)
CANDIDATE_MAX_ITER = 100
#: IPOPT CPU seconds for a candidate's fit (see :func:`diagnose`)
CANDIDATE_CPU_TIME = 30.0
SCREEN = 4
#: two candidates whose held-out RMSE differ by less than this (relative) are reported as a tie
TIE = 0.05
#: the ladder's backward pass keeps a simpler model whose BIC is at most this much above the richer one's: a
#: difference under 2 is "not worth more than a bare mention" (Kass & Raftery 1995), so the evidence cannot
#: separate them and the fewer parameters win. Entering needs BIC_THRESHOLD (-10), leaving only this: the
#: stepwise-regression rule of a stricter threshold to enter than to stay, so that no effect flips back and forth
PARSIMONY_BIC = 2.0
#: candidates (best first) whose fitted set is checked against the derived stability certificate
STABILITY_CHECKED = 4
#: base held-out NRMSE below which the model is said to fit the record exactly (noise-free data)
EXACT_FIT = 1e-3
#: the residual "grows over the record" (the diagnosis's trend): growth above this, or below its inverse
GROWTH = 1.5
#: default time budget of a ladder run (seconds): the issue's bound for any real record
DEFAULT_BUDGET = 600.0


@dataclass(frozen=True)
class DiagnoseOptions:
    """Every setting of :func:`~duffsym.diagnose.diagnose` (its docstring describes each), with its default."""

    fit_result: Any = None
    start: Mapping[str, float] | None = None
    candidates: Iterable[str] | None = None
    fixed: Mapping[str, float] | None = None
    holdout: float = 0.3
    noise: float | None = None
    mask: Any = field(default=None, compare=False)
    bic_threshold: float = BIC_THRESHOLD
    min_improvement: float = MIN_IMPROVEMENT
    min_explained: float = MIN_EXPLAINED
    candidate_max_iter: int = CANDIDATE_MAX_ITER
    candidate_cpu_time: float | None = CANDIDATE_CPU_TIME
    screen: int | None = SCREEN
    sindy: bool = True
    decimate: bool | int = True
    progress: Any = None
    engine: Any = None
    second_start: bool = True
    deadline: float | None = None


@dataclass(frozen=True)
class LadderOptions:
    """Every setting of :func:`~duffsym.diagnose.ladder` (its docstring describes each), with its default.
    ``rules``: settings of each step's :func:`~duffsym.diagnose.diagnose` (``bic_threshold``, ``screen``,
    ``sindy``, ``decimate``, ``engine``, ...: any of its settings but those the ladder sets itself); :func:`ladder`
    also takes them by keyword."""

    max_steps: int = 4
    candidates: Iterable[str] | None = None
    fixed: Mapping[str, float] | None = None
    holdout: float = 0.3
    noise: float | None = None
    mask: Any = field(default=None, compare=False)
    accept: str = "needed"
    discover: bool = True
    progress: Callable[[str], None] | None = None
    budget: float | None = None
    joint: bool = True
    on_step: Callable | None = None
    rules: Mapping[str, Any] = field(default_factory=dict)
