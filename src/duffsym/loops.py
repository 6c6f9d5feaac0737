"""Metrics of one steady hysteresis cycle, measured on simulated or measured loops (no plotting).

A cycle is given by samples of the input displacement ``d``, its velocity ``d_dot`` and the output
``y`` over one excitation period. The metrics put numbers on the words the paper uses for its
Figs. 3 and 6: loop area, width, pre-/post-yield slopes, turning sharpness, orientation,
force amplitude and linearity.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from duffsym.errors import DataError


def signed_area(x: np.ndarray, y: np.ndarray) -> float:
    """Signed area enclosed by the closed polygon (x, y) (shoelace): > 0 when counter-clockwise."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def cycle_integral(x, y) -> float:
    """:math:`\\oint y\\,dx` over a closed cycle of samples, by the trapezoid rule (closed from the last
    sample back to the first): the d–y loop area, i.e. the work per cycle, when x = d and y is the force."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    return float(np.sum(0.5 * (y + np.roll(y, -1)) * (np.roll(x, -1) - x)))


def _crossings(s: np.ndarray, other: np.ndarray) -> list[tuple[float, int]]:
    """Values of ``other`` (linearly interpolated) where ``s`` changes sign, with the crossing direction."""
    out = []
    n = s.size
    for i in range(n):
        j = (i + 1) % n
        if s[i] == 0.0:
            out.append((float(other[i]), int(np.sign(s[j] - s[i]))))
        elif s[i] * s[j] < 0:
            w = s[i] / (s[i] - s[j])
            out.append((float(other[i] + w * (other[j] - other[i])), int(np.sign(s[j] - s[i]))))
    return out


def _gap(s: np.ndarray, other: np.ndarray) -> float:
    """Distance between the values of ``other`` at the rising and the falling zero crossing of ``s``."""
    cross = _crossings(s, other)
    up = [v for v, direction in cross if direction > 0]
    down = [v for v, direction in cross if direction < 0]
    if not up or not down:
        return float("nan")
    return abs(float(np.mean(up)) - float(np.mean(down)))


def _slope(x: np.ndarray, y: np.ndarray) -> float:
    if x.size < 2 or np.ptp(x) == 0:
        return float("nan")
    return float(np.polyfit(x, y, 1)[0])


@dataclass(frozen=True)
class LoopMetrics:
    """Numbers describing one steady hysteresis cycle.

    Attributes
    ----------
    peak : max |y| (the force amplitude).
    area_d : area of the d–y loop, :math:`\\oint y\\,dd` (the energy dissipated per cycle, > 0 for a
        passive device).
    area_v : signed area of the d'–y loop (shoelace): > 0 counter-clockwise, < 0 clockwise.
    orientation : ``"counter-clockwise"`` or ``"clockwise"`` (of the d'–y loop).
    width_v : d'-distance between the two branches at y = 0 (the pre-yield width of the d'–y loop).
    width_d : d-distance between the two branches at y = 0 in the d–y loop.
    height_v : y-distance between the branches at d' = 0.
    pre_yield_slope : mean dy/dd' of the two branches where |y| < ``pre_fraction`` * peak.
    post_yield_slope : dy/dd' where |d'| > ``post_fraction`` * max |d'| (both branches).
    sharpness : pre_yield_slope / post_yield_slope; large for a sharp pre/post-yield turn.
    linearity : R^2 of a straight-line fit of y on d' over the cycle (1 for a purely viscous device).
    """

    peak: float
    area_d: float
    area_v: float
    orientation: str
    width_v: float
    width_d: float
    height_v: float
    pre_yield_slope: float
    post_yield_slope: float
    sharpness: float
    linearity: float

    def summary(self) -> str:
        return (f"peak {self.peak:.4g}, d-y area {self.area_d:.4g}, d'-y area {self.area_v:.4g} ({self.orientation}), "
                f"width at y=0: d' {self.width_v:.4g}, d {self.width_d:.4g}; height at d'=0 {self.height_v:.4g}; "
                f"slopes pre {self.pre_yield_slope:.4g}, post {self.post_yield_slope:.4g} (sharpness "
                f"{self.sharpness:.3g}); linearity R^2 {self.linearity:.4f}")


def loop_metrics(d, d_dot, y, *, pre_fraction: float = 0.5, post_fraction: float = 0.8) -> LoopMetrics:
    """Measure one closed cycle of samples ``d, d_dot, y`` (each ``(n_times,)``).

    The samples must cover one period (the first and last samples need not coincide); take them
    with :func:`duffsym.simulate.steady_cycle` from a simulation.

    Parameters
    ----------
    pre_fraction : samples with |y| below this fraction of the peak define the pre-yield region.
    post_fraction : samples with |d'| above this fraction of its maximum define the post-yield region.
    """
    d, v, y = (np.asarray(a, dtype=float).reshape(-1) for a in (d, d_dot, y))
    if not (d.size == v.size == y.size):
        raise DataError(f"loop_metrics: d, d_dot and y must have the same length; got {d.size}, {v.size}, {y.size}")
    if d.size < 8:
        raise DataError(f"loop_metrics needs at least 8 samples of one cycle; got {d.size}")
    if not (np.all(np.isfinite(d)) and np.all(np.isfinite(v)) and np.all(np.isfinite(y))):
        raise DataError("loop_metrics: the cycle has non-finite samples (a failed simulation?); measure a finite cycle")
    peak = float(np.max(np.abs(y)))
    area_d = cycle_integral(d, y)
    area_v = signed_area(v, y)
    # branches of the d'-y loop: the accelerating branch (d' increasing) and the decelerating one
    accel = np.gradient(v) > 0
    pre = np.abs(y) < pre_fraction * peak
    slopes = [_slope(v[pre & mask], y[pre & mask]) for mask in (accel, ~accel)]
    pre_slope = float(np.nanmean(slopes)) if np.any(np.isfinite(slopes)) else float("nan")
    post = np.abs(v) > post_fraction * np.max(np.abs(v))
    post_slope = _slope(v[post], y[post])
    fit = np.polyfit(v, y, 1)
    resid = y - np.polyval(fit, v)
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    linearity = 1.0 - float(np.sum(resid**2)) / ss_tot if ss_tot > 0 else float("nan")
    return LoopMetrics(
        peak=peak, area_d=area_d, area_v=area_v,
        orientation="counter-clockwise" if area_v > 0 else "clockwise",
        width_v=_gap(y, v), width_d=_gap(y, d), height_v=_gap(v, y),
        pre_yield_slope=pre_slope, post_yield_slope=post_slope,
        sharpness=pre_slope / post_slope if post_slope else float("nan"),
        linearity=linearity,
    )


def trajectory_loop_metrics(traj, period: float, **kwargs) -> LoopMetrics:
    """:func:`loop_metrics` of the last full period of a simulated :class:`~duffsym.simulate.Trajectory`.

    The trajectory must have input channels ``d`` and ``d_dot``.
    """
    from duffsym.simulate import steady_cycle

    names = list(traj.input_names)
    if "d" not in names or "d_dot" not in names:
        raise DataError(f"trajectory of {traj.model} has inputs {names}; loop metrics need d and d_dot")
    sl = steady_cycle(traj, period)
    # steady_cycle includes both ends of the period; drop the repeated end point of the closed cycle
    idx = np.arange(traj.t.size)[sl][:-1]
    return loop_metrics(traj.u[idx, names.index("d")], traj.u[idx, names.index("d_dot")], traj.y[idx], **kwargs)
