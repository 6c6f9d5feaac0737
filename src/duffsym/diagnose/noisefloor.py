"""Which noise level a diagnosis can measure on a record, and how: raw, smoothed, or not at all.

The third-difference estimate (:func:`~duffsym.diagnose.residuals.noise_level`) assumes white noise
on a finely sampled signal. Published records are often pre-filtered, and then it measures something
else:

- **A short moving average** (a few samples, as a logger or a user applies it) colours the noise: its
  third differences see only what the average left at high frequencies, so the estimate comes out
  about 2x low (measured 0.42-0.54 of the true filtered noise for 3-5 samples). The average also
  distorts the signal itself by several times the noise (yield corners are rounded), which no
  model of the device reproduces. The width is detected from the shape of the force's spectrum
  near the Nyquist frequency, where the noise dominates: a moving average of w samples puts nulls
  at multiples of fs/w (:func:`detect_moving_average`). The diagnosis then fits the models to the
  force restored by a regularised inverse of that average (:func:`restore`) and judges every free
  run *through the same average* against the measured force, so a correct model leaves exactly the
  filtered noise, whose level is estimated with the average taken into account
  (:func:`smoothed_noise_level`).
- **A low-pass filter or no noise** (no white floor near Nyquist, see
  :func:`~duffsym.diagnose.residuals.has_noise_floor`) and **a force quantised before a long moving
  average** (the authors' UTFSM records: runs of equal increments, the same third-difference
  "noise" whatever the force level, :func:`stepped_share`): the noise cannot be measured from the
  record. The diagnosis says so and uses the held-out residual floor (the lowest held-out RMS of any
  fitted model, an upper bound) as its reference; the verdict does not quote "x the noise".
- **A low-pass filter** also rounds the force's sharp corners (a friction's switch, a yield corner) by
  many times the noise left in the record, which no model of the device reproduces: a perfect model
  judged against a force through a zero-phase 15 Hz Butterworth filter (200 Hz sampling) is 8-19x that
  noise off. The cutoff is found from the ratio of the measured force's spectrum to a fitted free run's
  (:func:`lowpass_cutoff`: where the force keeps less than half of what the model carries), and every
  free run and the measured force are then judged in the band below half that cutoff
  (:func:`in_band`), where the filter left the force intact: the same perfect model is then 1.0-1.3x
  the noise in that band (2x on one record of five).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from duffsym.diagnose.residuals import has_noise_floor, noise_level

#: moving-average widths (samples) looked for; longer averages leave no noise near Nyquist
MA_WIDTHS = tuple(range(3, 9))
#: a width is detected when the spectrum's misfit falls by this much (mean squared log-power) ...
MA_GAIN = 1.0
#: ... and to below this share of the white-noise misfit
MA_SHARE = 0.6
#: the largest gain of the regularised inverse of the moving average (:func:`restore`)
RESTORE_GAIN = 20.0
#: share of exactly-zero second differences above which the force is called quantised and smoothed
STEPPED = 0.05
_DIFF3 = np.array([1.0, -3.0, 3.0, -1.0])
#: spectral bins of a model's free run that :func:`lowpass_cutoff` uses: power above this share of its peak
LOWPASS_BINS = 1e-6
#: the judging band's edge as a share of the low-pass cutoff found (see the module docstring)
BAND_SHARE = 0.5
#: highest low-pass cutoff looked for (cycles per sample): above it the band left out is too thin to matter
LOWPASS_MAX = 0.35
#: least share of the measured force's variance the judging band must keep: a band that cuts into the signal
#: itself (a long moving average, a filter at the excitation's own frequencies) would hide the models' errors
BAND_KEEPS = 0.9


def _ma_response2(f: np.ndarray, w: int) -> np.ndarray:
    """|H(f)|² of a w-sample moving average at frequencies ``f`` (cycles per sample)."""
    den = w * np.sin(np.pi * f)
    out = np.ones_like(f)
    nz = np.abs(den) > 1e-12
    out[nz] = (np.sin(np.pi * f[nz] * w) / den[nz]) ** 2
    return out


def spectrum_misfit(y, widths=(1,) + MA_WIDTHS) -> dict[int, float]:
    """Mean squared log-misfit of the force's Welch spectrum over the upper 70 % of the band against a
    scaled w-sample moving-average response (w = 1: white noise), per width."""
    from scipy.signal import welch

    y = np.asarray(y, dtype=float)
    f, P = welch(y - np.mean(y), fs=1.0, nperseg=int(min(256, max(16, y.size // 4))))
    m = f >= 0.15
    lp = np.log(P[m] + 1e-300)
    out = {}
    for w in widths:
        lm = np.log(_ma_response2(f[m], w) + 1e-3)
        c = float(np.median(lp - lm))
        out[w] = float(np.mean((lp - lm - c) ** 2))
    return out


def detect_moving_average(y) -> int:
    """The width (samples) of a moving average the force was smoothed with, or 1 when its spectrum near
    Nyquist is that of white noise (or of the signal). A width w in ``MA_WIDTHS`` is taken when its
    response fits the spectrum much better than white noise does (``MA_GAIN``, ``MA_SHARE``); measured
    on independent records: 3- and 5-sample averages found in 8/8, raw records (sine, multisine,
    random; clean, backlash, friction, lag) never."""
    mis = spectrum_misfit(y)
    w = min(MA_WIDTHS, key=lambda k: mis[k])
    return w if mis[w] <= mis[1] - MA_GAIN and mis[w] <= MA_SHARE * mis[1] else 1


def moving_average(y, w: int) -> np.ndarray:
    """The centred w-sample moving average (along the first axis), the ends padded with the end values."""
    y = np.asarray(y, dtype=float)
    if w <= 1:
        return y.copy()
    if y.ndim > 1:
        return np.apply_along_axis(moving_average, 0, y, w)
    pad = np.pad(y, (w // 2, w - 1 - w // 2), mode="edge")
    return np.convolve(pad, np.ones(w) / w, mode="valid")


def _ma_matrix(n: int, w: int):
    """The sparse (n, n) matrix of :func:`moving_average` (end values repeated beyond the ends)."""
    from scipy.sparse import coo_matrix

    row_parts, col_parts = [], []
    for j in range(-(w // 2), w - w // 2):
        row_parts.append(np.arange(n))
        col_parts.append(np.clip(np.arange(n) + j, 0, n - 1))
    rows, cols = np.concatenate(row_parts), np.concatenate(col_parts)
    return coo_matrix((np.full(rows.size, 1.0 / w), (rows, cols)), shape=(n, n)).tocsr()


def restore(y, w: int, gain: float = RESTORE_GAIN) -> np.ndarray:
    """The force before a w-sample moving average, as far as it can be restored: the Tikhonov-regularised
    inverse, argmin |A x - y|² + λ|x|² with A the average of :func:`moving_average` (ends included) and
    λ = 1/(4 gain²), so that no frequency is amplified more than ``gain`` times; frequencies near the
    average's nulls (which held almost only noise) stay damped. Measured on independent records
    (5-sample average, gain 20): the average of the restored force is within 0.07 % (NRMSE) of the
    measured force (0.2 % with gain 5, whose losses near the nulls exceed the noise), and the restored
    force within 0.6-1.5 % of the force before averaging, about the raw noise."""
    from scipy.sparse import identity
    from scipy.sparse.linalg import spsolve

    y = np.asarray(y, dtype=float)
    if w <= 1:
        return y.copy()
    A = _ma_matrix(y.size, w)
    lhs = (A.T @ A + identity(y.size, format="csr") / (4 * gain**2)).tocsc()
    return np.asarray(spsolve(lhs, A.T @ y), dtype=float)


def smoothed_noise_level(y, w: int) -> float:
    """Standard deviation of the noise left in ``y`` after a w-sample moving average of white noise:
    the third differences' robust spread divided by that of the averaged noise's (so w = 1 is
    :func:`~duffsym.diagnose.residuals.noise_level`)."""
    if w <= 1:
        return noise_level(y)
    h = np.convolve(_DIFF3, np.ones(w) / w)
    dk = np.diff(np.asarray(y, dtype=float), n=3)
    spread = 1.4826 * float(np.median(np.abs(dk - np.median(dk))))
    sigma_raw = spread / math.sqrt(float(np.sum(h**2)))
    return sigma_raw / math.sqrt(w)


def stepped_share(y) -> float:
    """Share of the force's second differences that are exactly zero (to 1e-6 of max |y|): equal
    consecutive increments. A moving average over a quantised force changes its increment only when a
    quantum enters or leaves the window, so such records hold runs of equal increments (3-28 % on the
    UTFSM tests of at least 4000 samples); a force with any measurable noise holds none (0 % on
    independent records, raw or averaged)."""
    y = np.asarray(y, dtype=float)
    d2 = np.abs(np.diff(y, 2))
    if d2.size < 20:
        return 0.0
    return float(np.mean(d2 <= 1e-6 * float(np.max(np.abs(y)) or 1.0)))


def lowpass_cutoff(y, y_model) -> float | None:
    """The cutoff (cycles per sample) of a low-pass filter the measured force ``y`` went through, or None.

    From the transfer ratio |P_{ŷy}| / P_{ŷŷ} of a fitted free run ŷ to the force (Welch estimates), on the
    bins where the free run carries power (``LOWPASS_BINS`` of its peak): the cutoff is the first such bin
    from which the ratio stays below one half, with at least three such bins above it. A model that follows
    the force keeps the ratio near 1 in the pass band whatever its own errors; measured on independent
    records (zero-phase Butterworth, order 4, at 200 Hz sampling; sine, multisine and random inputs): 16-17 Hz
    for a 15 Hz filter, 29-32 Hz for a 30 Hz one; none on raw records."""
    from scipy.signal import csd, welch

    y = np.asarray(y, dtype=float)
    yh = np.asarray(y_model, dtype=float)
    if y.size < 64 or not np.all(np.isfinite(yh)):
        return None
    n = int(min(256, max(16, y.size // 4)))
    f, pxy = csd(yh - yh.mean(), y - y.mean(), fs=1.0, nperseg=n)
    _, pxx = welch(yh - yh.mean(), fs=1.0, nperseg=n)
    if not pxx.max() > 0:
        return None
    strong = np.flatnonzero(pxx >= LOWPASS_BINS * pxx.max())
    low = np.abs(pxy[strong]) / pxx[strong] < 0.5
    for j in range(strong.size - 2):
        if low[j:].all():
            fc = float(f[strong[j]])
            return fc if 0 < fc <= LOWPASS_MAX else None
    return None


def judging_band(y, y_model) -> float | None:
    """The band edge (cycles per sample) for a force without a white-noise floor: ``BAND_SHARE`` of the
    :func:`lowpass_cutoff` found from the free run ``y_model``, when that band keeps at least ``BAND_KEEPS`` of the
    force's variance (measured 0.95-0.99 on independent records through a 15 Hz filter at 200 Hz); None without a
    cutoff or when the band would cut into the signal itself."""
    fc = lowpass_cutoff(y, y_model)
    if fc is None:
        return None
    band = BAND_SHARE * fc
    y = np.asarray(y, dtype=float)
    kept = float(np.var(in_band(y, band)) / np.var(y)) if np.var(y) > 0 else 0.0
    return band if kept >= BAND_KEEPS else None


def in_band(y, band: float | None) -> np.ndarray:
    """``y`` (along its first axis) through a zero-phase Butterworth low-pass (order 4, applied forwards and
    backwards) at ``band`` cycles per sample (None: unchanged)."""
    from scipy.signal import butter, filtfilt

    y = np.asarray(y, dtype=float)
    if band is None:
        return y.copy()
    b, a = butter(4, 2 * band)
    return np.asarray(filtfilt(b, a, y, axis=0), dtype=float)


@dataclass(frozen=True)
class NoiseEstimate:
    """How the noise of a record is measured.

    sigma : the estimate (of the noise *left in* the record, after any detected moving average).
    method : in words, for the verdict.
    measurable : False when the record carries no measurable noise floor (low-pass filtered,
        noise-free, or quantised and smoothed): ``sigma`` is then only the third-difference number and
        the diagnosis replaces it by the held-out residual floor.
    smoothing : the detected moving-average width (1: none).
    stepped : share of equal consecutive increments of the force (quantised and smoothed when >= ``STEPPED``).
    band : the judging band's edge (cycles per sample) when the force was found low-pass filtered
        (:func:`lowpass_cutoff`; None: judged over the whole band).
    """

    sigma: float
    method: str
    measurable: bool = True
    smoothing: int = 1
    stepped: float = 0.0
    band: float | None = None

    def measured(self, y) -> np.ndarray:
        """The measured force as every free run is judged against it: in the judging band, if any."""
        return in_band(y, self.band)

    def restored(self, record):
        """``record`` (a :class:`~duffsym.data.record.Record`) as the models are fitted to it: its force restored by
        :func:`restore` when a moving average was detected, else ``record`` itself."""
        if self.smoothing <= 1:
            return record
        return record.replace(y=restore(np.asarray(record.y, dtype=float), self.smoothing))

    def judged(self, y_model) -> np.ndarray:
        """A free run of the fitted force as it is judged: through the detected moving average (the models
        were fitted to the restored force) and in the judging band, if any. Along the first axis: the columns
        of a regression's matrix go through the same."""
        return in_band(moving_average(y_model, self.smoothing), self.band)

    def to_dict(self) -> dict:
        return dict(
            sigma=self.sigma,
            method=self.method,
            measurable=self.measurable,
            smoothing=self.smoothing,
            stepped=self.stepped,
            band=self.band,
        )


def estimate_noise(y, dt: float) -> NoiseEstimate:
    """The noise estimate a diagnosis uses for the measured force ``y`` (see the module docstring)."""
    y = np.asarray(y, dtype=float)
    third = noise_level(y)
    steps = stepped_share(y)
    if steps >= STEPPED:
        return NoiseEstimate(
            third,
            f"not measurable: {100 * steps:.0f} % of the force's consecutive increments are "
            "equal (a quantised force, then smoothed), so the third-difference estimate "
            f"({third:.3g}) measures the quantisation, not the noise",
            measurable=False,
            stepped=steps,
        )
    if not has_noise_floor(y, dt):
        return NoiseEstimate(
            third,
            "not measurable: the force has no white-noise floor near the Nyquist frequency "
            f"(low-pass filtered or noise-free), so the third-difference estimate ({third:.3g}) "
            "measures its smoothness",
            measurable=False,
        )
    w = detect_moving_average(y)
    if w > 1:
        return NoiseEstimate(
            smoothed_noise_level(y, w),
            f"third differences of the measured force, corrected for "
            f"a {w}-sample moving average detected in its spectrum",
            smoothing=w,
        )
    return NoiseEstimate(third, "third differences of the measured force")
