"""Decimation of a diagnosis's fitting data (duffsym.diagnose.prepare): analytic signals, exact expectations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from duffsym.data import Record
from duffsym.diagnose.prepare import (
    MIN_PER_CYCLE,
    OVERSAMPLE,
    bandwidth,
    choose_decimation,
    decimate_mask,
    decimate_record,
)


def _record(fs=1000.0, duration=6.0, harmonics=(1, 3, 5, 7, 9), noise=0.0, extra=None, seed=0):
    """1 Hz sine input; output: odd harmonics with amplitudes 1/k^2 (a rounded square wave)."""
    t = np.arange(int(duration * fs)) / fs
    w = 2 * math.pi
    d = np.sin(w * t)
    y = sum(np.sin(k * w * t) / k**2 for k in harmonics)
    if extra is not None:
        y = y + extra(t)
    y = y + noise * np.random.default_rng(seed).standard_normal(t.size)
    return Record(t=t, d=d, d_dot=w * np.cos(w * t), y=y, name="analytic")


def test_decimated_samples_equal_the_band_limited_signal_to_5e4_including_the_ends():
    rec = _record()
    out = decimate_record(rec, 8)
    t = np.asarray(out.t)
    w = 2 * math.pi
    exact = sum(np.sin(k * w * t) / k**2 for k in (1, 3, 5, 7, 9))
    assert out.n_times == -(-rec.n_times // 8)
    assert np.allclose(t, np.asarray(rec.t)[::8])
    # the 9 Hz harmonic sits at 0.14 of the new Nyquist: the Hamming FIR's pass-band ripple is ~3e-4
    assert np.max(np.abs(np.asarray(out.y) - exact)) < 5e-4 * np.max(np.abs(exact))
    # the velocity channel is filtered the same way: cos at 1 Hz stays exact
    assert np.max(np.abs(np.asarray(out.d_dot) - w * np.cos(w * t))) < 1e-3 * w
    assert out.metadata["decimated"]["factor"] == 8


def test_a_component_above_the_new_nyquist_is_removed_not_folded():
    # 400 Hz at 1 kHz, decimated by 8 (new Nyquist 62.5 Hz): plain subsampling would fold it to 100 Hz -> 25 Hz
    rec = _record(harmonics=(1,), extra=lambda t: 0.1 * np.sin(2 * math.pi * 400 * t))
    out = decimate_record(rec, 8)
    t = np.asarray(out.t)
    left = np.asarray(out.y) - np.sin(2 * math.pi * t)
    assert np.max(np.abs(left[40:-40])) < 0.1 * 1e-2  # > 40 dB rejection away from the ends
    folded = np.asarray(rec.y)[::8] - np.sin(2 * math.pi * t)
    assert np.max(np.abs(folded)) > 0.05  # what subsampling alone would have kept


def test_bandwidth_finds_the_last_harmonic_above_minus_60_db():
    # amplitudes 1/k^2: k = 9 -> 0.0123, k = 41 -> 6e-4 (below 1e-3 of the peak)
    rec = _record(harmonics=(1, 9, 41))
    fb, f0 = bandwidth(rec.y, rec.dt)
    assert f0 == pytest.approx(1.0, abs=0.2)
    assert fb == pytest.approx(9.0, abs=0.5)


def test_the_factor_follows_the_bandwidth_and_the_samples_per_input_period():
    # last harmonic 9 Hz at 1/81 = 0.012 of the peak; 1 % noise stays below the floor rule; 12 000 samples
    rec = _record(noise=0.01, duration=12.0)
    prep = choose_decimation(rec)
    need = max(OVERSAMPLE * 9.0, MIN_PER_CYCLE * 1.0)  # 50 samples per 1 Hz period decide: 50 Hz
    assert prep.factor == math.floor(1000.0 / need) == 20
    assert prep.rate == pytest.approx(1000.0 / prep.factor)
    assert prep.factor > 1 and "decimated by" in prep.summary()
    # switched off, or capped
    assert choose_decimation(rec, max_factor=1).factor == 1
    assert choose_decimation(rec, max_factor=3).factor == 3
    # too few samples left: the factor shrinks to keep MIN_SAMPLES
    short = choose_decimation(rec, n_fit=1200)
    assert short.factor == 3 and short.n_out == 400


def test_a_broadband_output_is_not_decimated():
    rec = _record(fs=200.0, duration=8.0, harmonics=tuple(range(1, 80, 2)))  # harmonics up to the Nyquist
    assert choose_decimation(rec).factor == 1


def test_non_uniform_sampling_is_not_decimated():
    rec = _record(fs=100.0)
    t = np.asarray(rec.t).copy()
    t[5:] += 0.003
    odd = rec.replace(t=t)
    prep = choose_decimation(odd)
    assert prep.factor == 1 and "not uniform" in prep.reason


def test_mask_keeps_a_sample_out_when_any_neighbour_within_half_a_step_is_out():
    m = np.zeros(40, dtype=bool)
    m[13] = True  # nearest kept samples (q = 4): 12 (index 3) within 2, 16 (index 4) not
    out = decimate_mask(m, 4, 10)
    assert out.tolist() == [False, False, False, True] + [False] * 6
    assert decimate_mask(None, 4, 10) is None


# ------------------------------------------------------------------------------------------------ in diagnose
def _fine_offset_record():
    """The base model at 1 kHz (2 Hz sine, 3 s), with a load-cell offset of 0.15 added to the force by hand
    (not through duffsym.effects) and 1 % noise."""
    from duffsym.data import synthetic_record
    from duffsym.excitation import Sine
    from duffsym.model.library import mr_damper
    from duffsym.model.presets import table2_params

    truth = table2_params(0.4)
    rec = synthetic_record(mr_damper(), truth, Sine(1.0, 2.0), dt=0.001, duration=3.0, noise=0.0, rng=1)
    y = np.asarray(rec.y)
    y = y + 0.15 + 0.01 * np.std(y) * np.random.default_rng(3).standard_normal(y.size)
    return rec.replace(y=y), truth


def _diagnose(rec, truth, decimate):
    from duffsym.diagnose import diagnose

    return diagnose(
        rec, candidates=["force-offset", "output-lag"], fixed={"A_f": truth["A_f"]}, sindy=False, decimate=decimate
    )


def test_diagnose_fits_a_1_khz_record_decimated_and_still_finds_the_offset():
    rec, truth = _fine_offset_record()
    dg = _diagnose(rec, truth, True)
    prep = dg.prepare
    # the model's force has harmonics above -60 dB up to ~45 Hz: 4x that is ~180 Hz, so q = 5 of 1 kHz
    assert 4 <= prep.factor <= 6 and prep.n_out == -(-dg.split["n_fit"] // prep.factor)
    assert dg.to_dict()["prepare"]["factor"] == prep.factor and "decimated by" in dg.summary()
    assert dg.needed == ("force-offset",), dg.summary()
    assert dg.best.params["off_y0"] == pytest.approx(0.15, rel=0.03)
    assert dg.y_base.shape == (rec.n_times,)  # the evidence is at the record's own rate


@pytest.mark.slow
def test_decimation_leaves_the_verdict_and_the_held_out_errors_unchanged():
    rec, truth = _fine_offset_record()
    a, b = _diagnose(rec, truth, True), _diagnose(rec, truth, False)
    assert b.prepare.factor == 1 and a.prepare.factor > 1
    assert a.needed == b.needed == ("force-offset",)
    assert a.nrmse_heldout == pytest.approx(b.nrmse_heldout, rel=0.02)
    assert a.best.nrmse_after == pytest.approx(b.best.nrmse_after, rel=0.02)
    assert a.best.params["off_y0"] == pytest.approx(b.best.params["off_y0"], rel=0.01)


def test_energy_bandwidth_counts_variance_not_amplitude():
    """The fit's variance rule: a 50 Hz line with 4e-4 of the variance lies above the 3e-3 cut, one with 1e-2
    below it; the amplitude rule (-60 dB) counts both."""
    from duffsym.data.decimate import energy_bandwidth

    t = np.arange(0, 20, 1e-3)
    for amp, expect in ((0.02, 1.0), (0.1, 50.0)):
        y = np.sin(2 * math.pi * t) + amp * np.sin(2 * math.pi * 50 * t)
        assert energy_bandwidth(y, 1e-3, 3e-3)[0] == pytest.approx(expect, abs=0.11)
        assert bandwidth(y, 1e-3)[0] >= 50.0


def test_fit_rule_floors_and_cap():
    """prepare_for_fit: 25 samples per period and 200 samples at least; a cap of 1 switches it off."""
    from duffsym.data.decimate import prepare_for_fit

    rec = _record(fs=1000.0, duration=6.0, harmonics=(1, 3))  # 1 Hz: 25 samples/period allow q = 40
    prep, out = prepare_for_fit(rec)
    assert prep.factor == 30 and out.n_times == 200  # 6000 samples / 200 = 30 < 40: the sample floor
    assert prepare_for_fit(rec, False)[0].factor == 1


def test_diagnose_from_python_without_a_budget_fits_on_at_most_the_sample_cap():
    """The command line always has a budget, which capped the fitting samples; ``diagnose()`` from Python had none
    and fitted at the spectrum's rate however long the record (the 6 s Dyke slice at 500 Hz: a plain-fit
    reference on 3005 samples ran for more than 12 CPU minutes). An independent record whose spectrum needs the
    full rate, 2400 fitting samples: fitted on at most BUDGET_SAMPLES, the evidence still at the record's rate."""
    import independent_sim as gen
    from duffsym.diagnose import diagnose
    from duffsym.diagnose.search import BUDGET_SAMPLES

    g = gen.scenario("clean", 0, duration=16.0)
    rec = Record(t=g.t, d=g.d, y=g.y, name="clean-16s", source="independent_sim")
    dg = diagnose(rec, candidates=[], sindy=False)
    assert dg.split["n_fit"] > BUDGET_SAMPLES and 2 <= dg.prepare.factor <= 3
    assert dg.prepare.n_out <= BUDGET_SAMPLES and "at most 2000 fitting samples" in dg.prepare.summary()
    assert dg.y_base.shape == (rec.n_times,)
    floor = g.noise_std / float(np.std(np.asarray(rec.y)[dg.split["n_fit"] :]))
    assert dg.nrmse_heldout <= 1.1 * floor  # the clean device's model, fitted on the capped data, is at the noise
