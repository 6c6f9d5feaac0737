"""Residual analysis of the diagnosis, checked on residuals whose structure is known by construction."""

from __future__ import annotations

import math

import numpy as np
import pytest

from duffsym.data.record import Record
from duffsym.diagnose import analyse_residuals, noise_level, split_record
from duffsym.diagnose.residuals import autocorrelation, cross_correlation, ljung_box, reversal_distance
from duffsym.errors import DataError

DT = 0.002
T = np.arange(0, 6.0, DT)
W = 2 * np.pi * 1.5


def damper_record(y_clean, sigma=0.0, seed=0, **kw) -> tuple[Record, np.ndarray]:
    """A record of a linear viscous damper y = c d' under a 1.5 Hz sine, plus white noise."""
    rng = np.random.default_rng(seed)
    d = np.sin(W * T)
    v = W * np.cos(W * T)
    y = y_clean(d, v) + sigma * rng.standard_normal(T.size)
    return Record(t=T, d=d, d_dot=v, y=y, name="linear", **kw), y_clean(d, v)


def test_noise_level_recovers_white_noise_under_a_smooth_signal():
    for sigma in (0.01, 0.05):
        rec, _ = damper_record(lambda d, v: 2.0 * v, sigma=sigma, seed=3)
        assert noise_level(rec.y) == pytest.approx(sigma, rel=0.1)


def test_noise_level_of_a_noise_free_smooth_signal_is_negligible():
    rec, _ = damper_record(lambda d, v: 2.0 * v)
    assert noise_level(rec.y) < 1e-4 * np.std(rec.y)


def test_autocorrelation_of_white_and_ar1_noise():
    rng = np.random.default_rng(1)
    e = rng.standard_normal(20000)
    acf = autocorrelation(e, 20)
    assert acf[0] == pytest.approx(1.0)
    assert np.all(np.abs(acf[1:]) < 4 / math.sqrt(e.size))
    _, p = ljung_box(acf, e.size)
    assert p > 0.001
    ar = np.zeros_like(e)
    for i in range(1, e.size):
        ar[i] = 0.8 * ar[i - 1] + e[i]
    acf = autocorrelation(ar, 5)
    assert acf[1:4] == pytest.approx([0.8, 0.64, 0.512], abs=0.03)
    assert ljung_box(acf, ar.size)[1] < 1e-10


def test_cross_correlation_peaks_at_the_delay():
    rng = np.random.default_rng(2)
    u = rng.standard_normal(5000)
    r = np.roll(u, 7)  # the residual follows the input by 7 samples
    c = cross_correlation(r, u, 20)
    assert int(np.argmax(c)) - 20 == 7
    assert c.max() == pytest.approx(1.0, abs=0.01)


def test_reversal_distance_counts_samples_since_the_last_sign_change():
    v = np.array([1, 1, -1, -1, -1, 2, 2, 0, -3], dtype=float)
    assert reversal_distance(v).tolist() == [9, 9, 0, 1, 2, 0, 1, 2, 0]


def test_a_model_equal_to_the_clean_signal_is_at_noise_level():
    rec, clean = damper_record(lambda d, v: 2.0 * v + 0.5 * np.tanh(v / 0.5), sigma=0.02, seed=4)
    res = analyse_residuals(rec, clean)
    assert res.at_noise_level
    assert res.excess == pytest.approx(1.0, abs=0.1)
    assert len(res.findings()) == 1 and "noise level" in res.findings()[0]


def test_an_offset_shows_as_a_shifted_mean():
    rec, clean = damper_record(lambda d, v: 2.0 * v, sigma=0.02, seed=5)
    res = analyse_residuals(rec, clean - 0.3)
    assert res.mean == pytest.approx(0.3, abs=0.005)
    assert not res.at_noise_level
    assert any("shifted" in f for f in res.findings())


def test_error_at_low_velocity_is_located():
    # the model misses a friction-like term that only matters near zero velocity
    rec, clean = damper_record(lambda d, v: 2.0 * v + 0.5 * np.tanh(v / 0.3), sigma=0.01, seed=6)
    v = rec.d_dot
    model = 2.0 * v + 0.5 * np.sign(v)  # right far from reversals, wrong close to them
    res = analyse_residuals(rec, model)
    low = res.bin("at low velocity (|d'| < 20 % of max)")
    high = res.bin("at high velocity (|d'| >= 70 % of max)")
    assert low.rms_ratio > 2.5 and high.rms_ratio < 0.3
    assert any("low velocity" in f for f in res.findings())


def test_growing_error_is_reported_as_growing_with_time():
    rec, clean = damper_record(lambda d, v: 2.0 * v, sigma=0.01, seed=7)
    model = clean * (1 + 0.3 * T / T[-1])  # the gain drifts over the record
    res = analyse_residuals(rec, model)
    assert res.trend["growth"] > 3 and res.trend["spearman"] > 0.9
    assert any("grows with time" in f for f in res.findings())


def test_cycle_energy_error_of_a_scaled_damper():
    rec, clean = damper_record(lambda d, v: 2.0 * v)
    res = analyse_residuals(rec, 1.1 * clean)
    assert res.cycle_energy.size >= 7
    assert res.cycle_energy == pytest.approx(0.1, abs=1e-9)


def test_analysis_rejects_a_failed_free_run():
    rec, clean = damper_record(lambda d, v: 2.0 * v)
    bad = clean.copy()
    bad[10] = np.nan
    with pytest.raises(DataError, match="free run failed"):
        analyse_residuals(rec, bad)
    with pytest.raises(DataError, match="samples"):
        analyse_residuals(rec, clean[:-1])


def test_split_holds_out_whole_cycles_at_the_end():
    rec, _ = damper_record(lambda d, v: 2.0 * v)
    k = split_record(rec, 0.3)
    assert abs(k - 0.7 * T.size) <= 0.5 / 1.5 / DT  # within half a period of 70 %
    assert rec.d[k - 1] < 0 and rec.d[k] > -1e-9  # at a rising zero crossing of the input
    with pytest.raises(DataError, match="holdout"):
        split_record(rec, 0.9)
    t = np.arange(50) * DT
    short = Record(t=t, d=np.sin(2 * np.pi * 40 * t), y=np.cos(2 * np.pi * 40 * t))  # 4 cycles, 50 samples
    with pytest.raises(DataError, match="too short"):
        split_record(short, 0.3)


def test_a_white_residual_between_1_25_and_1_5_times_the_noise_is_at_noise_level_yet_worth_a_search():
    sigma = 0.01
    rng = np.random.default_rng(5)
    for scale, at_noise, search in ((1.0, True, False), (1.4, True, True), (1.7, False, True)):
        rec, clean = damper_record(lambda d, v: 2.0 * v)
        y_hat = clean - scale * sigma * rng.standard_normal(T.size)  # a white residual of RMS scale * sigma
        res = analyse_residuals(rec, y_hat, noise=sigma)
        assert res.excess == pytest.approx(scale, rel=0.05)
        assert (res.at_noise_level, res.worth_a_search) == (at_noise, search)
    rec, clean = damper_record(lambda d, v: 2.0 * v)  # small but structured: a residual that follows the velocity
    res = analyse_residuals(rec, clean - 0.01 * np.cos(W * T) - sigma * rng.standard_normal(T.size), noise=sigma)
    assert res.excess < 1.25 and not res.at_noise_level and res.worth_a_search
