"""Sanity of real records: clipped or frozen channels, and whether a record lies inside a fit's range.

Real test records carry stretches no model should be fitted to or scored on: a load cell that clips
(the force sits at exactly one value, the channel's extreme, while the device moves), a channel that
freezes (a displacement held at one value while the force goes on changing). :func:`check_record`
finds them in the displacement ``d`` and the force ``y`` and :func:`valid_part` leaves them out (the
leading/trailing ones cut off, the interior ones as a mask); ``duffsym fit`` and ``duffsym validate``
do so unless ``--keep-invalid`` is given, and say so in one line.

The rule (all thresholds are module constants):

- **Runs.** A run is a stretch of at least ``MIN_RUN`` (5) consecutive samples with *exactly* the same
  value (a measured, noisy channel never repeats exactly for long unless it is held). The signal's
  *quantum* ``q`` is its smallest non-zero step (the converter's or the printout's resolution).
- **Under motion.** An honest quantised signal also repeats near a turning point, where it stays within
  one quantum: a parabola that stays within ``q`` for the run's ``L`` samples leaves it with a slope of
  ``4 q / L`` per sample. A run is *under motion* on a side when the signal's mean step over the
  ``MIN_RUN`` samples next to it exceeds ``SLOPE_FACTOR`` (10) times that (only the side that exists for a
  run at either end of the record): a clipped or frozen channel is left and entered at the speed of the
  motion, not at the speed of a turning point.
- **Longer than the signal's own plateaus.** A signal with flat stretches of its own (the post-yield force
  plateau of an MR damper read by a coarse converter) repeats exactly while moving; a run counts only when
  it is more than ``RUN_FACTOR`` (3) times longer than the longest run under motion elsewhere in the same
  signal (away from its extremes, so a clipping level hit at every peak does not excuse itself).
- **Clipped:** such a run at the signal's maximum or minimum (within ``q/2``).
- **Frozen:** a run under motion on every side that exists, elsewhere, lasting at least ``MIN_SECONDS``
  (10 ms) and ``MIN_RUN`` samples, while the *other* signal's range during it exceeds ``MOTION_QUANTA`` (50) of
  its own quanta (both still is a device at rest, which is valid data).

The command channel is not checked: a held command is an ordinary test condition.

:func:`training_ranges` summarises the records a fit saw (command, displacement and velocity
amplitude, the input's frequency band) and :func:`range_notes` says in words when another record lies
outside them by more than ``RANGE_TOL`` (10 %) of the range's upper end (2 % for the command, of its span).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from duffsym.data.record import Record
from duffsym.errors import DataError

#: fewest equal consecutive samples that make a run
MIN_RUN = 5
#: a frozen run (not at the extreme) lasts at least this long, s
MIN_SECONDS = 0.01
#: a run is under motion when the slope next to it exceeds this many times that of a smooth turning point
SLOPE_FACTOR = 10.0
#: the other channel moves during a run when its range there exceeds this many of its quanta
MOTION_QUANTA = 50.0
#: a run is invalid only when longer than this many times the longest run under motion elsewhere in the signal
RUN_FACTOR = 3.0
#: a validation record's amplitude/frequency outside the training range by more than this fraction is noted
RANGE_TOL = 0.10
#: ... and its command outside by more than this fraction of the command's training span (or of its max)
COMMAND_TOL = 0.02
#: the input's frequency band leaves this share of its variance out at either end
BAND_TAIL = 0.025

SIGNALS = (("d", "displacement"), ("y", "force"))


@dataclass(frozen=True)
class Stretch:
    """One invalid stretch: samples ``start:stop`` (half-open) of ``signal`` held at ``value``.

    kind : ``"clipped"`` (at the channel's extreme) or ``"frozen"``; t_start, t_stop : its time span, s.
    """

    signal: str
    kind: str
    start: int
    stop: int
    t_start: float
    t_stop: float
    value: float

    @property
    def n(self) -> int:
        return self.stop - self.start

    def to_dict(self) -> dict:
        return dict(
            signal=self.signal,
            kind=self.kind,
            start=self.start,
            stop=self.stop,
            n=self.n,
            t_start=self.t_start,
            t_stop=self.t_stop,
            value=self.value,
        )

    def describe(self) -> str:
        return (
            f"{self.signal} {self.kind} at {self.value:.6g} for {self.t_stop - self.t_start:.3g} s "
            f"(t {self.t_start:.4g}-{self.t_stop:.4g} s, {self.n} samples)"
        )


@dataclass(frozen=True)
class SanityReport:
    """The invalid stretches of one record (:func:`check_record`)."""

    record: str
    n_times: int
    stretches: tuple
    quantum: dict

    @property
    def ok(self) -> bool:
        return not self.stretches

    @property
    def mask(self) -> np.ndarray:
        """(n_times,) True on every sample of an invalid stretch."""
        m = np.zeros(self.n_times, dtype=bool)
        for s in self.stretches:
            m[s.start : s.stop] = True
        return m

    @property
    def n_invalid(self) -> int:
        return int(self.mask.sum())

    def summary(self) -> str:
        """One line for a person."""
        if self.ok:
            return f"data check of {self.record}: no clipped or frozen stretch"
        return f"data check of {self.record}: {self.n_invalid} of {self.n_times} samples invalid: " + "; ".join(
            s.describe() for s in self.stretches
        )

    def to_dict(self) -> dict:
        return dict(
            record=self.record,
            n_times=self.n_times,
            n_invalid=self.n_invalid,
            ok=self.ok,
            stretches=[s.to_dict() for s in self.stretches],
            quantum=dict(self.quantum),
            rule=f"runs of >= {MIN_RUN} equal samples under motion (slope next to them > {SLOPE_FACTOR:g} x a "
            f"turning point's) and > {RUN_FACTOR:g} x the signal's longest plateau elsewhere: at the "
            f"channel's extreme = clipped; elsewhere, >= {MIN_SECONDS:g} s while the other channel moves "
            "= frozen",
        )


def quantum(x: np.ndarray) -> float:
    """The smallest non-zero step of ``x`` (its resolution); 0 for a constant signal."""
    steps = np.abs(np.diff(np.asarray(x, dtype=float)))
    steps = steps[steps > 0]
    return float(steps.min()) if steps.size else 0.0


def runs(x: np.ndarray, min_run: int = MIN_RUN) -> list[tuple[int, int]]:
    """Half-open ``(start, stop)`` of every stretch of at least ``min_run`` exactly equal consecutive samples."""
    eq = np.diff(np.asarray(x, dtype=float)) == 0
    edges = np.flatnonzero(np.diff(np.concatenate([[0], eq.astype(np.int8), [0]])))
    return [(int(a), int(b) + 1) for a, b in edges.reshape(-1, 2) if b + 1 - a >= min_run]


def _moves(x: np.ndarray, a: int, b: int, q: float) -> list[bool]:
    """For each side of the run ``a:b`` that exists, whether ``x`` is under motion there: its mean step over
    the ``MIN_RUN`` samples next to the run exceeds ``SLOPE_FACTOR`` times ``4 q / L``, the edge slope of a
    smooth turning point that stays within one quantum ``q`` for the run's ``L`` samples."""
    n, L = x.size, b - a
    w = MIN_RUN
    limit = SLOPE_FACTOR * 4.0 * q / L * w
    out = []
    if a > 0:
        out.append(abs(x[a] - x[max(a - w, 0)]) > limit)
    if b < n:
        out.append(abs(x[min(b - 1 + w, n - 1)] - x[b - 1]) > limit)
    return out


def _longest_elsewhere(x, moving_runs, skip, extremes, q) -> int:
    """The longest run under motion of ``x`` other than ``skip``, away from the extremes (1 when none)."""
    lengths = [b - a for a, b in moving_runs if (a, b) != skip and not any(abs(x[a] - e) <= 0.5 * q for e in extremes)]
    return max(lengths, default=1)


def _classify(x, other, run, moving_runs, q, q_other, dt, extremes) -> str | None:
    """``"clipped"``, ``"frozen"`` or None for the ``run`` of ``x`` (module docstring)."""
    a, b = run
    sides = _moves(x, a, b, q)
    if b - a < MIN_RUN or not any(sides):
        return None
    if b - a <= RUN_FACTOR * _longest_elsewhere(x, moving_runs, run, extremes, q):
        return None  # the signal holds this long elsewhere while moving: a plateau of the signal itself
    if any(abs(x[a] - e) <= 0.5 * q for e in extremes):
        return "clipped"
    long_enough = (b - a) >= max(MIN_RUN, math.ceil(MIN_SECONDS / dt))
    other_moves = np.ptp(other[a:b]) > MOTION_QUANTA * q_other
    return "frozen" if all(sides) and long_enough and other_moves else None


def check_record(record: Record) -> SanityReport:
    """The clipped and frozen stretches of ``record``'s displacement and force (module docstring)."""
    sig = {k: np.asarray(getattr(record, k), dtype=float) for k, _ in SIGNALS}
    q = {k: quantum(v) for k, v in sig.items()}
    t = np.asarray(record.t)
    found = []
    for (k, label), (k_other, _) in zip(SIGNALS, reversed(SIGNALS)):
        x = sig[k]
        extremes = (float(x.max()), float(x.min()))
        all_runs = runs(x, 2)
        moving = [r for r in all_runs if any(_moves(x, r[0], r[1], q[k]))]
        for run in moving:
            kind = _classify(x, sig[k_other], run, moving, q[k], q[k_other], record.dt, extremes)
            if kind:
                a, b = run
                found.append(Stretch(label, kind, a, b, float(t[a]), float(t[b - 1]), float(x[a])))
    found.sort(key=lambda s: (s.start, s.signal))
    return SanityReport(record.name or "(unnamed)", record.n_times, tuple(found), {label: q[k] for k, label in SIGNALS})


@dataclass(frozen=True)
class ValidPart:
    """A record without its invalid stretches: ``record`` is the original cut to ``start:stop`` (the
    invalid stretches at either end removed) and ``mask`` (True = invalid) marks the interior ones on it."""

    record: Record
    mask: np.ndarray
    start: int
    stop: int
    report: SanityReport

    def to_dict(self) -> dict:
        return {**self.report.to_dict(), "kept": [self.start, self.stop], "n_masked_inside": int(self.mask.sum())}


def valid_part(record: Record, report: SanityReport | None = None) -> ValidPart:
    """``record`` with its invalid stretches left out (see :class:`ValidPart`); unchanged when it has none."""
    report = check_record(record) if report is None else report
    bad = report.mask
    if not bad.any():
        return ValidPart(record, bad, 0, record.n_times, report)
    good = np.flatnonzero(~bad)
    start, stop = (int(good[0]), int(good[-1]) + 1) if good.size else (0, 0)
    if stop - start < 2 * MIN_RUN:
        from duffsym.errors import DataError

        raise DataError(
            f"record {report.record}: almost every sample is clipped or frozen ({report.summary()}); "
            "check the sensors, or pass --keep-invalid to use it as it is"
        )
    cut = record if (start, stop) == (0, record.n_times) else record.slice(start, stop)
    return ValidPart(cut, bad[start:stop].copy(), start, stop, report)


# ------------------------------------------------------------------ training ranges
def frequency_band(d, dt: float) -> tuple[float, float]:
    """(lo, hi): the frequencies between which the input ``d`` (mean removed, Hann window) carries the middle
    ``1 - 2 BAND_TAIL`` of its variance, Hz (a sine's band is its frequency)."""
    d = np.asarray(d, dtype=float)
    p = np.abs(np.fft.rfft((d - d.mean()) * np.hanning(d.size))) ** 2
    p[0] = 0.0
    f = np.fft.rfftfreq(d.size, dt)
    c = np.cumsum(p) / max(float(np.sum(p)), 1e-300)
    lo, hi = int(np.searchsorted(c, BAND_TAIL)), int(np.searchsorted(c, 1 - BAND_TAIL))
    return float(f[min(lo, f.size - 1)]), float(f[min(hi, f.size - 1)])


def _record_ranges(record: Record) -> dict:
    d = np.asarray(record.d, dtype=float)
    out: dict[str, Any] = {"amplitude": [0.5 * float(np.ptp(d))] * 2}
    if record.is_uniform():
        out["frequency_hz"] = list(frequency_band(d, record.dt))
        out["velocity_amplitude"] = [0.5 * float(np.ptp(record.velocity()))] * 2
    try:
        c = record.command_signal()
        out["command"] = [float(np.min(c)), float(np.max(c))]
        out["command_name"] = record.command_name or ("current" if record.current is not None else "voltage")
    except DataError:  # no command: nothing to compare
        pass
    return out


def training_ranges(records) -> dict:
    """``{quantity: [lo, hi]}`` over the records a fit saw: ``command`` (its name in ``command_name``),
    ``amplitude`` (half the input's peak-to-peak), ``velocity_amplitude``, ``frequency_hz`` (the input's band,
    :func:`frequency_band`)."""
    per = [_record_ranges(r) for r in records]
    out: dict = {}
    for key in ("command", "amplitude", "velocity_amplitude", "frequency_hz"):
        vals = [p[key] for p in per if key in p]
        if vals:
            out[key] = [min(v[0] for v in vals), max(v[1] for v in vals)]
    if "command" in out:
        out["command_name"] = per[0].get("command_name", "command")
    return out


_WORDS = {"amplitude": "amplitude", "velocity_amplitude": "velocity amplitude", "frequency_hz": "frequency band (Hz)"}


def range_notes(ranges: dict, record: Record) -> list[str]:
    """One sentence per quantity of ``record`` outside the fit's ``ranges`` (:func:`training_ranges`)."""
    if not ranges:
        return []
    here = _record_ranges(record)
    notes = []
    if "command" in ranges and "command" in here:
        lo, hi = ranges["command"]
        tol = COMMAND_TOL * max(hi - lo, abs(hi), 1e-12)
        c_lo, c_hi = here["command"]
        if c_lo < lo - tol or c_hi > hi + tol:
            name = ranges.get("command_name", "command")
            notes.append(f"the {name} spans {c_lo:.4g}..{c_hi:.4g}, outside the fit's {lo:.4g}..{hi:.4g}")
    for key, word in _WORDS.items():
        if key not in ranges or key not in here:
            continue
        lo, hi = ranges[key]
        x_lo, x_hi = here[key]
        # a band is known to two frequency bins (1 / duration) of the record's spectrum
        slack = 2.0 / record.duration if key == "frequency_hz" else 0.0
        if x_hi > hi * (1 + RANGE_TOL) + slack or x_lo < lo * (1 - RANGE_TOL) - slack:
            text = f"{x_lo:.4g}" if x_lo == x_hi else f"{x_lo:.4g}..{x_hi:.4g}"
            fit = f"{lo:.4g}" if lo == hi else f"{lo:.4g}..{hi:.4g}"
            notes.append(f"the {word} {text} lies outside the fit's {fit}")
    return notes
