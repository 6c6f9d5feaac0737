"""Rates the sampling cannot resolve (issue 24: a fit that gets slower when the record gets smaller): the decay
parameters found from the equations, their bounds set by the record's step, the command start kept inside them,
and a fit of an independent record whose field is faster than its sampling that converges, with the rate on the
sampling's bound and a flag that says why (records: tests/independent_current_sim.py, numpy only)."""

from __future__ import annotations

import numpy as np
import pytest

import independent_current_sim as gen
from duffsym.data.record import Record
from duffsym.effects import CATALOGUE, apply_effects
from duffsym.identify import Problem, fit
from duffsym.identify.initial import command_start
from duffsym.identify.problem import RATE_STEP_LIMIT, decay_parameters, sampling_bounds
from duffsym.model import get_model

DISP = gen.Sines((0.5, 0.2), (1.0, 2.3), (0.0, 1.0))
SWITCH = gen.Switching(0.1, 0.9, gen.Sines((1.0, 0.7), (0.45, 1.1), (0.3, 2.0)))


def test_decay_parameters_are_read_from_the_equations():
    """The field rate of a command model (u' = -eta (u - i): d f/d u = -eta), an output lag's time constant
    (z' = (y - z)/tau: -1/tau), and none in the plain damper (no state besides position and velocity)."""
    assert decay_parameters(get_model("mr-damper-current")) == (("eta", "rate"),)
    lagged = apply_effects(get_model("mr-damper"), [CATALOGUE["output-lag"]])
    assert decay_parameters(lagged) == (("lag_tau", "time"),)
    assert decay_parameters(get_model("mr-damper")) == ()


def test_sampling_bounds_follow_the_step():
    """eta <= RATE_STEP_LIMIT / dt, lag_tau >= dt / RATE_STEP_LIMIT; the ParamSpec bound where it is tighter."""
    m = get_model("mr-damper-current")
    t = np.arange(2000) * 0.004
    rec = Record(t=t, d=np.sin(5 * t), y=np.cos(t), command=np.ones_like(t), command_name="current")
    assert sampling_bounds(m, [rec]) == {"eta": (m.param("eta").lower, pytest.approx(RATE_STEP_LIMIT / 0.004))}
    fine = Record(t=t * 1e-3, d=np.sin(5 * t), y=np.cos(t), command=np.ones_like(t), command_name="current")
    assert sampling_bounds(m, [fine]) == {}  # 6/4e-6 is above eta's own bound 1e4: nothing to add
    lagged = apply_effects(get_model("mr-damper"), [CATALOGUE["output-lag"]])
    lo, hi = sampling_bounds(lagged, [Record(t=t, d=np.sin(5 * t), y=np.cos(t))])["lag_tau"]
    assert lo == pytest.approx(0.004 / RATE_STEP_LIMIT) and hi == lagged.param("lag_tau").upper


def _fast_field_record() -> Record:
    truth = {**gen.TRUTH, "eta": 5000.0}  # a field time constant of 0.2 ms, sampled every 4 ms
    g = gen.generate(truth, DISP, SWITCH, dt=0.004, duration=6.0, substeps=20, seed=3)
    return Record(t=g["t"], d=g["d"], y=g["y"], d_dot=g["d_dot"], command=g["command"], command_name="current")


def test_a_field_faster_than_the_sampling_is_fitted_at_the_sampling_bound():
    """The record cannot tell a field of 0.2 ms from one of 0.33 ms (a twelfth of its 4 ms step): the start and the
    fit stay inside the sampling's bound, the fit converges near the noise (1 %), and the on-bound flag says the
    bound comes from the sampling."""
    rec = _fast_field_record()
    model = get_model("mr-damper-current")
    cap = RATE_STEP_LIMIT / rec.dt
    assert command_start(rec, model)["eta"] <= cap * (1 + 1e-12)
    res = fit(Problem(model, rec, fixed={"A_f": gen.TRUTH["A_f"]}), max_wall_time=120.0)
    assert res.success, res.message
    assert res.nrmse < 0.03
    assert res.params["eta"] == pytest.approx(cap, rel=1e-3)
    flag = next(f for f in res.flags if f["flag"] == "on-bound")
    assert "eta" in flag["parameters"] and "set by the sampling" in flag["message"]


def test_an_input_delay_reaches_at_most_a_quarter_of_the_dominant_period():
    """The Padé delay is a delay only for delays short against the input's period: its bound is a quarter of the
    dominant period (the range its guess scans), 0.125 s for a 2 Hz sine, where the static bound is 1 s; a record
    too short to have a period keeps the static bound."""
    from duffsym.identify.problem import record_scaled_bounds

    m = apply_effects(get_model("mr-damper"), [CATALOGUE["input-delay"]])
    t = np.arange(4000) * 0.002
    rec = Record(t=t, d=np.sin(2 * np.pi * 2.0 * t), y=np.cos(2 * np.pi * 2.0 * t))
    lo, hi = record_scaled_bounds(m, [rec])["delay_tau"]
    assert lo == m.param("delay_tau").lower and hi == pytest.approx(0.125, rel=0.01)
    slow = Record(t=t, d=np.sin(2 * np.pi * 0.05 * t), y=np.cos(2 * np.pi * 0.05 * t))  # 20 s period: 5 s > 1 s
    assert "delay_tau" not in record_scaled_bounds(m, [slow])


def test_an_effect_bound_and_a_sampling_bound_on_one_parameter_both_hold(monkeypatch):
    """Where an effect's record bound and the sampling's bound the same parameter, the tighter of each limit holds
    (before, the effect's replaced the sampling's); where they do not overlap, the effect's."""
    from duffsym.identify import problem as P

    m = apply_effects(get_model("mr-damper"), [CATALOGUE["output-lag"]])
    monkeypatch.setattr(P, "sampling_bounds", lambda model, records: {"lag_tau": (0.01, 5.0)})
    monkeypatch.setattr(P, "effect_record_bounds", lambda model, records: {"lag_tau": (0.001, 0.5)})
    assert P.record_scaled_bounds(m, []) == {"lag_tau": (0.01, 0.5)}
    monkeypatch.setattr(P, "effect_record_bounds", lambda model, records: {"lag_tau": (6.0, 7.0)})
    assert P.record_scaled_bounds(m, []) == {"lag_tau": (6.0, 7.0)}
