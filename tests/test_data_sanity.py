"""Data sanity (duffsym.data.sanity): clipped and frozen stretches found on independently generated records
(tests/independent_sim.py, no duffsym import; quantised like an ADC, noise added) and on the real Dyke and
UTFSM records, with exact expectations for where they are; the training-range note."""

from __future__ import annotations

import numpy as np
import pytest

from _external import DYKE_CSV, external_file
from duffsym.data import Record, read_csv
from duffsym.data.sanity import check_record, range_notes, training_ranges, valid_part
from independent_sim import scenario

DYKE_COLUMNS = dict(time="t", input="D", output="F", velocity="V", voltage="Y")


def _quantise(x, q):
    return np.round(np.asarray(x) / q) * q


def _independent(kind="sine", seed=3, q_y=None, q_d=None, duration=6.0):
    """An independent device record (1 % noise), quantised to ``q_y`` (force) and ``q_d`` (displacement)."""
    g = scenario("clean", seed, kind=kind, duration=duration, dt=0.005)
    y = g.y if q_y is None else _quantise(g.y, q_y)
    d = g.d if q_d is None else _quantise(g.d, q_d)
    return g.t, d, y


def test_clean_quantised_records_have_no_invalid_stretch():
    """Quantised sine / multisine / random records repeat exactly near their turning points: not flagged."""
    for kind in ("sine", "multisine", "random"):
        t, d, y = _independent(kind, q_y=None, q_d=None)
        for qy, qd in ((None, None), (0.002 * np.ptp(y), 0.002 * np.ptp(d)), (0.01 * np.ptp(y), 0.01 * np.ptp(d))):
            yy = y if qy is None else _quantise(y, qy)
            dd = d if qd is None else _quantise(d, qd)
            rep = check_record(Record(t=t, d=dd, y=yy, name=kind))
            assert rep.ok, (kind, qy, rep.summary())


def test_clipped_force_found_where_injected():
    """Force clipped at 80 % of its peak (as an ADC saturates: exactly one value): every clipped run found,
    exactly the samples at the limit, and nothing else."""
    t, d, y = _independent("sine", q_y=None)
    lim = 0.8 * float(np.max(y))
    yc = np.minimum(y, lim)
    rep = check_record(Record(t=t, d=d, y=yc, name="clipped"))
    held = yc == lim
    # the runs of >= 5 samples at the limit: one per positive peak
    assert not rep.ok and {s.kind for s in rep.stretches} == {"clipped"}
    assert {s.signal for s in rep.stretches} == {"force"}
    got = rep.mask
    assert np.all(held[got]) and got.sum() >= 0.95 * held.sum()
    assert all(abs(s.value - lim) == 0 for s in rep.stretches)
    assert "clipped" in rep.summary() and "\n" not in rep.summary()


def test_frozen_displacement_under_motion_found():
    """The displacement channel held for 0.3 s in the middle while the force keeps changing: one frozen
    stretch, exactly there; the valid part keeps the whole record and masks it."""
    t, d, y = _independent("random", seed=5)
    a, b = 400, 460
    d2 = d.copy()
    d2[a:b] = d2[a]
    rep = check_record(Record(t=t, d=d2, y=y, name="frozen"))
    assert [(s.signal, s.kind, s.start, s.stop) for s in rep.stretches] == [("displacement", "frozen", a, b)]
    vp = valid_part(Record(t=t, d=d2, y=y), rep)
    assert (vp.start, vp.stop) == (0, t.size) and vp.mask.sum() == b - a


def test_device_at_rest_is_valid():
    """Both channels still (the actuator stopped) is a device at rest, not a frozen sensor."""
    t, d, y = _independent("sine", seed=2)
    a = 300 + int(np.argmin(np.abs(d[300:400] - np.mean(d))))  # mid-stroke: not at either channel's extreme
    d2, y2 = d.copy(), y.copy()
    d2[a : a + 200] = d2[a]
    y2[a : a + 200] = y2[a]
    assert y2[a] not in (y2.max(), y2.min()) and d2[a] not in (d2.max(), d2.min())
    assert check_record(Record(t=t, d=d2, y=y2)).ok
    # the same stretch with the force still moving: the displacement is frozen
    assert [s.kind for s in check_record(Record(t=t, d=d2, y=y)).stretches] == ["frozen"]


