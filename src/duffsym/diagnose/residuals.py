"""Where a model fails: the structure of the free-run residual ``r = y - ŷ``.

Everything here is computed from a record and a model's free-run output, with no refit:

- a noise level estimated from the measurement alone (:func:`noise_level`), so that "the residual
  is at noise level" has a meaning independent of the model;
- binned statistics over regions a damper engineer reasons in: velocity bands, the neighbourhood
  of velocity reversals, pre-/post-yield force levels, compression vs extension;
- residual maps over the (d, d') plane and over the cycle phase;
- per-cycle dissipated-energy error;
- whiteness (autocorrelation) and residual–input cross-correlation with significance bounds;
- the error over time (does it grow?).

:func:`analyse_residuals` gathers them; :meth:`ResidualAnalysis.findings` turns them into short
statements for people, each with the number behind it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from duffsym._json import jsonable
from duffsym.data.record import Record, zero_crossings
from duffsym.errors import DataError
from duffsym.identify.result import nrmse as _nrmse
from duffsym.plot.loops import cycle_integral

#: Normal quantile of the two-sided 95 % bounds of sample correlations of white noise.
Z95 = 1.959963984540054
#: Lags (samples) of the whiteness and cross-correlation checks, at most.
MAX_LAG = 50
#: Residual RMS over the noise from which a search outside the catalogue runs (:attr:`ResidualAnalysis.worth_a_search`).
SEARCH_EXCESS = 1.25


def noise_level(y, *, order: int = 3) -> float:
    r"""Standard deviation of white measurement noise in ``y``, from ``y`` alone.

    The ``order``-th difference of a smooth signal sampled finely is small, while that of white
    noise of variance :math:`\sigma^2` has variance :math:`\binom{2k}{k}\sigma^2` (20σ² for k = 3).
    The median absolute deviation makes the estimate robust to the few samples where the signal
    itself bends sharply (yield corners), so

    .. math:: \hat\sigma = \frac{1.4826\,\mathrm{MAD}(\Delta^k y)}{\sqrt{\binom{2k}{k}}}.

    It over-estimates σ when the signal is coarsely sampled (its own k-th differences are not
    small); it is an upper bound of the noise in that case, which keeps "at noise level" verdicts
    on the cautious side.
    """
    y = np.asarray(y, dtype=float)
    if y.size < order + 10:
        raise DataError(f"noise_level needs at least {order + 10} samples; got {y.size}")
    dk = np.diff(y, n=order)
    mad = float(np.median(np.abs(dk - np.median(dk))))
    return 1.4826 * mad / math.sqrt(math.comb(2 * order, order))


#: High-band over mid-band power of the measured force below which it has no white-noise floor
#: near the Nyquist frequency (pre-filtered or noise-free); see :func:`has_noise_floor`.
FLOOR_RATIO = 0.03


def band_power_ratio(y, dt: float) -> float:
    """Median Welch power of ``y`` in the top 20 % of the band over that in 40-60 % of it.

    White measurement noise puts a flat floor under the whole spectrum, so the ratio stays near
    (or above) a few tenths wherever the signal itself has died out (measured on independent
    records with 1 % noise at dt = 5 ms: 0.05-0.7 raw, also with a 3- or 5-sample moving average);
    a low-pass pre-filter or the absence of noise takes the floor away (0.000-0.01 with a 15 or
    60 Hz Butterworth filter or no noise).
    """
    from scipy.signal import welch

    y = np.asarray(y, dtype=float)
    f, P = welch(y - np.mean(y), fs=1.0 / dt, nperseg=int(min(256, max(16, y.size // 4))))
    fn = f[-1]
    mid = float(np.median(P[(f >= 0.4 * fn) & (f < 0.6 * fn)]))
    top = float(np.median(P[f >= 0.8 * fn]))
    return top / mid if mid > 0 else 0.0


def has_noise_floor(y, dt: float) -> bool:
    """Whether the measured force shows a white-noise floor near Nyquist (see :func:`band_power_ratio`):
    without one, the third-difference :func:`noise_level` measures smoothness, not noise."""
    return band_power_ratio(y, dt) >= FLOOR_RATIO


def autocorrelation(r, max_lag: int = MAX_LAG) -> np.ndarray:
    """Sample autocorrelation of ``r`` at lags 0..max_lag (biased estimator, as in Box–Jenkins)."""
    r = np.asarray(r, dtype=float) - np.mean(r)
    n = r.size
    denom = float(np.dot(r, r))
    if denom == 0:
        return np.zeros(max_lag + 1)
    return np.array([np.dot(r[: n - k], r[k:]) / denom for k in range(max_lag + 1)])


def cross_correlation(r, u, max_lag: int = MAX_LAG) -> np.ndarray:
    """Sample cross-correlation of residual ``r`` with input ``u`` at lags -max_lag..max_lag
    (positive lag: the residual follows the input)."""
    r = np.asarray(r, dtype=float) - np.mean(r)
    u = np.asarray(u, dtype=float) - np.mean(u)
    n = r.size
    denom = math.sqrt(float(np.dot(r, r)) * float(np.dot(u, u)))
    out = np.zeros(2 * max_lag + 1)
    if denom == 0:
        return out
    for i, k in enumerate(range(-max_lag, max_lag + 1)):
        out[i] = np.dot(r[max(k, 0) : n + min(k, 0)], u[max(-k, 0) : n - max(k, 0)]) / denom
    return out


def ljung_box(acf: np.ndarray, n: int) -> tuple[float, float]:
    """Ljung–Box statistic over the lags of ``acf`` (lag 0 excluded) and its chi-square p-value."""
    from scipy.special import chdtrc  # chi-square survival function (scipy.stats is a much heavier import)

    h = acf.size - 1
    k = np.arange(1, h + 1)
    q = float(n * (n + 2) * np.sum(acf[1:] ** 2 / (n - k)))
    return q, float(chdtrc(h, q))


def reversal_distance(v: np.ndarray) -> np.ndarray:
    """For each sample, the number of samples since the last sign change of ``v`` (a large number
    before the first one)."""
    v = np.asarray(v, dtype=float)
    nz = np.flatnonzero(v != 0)
    out = np.full(v.size, v.size, dtype=int)
    if nz.size < 2:
        return out
    sv = np.sign(v[nz])
    rev = nz[1:][sv[1:] != sv[:-1]]
    last = -1
    j = 0
    for i in range(v.size):
        while j < rev.size and rev[j] <= i:
            last = int(rev[j])
            j += 1
        if last >= 0:
            out[i] = i - last
    return out


@dataclass(frozen=True)
class Bin:
    """Residual statistics over one region of the data."""

    region: str
    n: int
    rms: float
    mean: float
    share: float  # share of the total squared residual
    rms_ratio: float  # rms here / rms over all samples

    def to_dict(self) -> dict:
        return dict(
            region=self.region, n=self.n, rms=self.rms, mean=self.mean, share=self.share, rms_ratio=self.rms_ratio
        )


@dataclass(frozen=True)
class ResidualAnalysis:
    """The structure of a free-run residual (see the module docstring).

    Attributes
    ----------
    nrmse, rmse : free-run errors (the contract's NRMSE, and RMS in output units).
    noise : noise level estimated from the measurement alone (:func:`noise_level`).
    excess : ``rmse / noise``: about 1 when the model explains everything but noise.
    mean : mean residual (a force offset shows here), ``mean_z`` its size in standard errors.
    bins : statistics per region (velocity bands, reversals, yield, direction).
    acf, acf_bound, acf_outside, ljung_box_p : whiteness: autocorrelation at lags 0..L, the 95 %
        bound of white noise, the fraction of lags 1..L outside it, and the Ljung–Box p-value.
    xcorr : per input channel, ``{"max": max |ccf|, "lag": its lag, "bound": 95 % bound}``.
    trend : error over time: RMS in consecutive windows, ``growth`` = RMS of the last quarter over
        the first quarter, and the Spearman correlation of window RMS with time.
    cycle_energy : per whole input cycle, relative error of the dissipated energy ∮ŷ dd vs ∮y dd.
    map_d, map_v, map_mean : residual mean over a grid of the (d, d') plane (NaN in empty cells).
    phase, phase_mean : residual mean over the input cycle phase (for periodic inputs).
    """

    nrmse: float
    rmse: float
    noise: float
    excess: float
    mean: float
    mean_z: float
    bins: tuple[Bin, ...]
    acf: np.ndarray
    acf_bound: float
    acf_outside: float
    ljung_box_p: float
    xcorr: dict
    trend: dict
    cycle_energy: np.ndarray
    map_d: np.ndarray
    map_v: np.ndarray
    map_mean: np.ndarray
    phase: np.ndarray = field(default_factory=lambda: np.zeros(0))
    phase_mean: np.ndarray = field(default_factory=lambda: np.zeros(0))
    noise_kind: str = "measured"  # "floor": ``noise`` is the lowest held-out RMS of any fitted model

    # ------------------------------------------------------------------
    @property
    def white(self) -> bool:
        """At most a fifth of the autocorrelation's lags lie outside the 95 % bounds of white noise."""
        return self.acf_outside <= 0.2

    @property
    def at_noise_level(self) -> bool:
        """The residual is as small as the measurement noise and white."""
        return self.excess < 1.5 and self.white

    @property
    def worth_a_search(self) -> bool:
        """Whether a search outside the catalogue may still find something: the residual is not white, or its RMS
        is at least :data:`SEARCH_EXCESS` times the noise. Stricter than :attr:`at_noise_level`, which keeps the
        verdict cautious: with the noise measured from the fitted residuals (0.99-1.27x the true noise on
        independent records) a residual 1.25-1.5x the noise is 1.6-2.3x its variance, where discovery found the
        Stribeck peak it missed before; discovery's own held-out evidence still decides."""
        return not (self.excess < SEARCH_EXCESS and self.white)

    def bin(self, region: str) -> Bin:
        for b in self.bins:
            if b.region == region:
                return b
        raise KeyError(region)

    def findings(self) -> list[str]:
        """Where the model fails, as short statements with their numbers (largest effects first)."""
        out: list[tuple[float, str]] = []
        floor = self.noise_kind == "floor"
        ref = (
            "the lowest held-out RMS of any fitted model (the noise is not measurable here)"
            if floor
            else "the measurement noise"
        )
        if self.at_noise_level:
            level = "as small as the best fitted model's held-out residual" if floor else "at the noise level"
            return [
                f"the residual is {level} (RMS {self.rmse:.3g} vs {self.noise:.3g}) and white "
                f"({100 * self.acf_outside:.0f} % of lags outside the 95 % bound)"
            ]
        out.append((self.excess, f"residual RMS is {self.excess:.1f}x {ref} ({self.rmse:.3g} vs {self.noise:.3g})"))
        if abs(self.mean_z) > 5 and abs(self.mean) > 0.2 * self.rmse:
            out.append(
                (
                    abs(self.mean) / self.rmse * 10,
                    f"the residual has a mean of {self.mean:.3g} "
                    f"({100 * abs(self.mean) / self.rmse:.0f} % of its RMS): "
                    "the loop is shifted",
                )
            )
        for b in self.bins:
            if b.n >= 10 and b.rms_ratio > 1.5 and b.share > 0.15:
                out.append(
                    (
                        b.rms_ratio * b.share * 10,
                        f"the error concentrates {b.region}: RMS {b.rms_ratio:.1f}x the average there, "
                        f"{100 * b.share:.0f} % of the squared error",
                    )
                )
        g = self.trend.get("growth", 1.0)
        if g > 1.5 and self.trend.get("spearman", 0.0) > 0.5:
            out.append((g * 5, f"the error grows with time: the last quarter's RMS is {g:.1f}x the first quarter's"))
        for name, x in self.xcorr.items():
            if x["max"] > 3 * x["bound"] and x["max"] > 0.2:
                out.append(
                    (
                        x["max"] * 5,
                        f"the residual correlates with {name} (|ccf| {x['max']:.2f} at lag {x['lag']}, "
                        f"bound {x['bound']:.2f}): input-driven structure the model misses",
                    )
                )
        ce = self.cycle_energy
        if ce.size and np.all(np.isfinite(ce)) and abs(float(np.median(ce))) > 0.05:
            out.append(
                (
                    abs(float(np.median(ce))) * 20,
                    f"the model {'over' if np.median(ce) > 0 else 'under'}-estimates the energy dissipated per "
                    f"cycle by {100 * abs(float(np.median(ce))):.0f} % (median over {ce.size} cycles)",
                )
            )
        if not self.white:
            out.append(
                (
                    self.acf_outside,
                    f"the residual is not white: {100 * self.acf_outside:.0f} % of lags 1..{self.acf.size - 1} "
                    f"outside the 95 % bound (Ljung–Box p = {self.ljung_box_p:.2g})",
                )
            )
        out.sort(key=lambda item: -item[0])
        return [s for _, s in out]

    def to_dict(self) -> dict:
        return dict(
            nrmse=self.nrmse,
            rmse=self.rmse,
            noise=self.noise,
            noise_kind=self.noise_kind,
            excess=self.excess,
            mean=self.mean,
            mean_z=self.mean_z,
            at_noise_level=self.at_noise_level,
            bins=[b.to_dict() for b in self.bins],
            whiteness=dict(
                acf=self.acf.tolist(),
                bound=self.acf_bound,
                fraction_outside=self.acf_outside,
                ljung_box_p=self.ljung_box_p,
            ),
            xcorr=self.xcorr,
            trend=self.trend,
            cycle_energy_error=self.cycle_energy.tolist(),
            plane_map=jsonable(dict(d=self.map_d, d_dot=self.map_v, mean=self.map_mean)),
            phase_map=jsonable(dict(phase=self.phase, mean=self.phase_mean)),
            findings=self.findings(),
        )


def _bins(r: np.ndarray, v: np.ndarray, y: np.ndarray, dt: float, period: float | None) -> tuple[Bin, ...]:
    sse = float(np.sum(r**2)) or 1.0
    rms_all = math.sqrt(sse / r.size)
    av = np.abs(v)
    vmax = float(np.max(av)) or 1.0
    ay = np.abs(y)
    ymax = float(np.max(ay)) or 1.0
    near = 0.05 * period / dt if period else 10
    dist = reversal_distance(v)
    regions = {
        "at low velocity (|d'| < 20 % of max)": av < 0.2 * vmax,
        "at mid velocity (20-70 % of max |d'|)": (av >= 0.2 * vmax) & (av < 0.7 * vmax),
        "at high velocity (|d'| >= 70 % of max)": av >= 0.7 * vmax,
        "just after velocity reversals (first 5 % of a period)": dist <= max(near, 2),
        "before yield (|y| < 50 % of max)": ay < 0.5 * ymax,
        "after yield (|y| >= 80 % of max)": ay >= 0.8 * ymax,
        "in compression (d' < 0)": v < 0,
        "in extension (d' > 0)": v > 0,
    }
    out = []
    for name, m in regions.items():
        n = int(np.count_nonzero(m))
        if n == 0:
            out.append(Bin(name, 0, math.nan, math.nan, 0.0, math.nan))
            continue
        rms = math.sqrt(float(np.mean(r[m] ** 2)))
        out.append(
            Bin(
                name,
                n,
                rms,
                float(np.mean(r[m])),
                float(np.sum(r[m] ** 2)) / sse,
                rms / rms_all if rms_all else math.nan,
            )
        )
    return tuple(out)


def _spearman(a: np.ndarray, b: np.ndarray) -> float:
    """Spearman rank correlation (no ties expected in window RMS values)."""
    ra = np.argsort(np.argsort(a)).astype(float)
    rb = np.argsort(np.argsort(b)).astype(float)
    return float(np.corrcoef(ra, rb)[0, 1])


def _trend(r: np.ndarray, n_windows: int = 12) -> dict:
    n_windows = max(4, min(n_windows, r.size // 20))
    parts = np.array_split(r, n_windows)
    rms = np.array([math.sqrt(float(np.mean(p**2))) for p in parts])
    q = max(1, r.size // 4)
    first = math.sqrt(float(np.mean(r[:q] ** 2)))
    last = math.sqrt(float(np.mean(r[-q:] ** 2)))
    rho = _spearman(np.arange(rms.size), rms) if np.ptp(rms) > 0 else 0.0
    return {"window_rms": rms.tolist(), "growth": last / first if first > 0 else math.inf, "spearman": rho}


def rising_crossings(d) -> np.ndarray:
    """Indices ``i`` where ``d - mean(d)`` goes from negative (at ``i - 1``) to non-negative (at ``i``):
    the boundaries of whole input cycles."""
    d = np.asarray(d, dtype=float)
    z = zero_crossings(d) + 1
    dm = d - np.mean(d)
    return z[dm[z] > dm[z - 1]]


def _cycle_energy(d: np.ndarray, y: np.ndarray, y_hat: np.ndarray) -> np.ndarray:
    rising = rising_crossings(d)
    out = []
    for a, b in zip(rising[:-1], rising[1:]):
        e_meas = cycle_integral(d[a : b + 1], y[a : b + 1])
        e_model = cycle_integral(d[a : b + 1], y_hat[a : b + 1])
        out.append((e_model - e_meas) / abs(e_meas) if e_meas != 0 else math.nan)
    return np.array(out)


def _plane_map(d, v, r, n_grid: int = 15):
    de = np.linspace(np.min(d), np.max(d), n_grid + 1)
    ve = np.linspace(np.min(v), np.max(v), n_grid + 1)
    s, _, _ = np.histogram2d(d, v, bins=(de, ve), weights=r)
    c, _, _ = np.histogram2d(d, v, bins=(de, ve))
    with np.errstate(invalid="ignore", divide="ignore"):
        m = np.where(c > 0, s / np.maximum(c, 1), np.nan)
    return 0.5 * (de[1:] + de[:-1]), 0.5 * (ve[1:] + ve[:-1]), m


def _phase_map(t, r, period, n_bins: int = 36):
    ph = np.mod(t - t[0], period) / period
    idx = np.minimum((ph * n_bins).astype(int), n_bins - 1)
    s = np.bincount(idx, weights=r, minlength=n_bins)
    c = np.bincount(idx, minlength=n_bins)
    with np.errstate(invalid="ignore", divide="ignore"):
        m = np.where(c > 0, s / np.maximum(c, 1), np.nan)
    return (np.arange(n_bins) + 0.5) / n_bins, m


def analyse_residuals(
    record: Record,
    y_hat,
    *,
    noise: float | None = None,
    max_lag: int = MAX_LAG,
    periodic: bool | None = None,
    noise_kind: str = "measured",
    smoothing: int = 1,
) -> ResidualAnalysis:
    """The residual structure of a model's free-run output ``y_hat`` against ``record``.

    Parameters
    ----------
    record : the measurement.
    y_hat : (n_times,) the model's free-run output (not the collocation fit: a free run shows
        every error the model makes, accumulated as a user would see it in simulation).
    noise : the measurement-noise standard deviation if known; else :func:`noise_level` of ``y``.
    periodic : whether to compute the phase map; default: when the input has at least 3 cycles
        of a dominant period.
    noise_kind : "measured" (default), or "floor" when ``noise`` is the lowest held-out RMS of any
        fitted model because the record's noise cannot be measured: the findings then say so.
    smoothing : the width of a moving average the measured force went through (1: none). Its noise is
        then correlated over lags 1..w-1 by the average itself: whiteness is judged on lags >= w, and the
        cross-correlation bounds widen by sqrt(w) (the variance of a sample correlation of w-correlated
        noise with a smooth input).
    """
    y = np.asarray(record.y, dtype=float)
    y_hat = np.asarray(y_hat, dtype=float).reshape(-1)
    if y_hat.size != y.size:
        raise DataError(f"y_hat has {y_hat.size} samples but record {record.name!r} has {y.size}")
    if not np.all(np.isfinite(y_hat)):
        raise DataError("y_hat has NaN/inf values: the free run failed; analyse a successful run")
    r = y - y_hat
    n = r.size
    rmse = math.sqrt(float(np.mean(r**2)))
    sigma = float(noise) if noise is not None else noise_level(y)
    excess = rmse / sigma if sigma > 0 else math.inf
    v = np.asarray(record.velocity(), dtype=float)
    d = np.asarray(record.d, dtype=float)
    try:
        period = record.period
    except (IndexError, ZeroDivisionError, ValueError):
        period = None
    lag = int(min(max_lag, n // 5))
    acf = autocorrelation(r, lag)
    bound = Z95 / math.sqrt(n)
    w = max(1, int(smoothing))
    outside = float(np.mean(np.abs(acf[w:]) > bound)) if lag >= w else 0.0
    _, p_lb = ljung_box(acf, n)
    xc = {}
    for name, u in (("d", d), ("d_dot", v)):
        c = cross_correlation(r, u, lag)
        k = int(np.argmax(np.abs(c)))
        xc[name] = {"max": float(abs(c[k])), "lag": int(k - lag), "bound": bound * math.sqrt(w)}
    # the mean's standard error allows for correlated residuals (effective sample size)
    rho1 = float(acf[1]) if acf.size > 1 else 0.0
    n_eff = n * (1 - rho1) / (1 + rho1) if abs(rho1) < 1 else 1.0
    se_mean = math.sqrt(float(np.var(r)) / max(n_eff, 1.0)) or math.inf
    mean = float(np.mean(r))
    md, mv, mm = _plane_map(d, v, r)
    if periodic is None:
        periodic = period is not None and record.duration >= 3 * period
    ph, pm = _phase_map(np.asarray(record.t), r, period) if periodic and period else (np.zeros(0), np.zeros(0))
    return ResidualAnalysis(
        nrmse=_nrmse(y, y_hat),
        rmse=rmse,
        noise=sigma,
        excess=excess,
        mean=mean,
        mean_z=mean / se_mean,
        bins=_bins(r, v, y, record.dt, period),
        acf=acf,
        acf_bound=bound,
        acf_outside=outside,
        ljung_box_p=p_lb,
        xcorr=xc,
        trend=_trend(r),
        cycle_energy=_cycle_energy(d, y, y_hat),
        map_d=md,
        map_v=mv,
        map_mean=mm,
        phase=ph,
        phase_mean=pm,
        noise_kind=noise_kind,
    )
