"""Record validation (every DataError branch), the velocity differentiator, synthetic records."""

from __future__ import annotations

import math

import numpy as np
import pytest

from duffsym import DataError, Sine, mr_damper
from duffsym.data import Record, apply_backlash, synthetic_record
from duffsym.model.presets import table2_params


def _sine_record(n=400, dt=0.005, f=2.0, **kw):
    t = np.arange(n) * dt
    return dict(t=t, d=np.sin(2 * np.pi * f * t), y=np.cos(2 * np.pi * f * t), **kw)


def test_arrays_are_float_copies_and_read_only():
    raw = _sine_record()
    d = raw["d"].copy()
    rec = Record(**{**raw, "d": d})
    d[0] = 99.0
    assert rec.d[0] == 0.0 and rec.d.dtype == np.float64
    with pytest.raises(ValueError):
        rec.y[0] = 1.0
    with pytest.raises(TypeError):
        rec.metadata["x"] = 1


def test_nan_raise_names_signal_count_and_index():
    raw = _sine_record()
    raw["y"][[5, 9]] = np.nan
    with pytest.raises(DataError, match=r"NaN/inf values in y: 2 \(first at index 5\).*nan_policy='omit'"):
        Record(**raw)


def test_nan_omit_drops_samples_and_warns_with_count():
    raw = _sine_record()
    raw["y"][[5, 9]] = np.nan
    raw["d"][11] = np.inf
    with pytest.warns(UserWarning, match="dropped 3 of 400 samples"):
        rec = Record(**raw, nan_policy="omit")
    assert rec.n_times == 397 and np.all(np.isfinite(rec.y))


def test_bad_nan_policy():
    with pytest.raises(DataError, match="nan_policy must be one of"):
        Record(**_sine_record(), nan_policy="drop")


def test_non_increasing_time_counts_and_first_index():
    raw = _sine_record()
    raw["t"][100] = raw["t"][99]
    raw["t"][200] = raw["t"][198]
    with pytest.raises(DataError, match=r"strictly increasing: 2 non-increasing step\(s\), first at index 100"):
        Record(**raw)


def test_mismatched_lengths():
    raw = _sine_record()
    raw["y"] = raw["y"][:-3]
    with pytest.raises(DataError, match=r"different lengths \(t=400, d=400, y=397\)"):
        Record(**raw)


def test_non_numeric_and_2d():
    raw = _sine_record()
    with pytest.raises(DataError, match="d must be numeric"):
        Record(**{**raw, "d": ["a"] * 400})
    with pytest.raises(DataError, match="must be 1-D"):
        Record(**{**raw, "d": np.zeros((20, 20))})


def test_too_few_samples():
    with pytest.raises(DataError, match=r"too few samples: 19 \(need at least 20\)"):
        Record(**_sine_record(n=19, dt=0.2, f=1.0))


def test_less_than_one_cycle():
    # a quarter of a period: d rises monotonically
    with pytest.raises(DataError, match="less than one excitation cycle"):
        Record(**_sine_record(n=26, dt=0.005, f=2.0))


def test_constant_signals():
    raw = _sine_record()
    with pytest.raises(DataError, match="signal y is constant"):
        Record(**{**raw, "y": np.ones(400)})
    with pytest.raises(DataError, match="signal d is constant"):
        Record(**{**raw, "d": np.zeros(400)})


def test_non_finite_current():
    with pytest.raises(DataError, match="current must be finite"):
        Record(**_sine_record(), current=math.nan)


def test_non_uniform_time_checked_where_needed():
    raw = _sine_record()
    raw["t"] = raw["t"] + np.where(np.arange(400) > 250, 0.001, 0.0)
    rec = Record(**raw)  # fine as a record
    assert not rec.is_uniform()
    with pytest.raises(
        DataError, match=r"deriving the velocity from d needs uniform sampling.*first between index 250"
    ):
        rec.velocity()
    # a given velocity needs no derivation
    assert Record(**raw, d_dot=np.ones(400)).velocity()[0] == 1.0


def test_velocity_window_validated():
    with pytest.raises(DataError, match="velocity window must be odd"):
        Record(**_sine_record()).velocity(window=8)


