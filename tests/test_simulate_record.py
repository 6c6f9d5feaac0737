"""The public free run on a record (duffsym.simulate.simulate_record): equal to simulate() on the record's
channels, and the record's inputs are built once and reused."""

import numpy as np

from duffsym.data import synthetic_record
from duffsym.excitation import Sine
from duffsym.model import get_model
from duffsym.model.presets import TABLE2
from duffsym.simulate import simulate, simulate_record


def test_simulate_record_is_simulate_on_the_records_channels():
    model = get_model("mr-damper", 5)
    p = dict(TABLE2[0.4])
    rec = synthetic_record(model, p, Sine(amplitude=1.0, frequency=1.0), dt=0.005, duration=3.0, noise=0.0, rng=0)
    U = rec.input_matrix(model)
    assert U is rec.input_matrix(model) and not U.flags.writeable
    chans = rec.inputs_for(model)
    ref = simulate(model, p, rec.t, chans, on_failure="return")
    got = simulate_record(model, p, rec, on_failure="return")
    assert got.success and np.array_equal(got.y, ref.y)