def test_dyke_real_record_clean_and_its_clipped_end_found():
    """The shared Dyke record has no invalid stretch (exact repeats there are at most 5 samples, 1.7 ms).
    With its last 0.5 s replaced as in the second Dyke record (force at exactly 4545.45 N, displacement
    flat), both stretches are found, and the valid part ends where they start."""
    rec = read_csv(external_file(*DYKE_CSV), columns=DYKE_COLUMNS)
    assert check_record(rec).ok
    n = int(round(0.5 / rec.dt))
    y, d = np.array(rec.y), np.array(rec.d)
    y[-n:] = 4545.45
    d[-n:] = d[-n - 1]
    bad = rec.replace(y=y, d=d)
    rep = check_record(bad)
    kinds = {(s.signal, s.kind) for s in rep.stretches}
    assert kinds == {("force", "clipped"), ("displacement", "frozen")}
    force = next(s for s in rep.stretches if s.signal == "force")
    assert force.value == 4545.45 and force.stop == rec.n_times and force.start == rec.n_times - n
    vp = valid_part(bad, rep)
    assert vp.stop == rec.n_times - n - 1 and vp.start == 0 and not vp.mask.any()


def test_raw_utfsm_records_not_flagged():
    """The raw UTFSM DAQ exports (ADC-quantised, rest stretches between the five current segments, up to 37
    equal samples in a row, several samples at the displacement's maximum) carry no clipped or frozen
    stretch by this rule."""
    path = external_file("mr_damper_utfsm_quiroz2022", "raw_sinusoidal", "ME5mm3Hz.txt")
    x = np.genfromtxt(path, delimiter=",", skip_header=7, usecols=(2, 3))
    x = x[np.all(np.isfinite(x), axis=1)]
    rec = Record(t=np.arange(x.shape[0]) / 1000.0, d=x[:, 0] * 10, y=x[:, 1] * 980.665, name="ME5mm3Hz")
    assert check_record(rec).ok
    # the same record with its force clipped at 90 % of the peak: flagged
    y = np.minimum(np.asarray(rec.y), 0.9 * float(np.max(rec.y)))
    assert {s.kind for s in check_record(rec.replace(y=y)).stretches} == {"clipped"}


def test_range_notes():
    """A record whose command, amplitude or frequency lies outside the training records' range is noted;
    one inside is not."""
    t = np.arange(0, 8, 0.002)  # sin(t) spans -1..1

    def rec(amp, f, cmd):
        return Record(
            t=t,
            d=amp * np.sin(2 * np.pi * f * t),
            y=np.cos(2 * np.pi * f * t) + 0.1 * np.sin(t),
            command=cmd(t),
            command_name="voltage",
        )

    train = [rec(1.0, 2.0, lambda s: 1.0 + np.sin(s)), rec(2.0, 4.0, lambda s: 1.0 + 1.5 * np.sin(s))]
    r = training_ranges(train)
    assert r["command"] == pytest.approx([-0.5, 2.5], abs=0.01) and r["amplitude"] == pytest.approx([1, 2], rel=1e-3)
    assert r["frequency_hz"] == pytest.approx([2, 4], abs=0.13)  # a sine's band: its line, +-1 bin (1/8 Hz)
    assert range_notes(r, rec(1.5, 3.0, lambda s: 1.0 + np.sin(s))) == []
    notes = range_notes(r, rec(1.5, 3.0, lambda s: 1.0 + 1.71 * np.sin(s)))
    assert len(notes) == 1 and "voltage" in notes[0] and "2.71" in notes[0]
    notes = range_notes(r, rec(3.0, 8.0, lambda s: 1.0 + np.sin(s)))
    assert len(notes) == 3 and [n.split()[1] for n in notes] == ["amplitude", "velocity", "frequency"]
    # amplitude 3 at 1.5 Hz: velocity amplitude 9 pi inside the fit's 4 pi .. 16 pi; frequency 25 % below
    notes = range_notes(r, rec(3.0, 1.5, lambda s: 1.0 + np.sin(s)))
    assert [n.split()[1] for n in notes] == ["amplitude", "frequency"]