def test_savgol_velocity_has_zero_lag_and_tiny_bias_at_2hz():
    """Centred filter: no lag; amplitude bias on a 2 Hz sine at dt = 0.005 bounded (< 0.5 %, measured ~1e-5)."""
    dt, f = 0.005, 2.0
    t = np.arange(800) * dt
    w = 2 * np.pi * f
    rec = Record(t=t, d=np.sin(w * t + 0.3), y=np.cos(w * t))
    v = np.asarray(rec.velocity())
    inner = slice(50, -50)
    # least-squares fit v ~ a cos + b sin: gain sqrt(a^2+b^2)/w, phase atan2(-b, a)
    basis = np.column_stack([np.cos(w * t + 0.3), np.sin(w * t + 0.3)])[inner]
    (a, b), *_ = np.linalg.lstsq(basis, v[inner], rcond=None)
    gain = math.hypot(a, b) / w
    lag_s = math.atan2(-b, a) / w
    assert abs(gain - 1) < 5e-3
    assert abs(gain - 1) < 1e-4  # window 11 samples: (8/6) * (theta*w/2)^4 / 5! order, measured 2.5e-5
    assert abs(lag_s) < 1e-6 * dt  # a centred filter: no lag (a one-sided difference lags dt/2)
    # ends (polynomial extrapolation) are still within 1 %
    assert np.max(np.abs(v / (w * np.cos(w * t + 0.3)) - 1)[np.abs(np.cos(w * t + 0.3)) > 0.3]) < 1e-2


def test_period_and_cycles():
    rec = Record(**_sine_record(n=400, dt=0.005, f=2.0))
    assert rec.n_cycles == pytest.approx(4.0, abs=0.5)
    assert rec.period == pytest.approx(0.5, rel=1e-2)


def test_backlash_operator_play_and_velocity():
    t = np.linspace(0, 1, 2001)
    d = np.sin(2 * np.pi * t)
    dd = 2 * np.pi * np.cos(2 * np.pi * t)
    u, ud = apply_backlash(d, dd, 0.1)
    assert np.max(np.abs(u - d)) <= 0.1 + 1e-12
    # after the top reversal u stays at max(d) - 0.1 until d has come down by 0.2
    top = np.argmax(d)
    assert u[top] == pytest.approx(1 - 0.1)
    stuck = (t > t[top]) & (d > 1 - 0.2 + 1e-3)
    assert np.all(u[stuck] == u[top]) and np.all(ud[stuck] == 0)
    assert u[-1] == pytest.approx(d[-1] - 0.1, abs=1e-9)  # rising at the end: dragged from below


def test_synthetic_record_is_deterministic_and_keeps_truth():
    m = mr_damper()
    truth = table2_params(0.4)
    kw = dict(dt=0.005, duration=1.0, noise=0.02)
    a = synthetic_record(m, truth, Sine(1.0, 2.0), rng=7, **kw)
    b = synthetic_record(m, truth, Sine(1.0, 2.0), rng=7, **kw)
    c = synthetic_record(m, truth, Sine(1.0, 2.0), rng=8, **kw)
    assert np.array_equal(a.y, b.y) and not np.array_equal(a.y, c.y)
    assert a.metadata["truth"] == {k: float(v) for k, v in truth.items()}
    clean = np.asarray(a.metadata["clean_y"])
    rel = np.std(a.y - clean) / np.sqrt(np.mean(clean**2))
    assert rel == pytest.approx(0.02, rel=0.15)
    assert a.n_times == 200 and a.t[1] == pytest.approx(0.005)


def test_synthetic_record_bad_arguments():
    m = mr_damper()
    with pytest.raises(DataError, match="noise must be"):
        synthetic_record(m, None, Sine(1.0, 2.0), dt=0.005, duration=1.0, noise=-1)
    with pytest.raises(DataError, match="backlash must be"):
        synthetic_record(m, None, Sine(1.0, 2.0), dt=0.005, duration=1.0, backlash=-0.1)
    with pytest.raises(DataError, match="dt must be a positive"):
        synthetic_record(m, None, Sine(1.0, 2.0), dt=0.0, duration=1.0)
