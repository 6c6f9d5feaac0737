"""What drifts, and with what: windowed refits and a drifting parameter.

When the residual of a base fit grows (or shrinks) over the record — the diagnosis measures it: the
last quarter's RMS against the first quarter's, and the rank correlation of the window RMS with time
— :func:`windowed_refits` refits the base model on consecutive windows of the *fitting part* (whole
input cycles) from the base fit and reports how each parameter changes from window to window.
:func:`discover_drift` then lets the parameters that change most (monotone, by more than 10 %)
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

from duffsym.effects.drift import ParameterDrift

#: the residual "grows over the record" (the diagnosis's trend): growth above this, or below its inverse
GROWTH = 1.5
#: a parameter counts as drifting when its windowed values change monotonically by more than this (relative)
MIN_CHANGE = 0.10
#: at most this many drifting parameters are tried (each with time and with energy)
MAX_PARAMETERS = 2
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
        """The parameters that change monotonically by more than ``MIN_CHANGE``, largest change first."""
        names = [n for n in self.change if self.monotone[n] and abs(self.change[n]) > MIN_CHANGE]
        return sorted(names, key=lambda n: -abs(self.change[n]))

    def to_dict(self) -> dict:
        return dict(bounds=self.bounds, params=self.params, stderr=self.stderr, change=self.change,
                    monotone=self.monotone, signals=self.signals, drifting=self.drifting())

    def summary(self) -> str:
        rows = [f"  {n}: " + " -> ".join(f"{v:.4g}" for v in self.params[n]) + f" ({100 * self.change[n]:+.0f} %)"
                for n in self.change]
        return "windowed refits of the fitting part:\n" + "\n".join(rows)


def _window_bounds(record, k: int, n: int) -> list[tuple[int, int]]:
    from duffsym.diagnose.residuals import rising_crossings

    cut = rising_crossings(np.asarray(record.d)[:k])
    edges = [0]
    for j in range(1, n):
        target = j * k / n
        near = cut[np.abs(cut - target) < 0.5 * k / n] if cut.size else cut
        edges.append(int(near[np.argmin(np.abs(near - target))]) if near.size else int(round(target)))
    edges.append(k)
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
    mids = {s: [] for s in sig}
    for a, b in bounds:
        win = record.replace(t=record.t[a:b], d=record.d[a:b], y=record.y[a:b], d_dot=v[a:b],
                             command=None if record.command is None else record.command[a:b])
        fr = _fit(model, win, fx, dict(dg.base_fit.params))
        for n in params:
            params[n].append(float(fr.params[n]) if fr.success else math.nan)
            stderr[n].append(float(fr.stderr.get(n, math.nan)) if fr.success else math.nan)
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


def candidates(record, dg, windows: Windows) -> list[ParameterDrift]:
    """Drift effects to try: each drifting parameter (at most ``MAX_PARAMETERS``) following time, and
    following the dissipated energy; ``u_ref`` = the signal at the end of the fitting part."""
    k = dg.split["n_fit"]
    out = []
    for name in windows.drifting()[:MAX_PARAMETERS]:
        for signal in ("energy", "time"):
            ref = float(record.drift_signal(signal)[k - 1])
            if ref > 0:
                out.append(ParameterDrift(name, signal, ref))
    return out


def guess(effect: ParameterDrift, windows: Windows) -> float:
    """The drift coefficient ``a`` the windowed refits imply (a straight line through them in the signal)."""
    x = np.asarray(windows.params[effect.parameter], float)
    u = np.asarray(windows.signals[effect.signal], float) / effect.scale
    ok = np.isfinite(x)
    if ok.sum() < 2 or np.ptp(u[ok]) == 0:
        return 0.0
    slope, icpt = np.polyfit(u[ok], x[ok], 1)
    return float(np.clip(-slope / icpt if icpt else 0.0, -0.9, 0.9))
