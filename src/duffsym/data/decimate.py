"""Decimate a record for fitting where its spectrum allows (used by ``diagnose``, ``ladder`` and ``fit``).

The fits of a diagnosis (base and every candidate) cost time in proportion to the number of
samples, and a finely sampled record carries far more samples than its dynamics need: the UTFSM MR
damper tests are sampled at 1 kHz for a 1 Hz stroke whose force has nothing above ~40 Hz. The
fitting data are therefore decimated to the lowest rate that keeps the output's whole significant
spectrum well inside the pass band; the evidence (free runs, held-out errors, ΔBIC, residual
analysis) is still computed on the record at its own rate.

How the rate is chosen (:func:`choose_decimation`): the amplitude spectrum of the output and of the
input (Hann window, mean removed) gives each signal's *bandwidth*, the highest frequency whose
amplitude exceeds both ``REL`` (1e-3, −60 dB: a line below it carries under 0.1 % of the output) of
the spectrum's peak and ``FLOOR_FACTOR`` (10) times the noise floor (the median amplitude over the
upper half of the band). The new sample rate is at
least ``OVERSAMPLE`` (4) times the larger bandwidth, so that every significant harmonic lies below
half the new Nyquist frequency, where the anti-aliasing filter is flat; at least ``MIN_PER_CYCLE``
(50) samples per period of the input's main frequency (the collocation interpolates the input
linearly between samples); and the decimated fitting data keep at least ``MIN_SAMPLES`` samples.

How it is decimated (:func:`decimate_record`): a zero-phase low-pass FIR (Hamming window, cut-off at
the new Nyquist frequency, ``20 q + 1`` taps, as :func:`scipy.signal.decimate`), applied to the
displacement, the velocity and the force with odd-reflection padding at both ends (no edge dip,
unlike zero padding), then every ``q``-th sample from the first. The first sample keeps its time, so
the fitted initial state belongs to the same instant as on the full record.

The rule for ``duffsym fit`` (:func:`choose_fit_decimation`, ``energy`` given): broadband device records
(the Dyke record: random displacement and a switching voltage, anti-alias filtered at 100 Hz) carry force
lines above -60 dB up to ~650 Hz, so the amplitude rule above keeps them at their full 3 kHz rate, while
99.7 % of the force's variance lies below 227 Hz. With ``energy`` the bandwidth of each signal is instead
the frequency below which it keeps ``1 - energy`` of its variance (Hann-windowed periodogram, mean
removed), and the new Nyquist frequency must be at least that bandwidth (the part given up is at most
``energy`` of the variance, an NRMSE floor of ``sqrt(energy)`` added in quadrature: 0.055 for the default
``FIT_ENERGY`` = 3e-3, which puts the Dyke record at 500 Hz, the rate study s11 found to give the same
validation error as 1 kHz; 1e-3 keeps 750 Hz, 1.5 times the samples to fit, and 1e-2 keeps 250 Hz: NRMSE
0.200 at the fitted rate but 0.234 on the full-rate record; s11 records the fit times); the floors are
``FIT_MIN_PER_CYCLE`` (25) samples per input period and ``FIT_MIN_SAMPLES`` (200). The command channel is
low-passed with the others but does not set the rate (the field's first-order lag smooths its steps).

This module moved here from ``duffsym.diagnose.prepare`` (which re-exports it) so that the data layer,
identification and the command line can use it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from duffsym.data.record import Record
from duffsym.errors import DataError

#: relative amplitude (to the spectrum's peak) below which a spectral line is not significant
REL = 1e-3
#: a spectral line is significant only above this many times the noise floor
FLOOR_FACTOR = 10.0
#: the new sample rate is at least this many times the larger bandwidth
OVERSAMPLE = 4.0
#: fewest samples per period of the input's main frequency after decimation
MIN_PER_CYCLE = 50
#: fewest samples the decimated fitting data keep
MIN_SAMPLES = 400
#: ``duffsym fit``'s default share of each signal's variance that may lie above the new Nyquist frequency
FIT_ENERGY = 3e-3
#: ``duffsym fit``'s floors: samples per input period (s11 measured the UTFSM campaign's fits the same to three
#: decimals at 25, 50 and 100) and fitting samples per record
FIT_MIN_PER_CYCLE = 25
FIT_MIN_SAMPLES = 200


@dataclass(frozen=True)
class Preparation:
    """The decimation applied to the fitting data of a diagnosis.

    factor : q (1: the record is used as it is); rate, rate_in : sample rates after/before (Hz);
    bandwidth, input_bandwidth : of the output and of the input (Hz, see the module docstring);
    main_frequency : the input's strongest frequency (Hz); n_in, n_out : samples before/after;
    reason : why this factor, in words.
    """

    factor: int
    rate: float
    rate_in: float
    bandwidth: float
    input_bandwidth: float
    main_frequency: float
    n_in: int
    n_out: int
    reason: str

    def to_dict(self) -> dict:
        return dict(
            factor=self.factor,
            rate=self.rate,
            rate_in=self.rate_in,
            bandwidth=self.bandwidth,
            input_bandwidth=self.input_bandwidth,
            main_frequency=self.main_frequency,
            n_in=self.n_in,
            n_out=self.n_out,
            reason=self.reason,
        )

    def summary(self) -> str:
        if self.factor == 1:
            return (
                f"fits on the record at its own rate ({self.rate_in:.4g} Hz, {self.n_in} fitting samples): "
                f"{self.reason}"
            )
        return (
            f"fits on the record decimated by {self.factor} ({self.rate_in:.4g} -> {self.rate:.4g} Hz, "
            f"{self.n_in} -> {self.n_out} fitting samples; output bandwidth {self.bandwidth:.3g} Hz, input "
            f"{self.input_bandwidth:.3g} Hz): {self.reason}"
        )


def bandwidth(x, dt: float) -> tuple[float, float]:
    """(bandwidth, strongest frequency) of ``x`` sampled at ``dt`` (see the module docstring), in Hz."""
    x = np.asarray(x, dtype=float)
    a = np.abs(np.fft.rfft((x - np.mean(x)) * np.hanning(x.size)))
    f = np.fft.rfftfreq(x.size, dt)
    a[0] = 0.0
    peak = float(np.max(a))
    if not peak > 0 or not np.isfinite(peak):
        return 0.0, 0.0
    floor = float(np.median(a[a.size // 2 :]))
    sig = np.nonzero(a > max(REL * peak, FLOOR_FACTOR * floor))[0]
    return float(f[sig.max()]), float(f[int(np.argmax(a))])


def energy_bandwidth(x, dt: float, energy: float) -> tuple[float, float]:
    """(bandwidth, strongest frequency) of ``x``: the lowest frequency below which ``x`` (mean removed,
    Hann window) keeps ``1 - energy`` of its variance, in Hz."""
    x = np.asarray(x, dtype=float)
    p = np.abs(np.fft.rfft((x - np.mean(x)) * np.hanning(x.size))) ** 2
    f = np.fft.rfftfreq(x.size, dt)
    p[0] = 0.0
    total = float(np.sum(p))
    if not total > 0 or not np.isfinite(total):
        return 0.0, 0.0
    k = int(np.searchsorted(np.cumsum(p) / total, 1.0 - float(energy)))
    return float(f[min(k, f.size - 1)]), float(f[int(np.argmax(p))])


def choose_decimation(
    record: Record,
    *,
    n_fit: int | None = None,
    max_factor: int | None = None,
    energy: float | None = None,
    min_per_cycle: int | None = None,
    min_samples: int | None = None,
) -> Preparation:
    """The decimation factor for ``record`` (see the module docstring); ``n_fit`` samples will be fitted
    (default: all); ``max_factor`` caps q (1: no decimation); ``energy`` switches to the variance rule
    of ``duffsym fit`` (the new Nyquist frequency above the frequency keeping ``1 - energy`` of each
    signal's variance) instead of the amplitude rule; ``min_per_cycle``, ``min_samples``: the floors
    (default ``MIN_PER_CYCLE``, ``MIN_SAMPLES``)."""
    per_cycle = MIN_PER_CYCLE if min_per_cycle is None else int(min_per_cycle)
    fewest = MIN_SAMPLES if min_samples is None else int(min_samples)
    n = record.n_times
    n_fit = n if n_fit is None else int(n_fit)
    if not record.is_uniform():
        return Preparation(
            1,
            math.nan,
            math.nan,
            math.nan,
            math.nan,
            math.nan,
            n_fit,
            n_fit,
            "the sampling is not uniform, so the record is not decimated",
        )
    dt = record.dt
    fs = 1.0 / dt
    if energy is None:
        fb_y, _ = bandwidth(record.y, dt)
        fb_d, f0 = bandwidth(record.d, dt)
        need = max(OVERSAMPLE * max(fb_y, fb_d), per_cycle * f0)
        why = (
            f"the new rate is at least {OVERSAMPLE:g}x the bandwidth and {per_cycle} samples per input "
            f"period ({f0:.3g} Hz)"
        )
    else:
        fb_y, _ = energy_bandwidth(record.y, dt, energy)
        fb_d, _ = energy_bandwidth(record.d, dt, energy)
        _, f0 = bandwidth(record.d, dt)
        need = max(2.0 * max(fb_y, fb_d), per_cycle * f0)
        why = (
            f"the new Nyquist frequency keeps {1 - energy:.4g} of the force's and the input's variance below "
            f"it, and at least {per_cycle} samples per input period ({f0:.3g} Hz)"
        )
    q = int(math.floor(fs / need)) if need > 0 else 1
    if n_fit // max(q, 1) < fewest:
        q = min(q, max(1, n_fit // fewest))
        why += f", and at least {fewest} fitting samples"
    if max_factor is not None:
        q = min(q, max(1, int(max_factor)))
    q = max(q, 1)
    if q == 1:
        why = ("its spectrum needs the full rate (" + why + ")") if max_factor != 1 else "decimation switched off"
    return Preparation(q, fs / q, fs, fb_y, fb_d, f0, n_fit, -(-n_fit // q), why)


def _lowpass(x: np.ndarray, taps: np.ndarray) -> np.ndarray:
    """Zero-phase FIR filter with odd-reflection padding (the value and slope continue across each end)."""
    m = taps.size // 2
    m_pad = min(m, x.size - 1)
    head = 2 * x[0] - x[m_pad:0:-1]
    tail = 2 * x[-1] - x[-2 : -m_pad - 2 : -1]
    xp = np.concatenate([np.full(m - m_pad, head[0]), head, x, tail, np.full(m - m_pad, tail[-1])])
    return np.convolve(xp, taps, mode="valid")


def decimate_record(record: Record, q: int) -> Record:
    """``record`` low-passed (zero-phase FIR, cut-off at the new Nyquist frequency) and every ``q``-th
    sample kept, from the first. q = 1 returns the record itself."""
    q = int(q)
    if q < 1:
        raise DataError(f"the decimation factor must be a positive integer; got {q}")
    if q == 1:
        return record
    from scipy.signal import firwin

    record.require_uniform("decimation")
    taps = firwin(20 * q + 1, 1.0 / q, window="hamming")
    keep = slice(0, None, q)
    d, y = np.asarray(record.d, dtype=float), np.asarray(record.y, dtype=float)
    v = np.asarray(record.velocity(), dtype=float)
    meta = dict(record.metadata)
    meta["decimated"] = {
        "factor": q,
        "filter": f"zero-phase FIR, {taps.size} taps, Hamming, cut-off at the new Nyquist",
    }
    return record.replace(
        t=np.asarray(record.t)[keep],
        d=_lowpass(d, taps)[keep],
        y=_lowpass(y, taps)[keep],
        d_dot=_lowpass(v, taps)[keep],
        metadata=meta,
        command=None if record.command is None else _lowpass(np.asarray(record.command), taps)[keep],
    )


def decimate_mask(mask, q: int, n_out: int):
    """A per-sample mask for the decimated record: a kept sample leaves the objective when any original
    sample within half a new sampling interval of it does (None stays None)."""
    if mask is None or q == 1:
        return mask
    m = np.asarray(mask, dtype=bool)
    out = np.zeros(n_out, dtype=bool)
    h = q // 2
    for j in range(n_out):
        out[j] = m[max(0, j * q - h) : j * q + h + 1].any()
    return out


def prepare_record(record: Record, decimate: bool | int = True, *, n_fit: int | None = None, **rule):
    """(preparation, record to fit): ``record`` decimated by the factor :func:`choose_decimation` picks
    from ``record``'s spectrum (``decimate``: True, a cap on the factor, or False/1 for none; ``rule``:
    :func:`choose_decimation`'s ``energy``, ``min_per_cycle``, ``min_samples``)."""
    cap = 1 if decimate is False else (None if decimate is True else int(decimate))
    prep = choose_decimation(record, n_fit=n_fit, max_factor=cap, **rule)
    return prep, decimate_record(record, prep.factor)


def prepare_for_fit(record: Record, decimate: bool | int = True, *, energy: float = FIT_ENERGY):
    """(preparation, record to fit) by the variance rule of ``duffsym fit`` (module docstring):
    ``decimate`` True (the spectrum's factor), an int (a cap on it) or False (none)."""
    return prepare_record(record, decimate, energy=energy, min_per_cycle=FIT_MIN_PER_CYCLE, min_samples=FIT_MIN_SAMPLES)
