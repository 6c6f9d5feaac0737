"""What drifts, and with what: windowed refits and a drifting parameter.

When the residual of a base fit grows (or shrinks) over the record — the diagnosis measures it: the
last quarter's RMS against the first quarter's, and the rank correlation of the window RMS with time
— :func:`windowed_refits` refits the base model on consecutive windows of the *fitting part* (whole
input cycles) from the base fit and reports how each parameter changes from window to window.
:func:`discover_drift` then lets the parameters whose change is most significant (monotone, by more than 5 %)
follow the record's time or the energy dissipated since its start
(:class:`duffsym.effects.drift.ParameterDrift`, ``p·(1 - a·u/u_ref)``), fits each such model on the
fitting part through the normal path and keeps the one with the lowest BIC there; the held-out tail
judges it by the same evidence as a catalogued effect (the caller,
:func:`duffsym.diagnose.discover.discover_term`, applies the rules).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from duffsym.diagnose.options import GROWTH
from duffsym.effects.drift import ParameterDrift
from duffsym.errors import DataError, ModelError

#: a parameter counts as drifting when its windowed values change monotonically by more than this (relative)
MIN_CHANGE = 0.05
#: at most this many drifting parameters are tried with the dissipated energy (the best of them also with time);
#: windowed refits trade parameters off (on a short sine record with c2, c3 falling by 30-45 %, c3 fell by 7 %
#: and k1 by 12 % between two windows), so the largest windowed change alone does not name the parameter
MAX_PARAMETERS = 3
N_WINDOWS = 3


def trending(dg) -> bool:
    """The base fit's residual grows or shrinks over the record (the diagnosis's trend measure)."""
    tr = dg.residuals.trend
    g, rho = float(tr.get("growth", 1.0)), float(tr.get("spearman", 0.0))
    return bool((g > GROWTH and rho > 0.5) or (g < 1 / GROWTH and rho < -0.5))


@dataclass(frozen=True)
class Windows:
    """Refits of the base model on consecutive windows of the fitting part."""

    bounds: list  # (first, stop) sample indices
    params: dict  # name -> fitted value per window
    stderr: dict
    change: dict  # name -> (last - first) / |mean| over the windows (relative change)
    monotone: dict  # name -> the windowed values change in one direction
    signals: dict = field(default_factory=dict)  # "time"/"energy" -> value at each window's middle

    def drifting(self) -> list[str]:
        """The parameters that change monotonically by more than ``MIN_CHANGE``, the most significant change
        first (:meth:`significance`; ties by the relative change)."""
        names = [n for n in self.change if self.monotone[n] and abs(self.change[n]) > MIN_CHANGE]
        return sorted(names, key=lambda n: (-self.significance(n), -abs(self.change[n])))

    def significance(self, name: str) -> float:
        """The change of ``name`` from the first window to the last in standard errors of that difference (0 when
        a window's standard error is not finite). A change of 11 % with a standard error of 14 % (c2 on a short
        sine record whose force a moving average smoothed) ranks behind one of 7 % with 3 % (c3, the parameter
        that drifted): the relative change alone put c2 first and c3 fourth."""
        x, se = self.params[name], self.stderr[name]
        ok = [i for i in range(len(x)) if math.isfinite(x[i])]
        if len(ok) < 2:
            return 0.0
        a, b = ok[0], ok[-1]
        spread = math.hypot(se[a], se[b])
        return abs(x[b] - x[a]) / spread if math.isfinite(spread) and spread > 0 else 0.0

    def to_dict(self) -> dict:
        return dict(
            bounds=self.bounds,
            params=self.params,
            stderr=self.stderr,
            change=self.change,
            monotone=self.monotone,
            signals=self.signals,
            drifting=self.drifting(),
        )

    def summary(self) -> str:
        rows = [
            f"  {n}: " + " -> ".join(f"{v:.4g}" for v in self.params[n]) + f" ({100 * self.change[n]:+.0f} %)"
            for n in self.change
        ]
        return "windowed refits of the fitting part:\n" + "\n".join(rows)


def _window_bounds(record, k: int, n: int) -> list[tuple[int, int]]:
    """Consecutive windows of the first ``k`` samples, cut at rising crossings of ``d`` so that each holds
    at least two input cycles (fewer windows on a short record, at least two)."""
    from duffsym.diagnose.residuals import rising_crossings

    cut = rising_crossings(np.asarray(record.d)[:k])
    cut = cut[(cut > 0) & (cut < k)]
    n = max(2, min(n, cut.size // 2)) if cut.size else n
    edges = [0]
    for j in range(1, n):
        target = j * k / n
        edges.append(int(cut[np.argmin(np.abs(cut - target))]) if cut.size else int(round(target)))
    edges.append(k)
    edges = sorted(set(edges))
    return [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b - a > 20]


def windowed_refits(record, model, dg, fixed=None, n_windows: int = N_WINDOWS) -> Windows:
    """The base model refitted (from ``dg``'s base fit) on ``n_windows`` consecutive windows of the fitting part."""
    from duffsym.diagnose.search import _fit, with_default_af

    k = dg.split["n_fit"]
    fx = with_default_af(model, fixed, record)
    v = np.asarray(record.velocity())
    params: dict = {n: [] for n in dg.base_fit.free}
    stderr: dict = {n: [] for n in dg.base_fit.free}
    bounds = _window_bounds(record, k, n_windows)
    sig = {s: record.drift_signal(s) for s in ("time", "energy")}
    mids: dict[str, list[float]] = {s: [] for s in sig}
    for a, b in bounds:
        win = record.replace(
            t=record.t[a:b],
            d=record.d[a:b],
            y=record.y[a:b],
            d_dot=v[a:b],
            command=None if record.command is None else record.command[a:b],
        )
        try:
            fr = _fit(model, win, fx, dict(dg.base_fit.params))
        except (DataError, ModelError):  # a window the fit cannot use: no values from it
            fr = None
        ok = fr is not None and fr.success
        for n in params:
            params[n].append(float(fr.params[n]) if ok else math.nan)
            stderr[n].append(float(fr.stderr.get(n, math.nan)) if ok else math.nan)
        for s in sig:
            mids[s].append(float(sig[s][(a + b) // 2]))
    change, monotone = {}, {}
    for n, vals in params.items():
        x = np.asarray(vals)
        ok = np.isfinite(x)
        mean = float(np.mean(np.abs(x[ok]))) if ok.any() else 0.0
        change[n] = float((x[ok][-1] - x[ok][0]) / mean) if ok.sum() >= 2 and mean > 0 else 0.0
        steps = np.diff(x[ok])
        monotone[n] = bool(steps.size and (np.all(steps > 0) or np.all(steps < 0)))
    return Windows(bounds=bounds, params=params, stderr=stderr, change=change, monotone=monotone, signals=mids)


def any_change(windows: Windows) -> list[str]:
    """Every parameter whose windowed refits changed at all, largest change first: the fallback when none
    changes monotonically. Windowed refits trade parameters off (on the independent heating sine record,
    seed 9, three windows gave c3 -13 % but not monotone, k1 -78 %), so the caller ranks these by their
    linearised drift (:func:`duffsym.diagnose.discover._drift_ranking`) and the fits' evidence decides."""
    moved = [n for n, c in windows.change.items() if math.isfinite(c) and c != 0.0]
    return sorted(moved, key=lambda n: -abs(windows.change[n]))


def candidates(record, dg, windows: Windows, signal: str = "energy", names=None) -> list[ParameterDrift]:
    """Drift effects to try: each drifting parameter (at most ``MAX_PARAMETERS``, or ``names``) following
    ``signal``; ``u_ref`` = the signal at the end of the fitting part."""
    k = dg.split["n_fit"]
    ref = float(record.drift_signal(signal)[k - 1])
    if not ref > 0:
        return []
    return [ParameterDrift(n, signal, ref) for n in (names or windows.drifting()[:MAX_PARAMETERS])]


def guess(effect: ParameterDrift, windows: Windows) -> float:
    """The drift coefficient ``a`` the windowed refits imply (a straight line through them in the signal)."""
    x = np.asarray(windows.params[effect.parameter], float)
    u = np.asarray(windows.signals[effect.signal], float) / effect.scale
    ok = np.isfinite(x)
    if ok.sum() < 2 or np.ptp(u[ok]) == 0:
        return 0.0
    slope, icpt = np.polyfit(u[ok], x[ok], 1)
    return float(np.clip(-slope / icpt if icpt else 0.0, -0.9, 0.9))
