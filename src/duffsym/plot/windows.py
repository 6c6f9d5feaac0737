"""Which stretches of a record a loop plot shows: whole input cycles where the record has them, windows where not.

A loop (force against displacement or velocity) closes only over a whole cycle of a periodic input.
A sine test has such cycles; a sweep or a random record has none, and a stretch cut from it from one
upward zero crossing to the next does not close (on a 1-15 Hz sweep: a jump at d = 0). So
:func:`loop_windows` first asks whether the input repeats — most cycles (upward crossings of
``d - mean(d)``) of the median length and stroke — and returns whole cycles only then; otherwise it returns
windows of about one typical crossing interval, and says so, so a figure can say "window" and not
"steady cycle".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: cycles count as repeating when consecutive lengths differ by at most this fraction and strokes too
REPEAT_TOL = 0.05


@dataclass(frozen=True)
class LoopWindows:
    """Stretches of a record to draw loops of.

    Attributes
    ----------
    slices : the stretches (sample slices), in time order.
    whole_cycles : True when each is one whole cycle of a repeating input; False for windows of a
        record whose input does not repeat (a sweep, a random record).
    reason : why, in words (shown in figure titles).
    """

    slices: tuple
    whole_cycles: bool
    reason: str

    def describe(self, t, i: int) -> str:
        """``"cycle, t = 2.1-2.6 s"`` or ``"window, t = 2.1-2.6 s"`` for stretch ``i``."""
        sl = self.slices[i]
        tt = np.asarray(t)[sl]
        return f"{'cycle' if self.whole_cycles else 'window'}, t = {tt[0]:.3g}-{tt[-1]:.3g} s"


def _cycles(d: np.ndarray, skip: float) -> list[tuple[int, int]]:
    v = d - np.mean(d)
    rising = np.flatnonzero((v[:-1] <= 0) & (v[1:] > 0))
    return [(int(a), int(b)) for a, b in zip(rising[:-1], rising[1:]) if a >= skip * d.size]


def _repeating(d: np.ndarray, cycles: list[tuple[int, int]]) -> list[int]:
    """Indices of the cycles of a repeating input: within ``REPEAT_TOL`` of the median length and stroke.

    The input repeats when at least 60 % of the cycles (and two) match the median: a sine test does
    (its ramp-down at the end does not), a sweep (lengths falling through the record) and a random
    record do not, and then no index is returned.
    """
    lengths = np.array([b - a for a, b in cycles], dtype=float)
    strokes = np.array([np.ptp(d[a : b + 1]) for a, b in cycles])
    ok = (np.abs(lengths - np.median(lengths)) <= REPEAT_TOL * np.median(lengths)) & (
        np.abs(strokes - np.median(strokes)) <= REPEAT_TOL * max(float(np.median(strokes)), 1e-300)
    )
    keep = [int(i) for i in np.flatnonzero(ok)]
    return keep if len(keep) >= max(2, 0.6 * len(cycles)) else []


def loop_windows(d, *, count: int = 2, skip: float = 0.25, error=None) -> LoopWindows:
    """Up to ``count`` stretches of the record with input ``d`` for loop plots.

    Parameters
    ----------
    d : the input (displacement), one value per sample.
    count : how many stretches at most.
    skip : leading fraction of the record left out (the start-up transient).
    error : optional per-sample error (measured minus predicted): the stretches are then the one with
        the largest input stroke and the one with the largest RMS error; without it, the largest
        strokes, the latest of equal ones.

    Returns
    -------
    LoopWindows
        Whole cycles when the input repeats, else windows of the median crossing interval (or an
        eighth of the record when the input hardly crosses its mean).
    """
    d = np.asarray(d, dtype=float)
    cycles = _cycles(d, skip)
    rep = _repeating(d, cycles) if len(cycles) >= 2 else []
    if rep:
        cand = [cycles[i] for i in rep]
        whole, reason = True, f"the input repeats ({len(rep)} matching cycles)"
    else:
        width = int(np.median([b - a for a, b in cycles])) if cycles else max(d.size // 8, 2)
        start0 = int(skip * d.size)
        cand = [(a, min(a + width, d.size - 1)) for a in range(start0, d.size - width, max(width // 2, 1))] or [
            (0, d.size - 1)
        ]
        whole = False
        reason = (
            "the input does not repeat (cycles differ in length or stroke), so no loop closes"
            if cycles
            else "the input hardly crosses its mean"
        )
    chosen = _choose(d, cand, count, error)
    return LoopWindows(tuple(slice(a, b + 2 if whole else b + 1) for a, b in sorted(chosen)), whole, reason)


def _choose(d, cand, count, error) -> list[tuple[int, int]]:
    stroke = [np.ptp(d[a : b + 1]) for a, b in cand]
    order = sorted(range(len(cand)), key=lambda i: (round(stroke[i] / max(max(stroke), 1e-300), 3), i), reverse=True)
    picked = [cand[order[0]]]
    if error is not None and count > 1:
        e = np.asarray(error, dtype=float)
        rms = [float(np.sqrt(np.nanmean(e[a : b + 1] ** 2))) for a, b in cand]
        worst = cand[int(np.nanargmax(rms))]
        if worst not in picked:
            picked.append(worst)
    for i in order[1:]:
        if len(picked) >= count:
            break
        if cand[i] not in picked and all(abs(cand[i][0] - p[0]) >= (p[1] - p[0]) for p in picked):
            picked.append(cand[i])
    return picked[:count]
