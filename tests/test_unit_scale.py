"""The same record in other units gives the same fit (issue 24): the fit runs normalised and maps back.

The record comes from the independent simulator (``tests/independent_sim.py``, no duffsym import): the
paper's Table 2 damper at 0.4 V under a multisine, 1 % noise. Fitted as it is, with its input and
output x 1e-12, and with its input x 1e6 alone. Before the fix the 1e-12 record fitted at NRMSE 0.79
(unit scale: 0.009) and was called a success.

The expected parameters are written out by hand from the model (Eq. 12, n = 5, output A_f x'): the
input x a and output x b are reproduced with the states x a and c3 -> c3 a^-4, A_f -> A_f b/a; the
default A_f = max|y| then moves along the states' symmetry x -> x/a: c1 -> c1/a, c2 -> c1 + c2 - c1/a,
k1 -> k1/a, k2 -> k1 + k2 - k1/a, c3 back to c3 (c3 a^-4 a^4).
"""

from __future__ import annotations

import numpy as np
import pytest

from duffsym.data.record import Record
from duffsym.identify import Problem, fit
from duffsym.model.library import get_model
from independent_sim import Physics, generate, make_input, table2

SCALES = [(1e-12, 1e-12), (1e6, 1.0)]


@pytest.fixture(scope="module")
def generated():
    inp = make_input("multisine", np.random.default_rng(3))
    return generate(table2(0.4), Physics(), inp, dt=0.01, duration=4.0, noise=0.01, rng=1)


def _record(g, a: float, b: float) -> Record:
    return Record(t=g.t, d=g.d * a, y=g.y * b, name="scaled")


@pytest.fixture(scope="module")
def fits(generated):
    model = get_model("mr-damper", 5)
    out = {(1.0, 1.0): fit(Problem(model, _record(generated, 1.0, 1.0)))}
    for a, b in SCALES:
        out[(a, b)] = fit(Problem(model, _record(generated, a, b)))
    return out


def _by_hand(p: dict, a: float, b: float) -> dict:
    """The unit-scale parameters in the units (input x a, output x b) with A_f = b * max|y| (module docstring)."""
    return {
        "c1": p["c1"] / a,
        "c2": p["c1"] + p["c2"] - p["c1"] / a,
        "k1": p["k1"] / a,
        "k2": p["k1"] + p["k2"] - p["k1"] / a,
        "c3": p["c3"],
        "k3": p["k3"],
        "A_f": p["A_f"] * b,
    }


@pytest.mark.parametrize("a,b", SCALES)
def test_same_nrmse_and_success_at_any_units(fits, a, b):
    unit, scaled = fits[(1.0, 1.0)], fits[(a, b)]
    assert unit.success and unit.nrmse < 0.02  # the unit-scale fit is good (1 % noise)
    assert scaled.success == unit.success
    assert scaled.nrmse == pytest.approx(unit.nrmse, rel=1e-6, abs=1e-9)


@pytest.mark.parametrize("a,b", SCALES)
def test_parameters_are_the_unit_ones_moved_by_the_symmetry(fits, generated, a, b):
    unit, scaled = fits[(1.0, 1.0)], fits[(a, b)]
    want = _by_hand(unit.params, a, b)
    for k, v in want.items():
        # c2 = c1 + c2 - c1/a cancels ~1/a: compare it on the scale of its terms
        scale = max(abs(v), abs(unit.params["c1"] / a), abs(unit.params["k1"] / a)) if k in ("c2", "k2") else abs(v)
        assert abs(scaled.params[k] - v) <= 1e-6 * scale + 1e-300, (k, scaled.params[k], v)
    # the parameters and initial state in the record's units, run in its units, fit it as the unit fit did
    # (rel 1e-4: at a = 1e-12, c1 + c2 is the difference of two numbers ~1e13)
    rec = _record(generated, a, b)
    y_hat = np.asarray(scaled.simulate(rec, x0=scaled.x0[0]).y)
    nrmse = float(np.sqrt(np.mean((rec.y - y_hat) ** 2)) / np.std(rec.y))
    assert nrmse == pytest.approx(unit.nrmse, rel=1e-4)
    # a prediction (the initial state estimated from the record, as `duffsym validate` does) too: at 1e-12 it
    # was 0.0133 while its estimate ran in the record's units
    y_pred = scaled.predict(rec)
    unit_pred = unit.predict(_record(generated, 1.0, 1.0))
    assert float(np.sqrt(np.mean((rec.y - y_pred) ** 2)) / np.std(rec.y)) == pytest.approx(
        float(np.sqrt(np.mean((generated.y - unit_pred) ** 2)) / np.std(generated.y)), rel=1e-3
    )
    np.testing.assert_allclose(scaled.y_sim[0], unit.y_sim[0] * b, rtol=1e-6, atol=1e-6 * b * np.max(np.abs(rec.y)))
    # standard errors follow the parameters: relative errors of c1, k1, c3 unchanged
    for k in ("c1", "k1", "c3"):
        rel_u = unit.stderr[k] / abs(unit.params[k])
        assert scaled.stderr[k] / abs(scaled.params[k]) == pytest.approx(rel_u, rel=1e-4)
    assert scaled.settings["unit_scaling"]["normalised"] is True


def test_unit_scaling_map_derived_from_the_equations():
    from duffsym.derive.units import find_unit_scaling

    p = {"c1": 10.0, "c2": 10.0, "c3": 320.0, "k1": 34.0, "k2": 480.0, "k3": 2.0, "A_f": 1.6}
    got = find_unit_scaling(get_model("mr-damper", 5)).apply(p, 1e-3, 1e4)
    want = {**p, "c3": 320.0 * 1e12, "k3": 2.0 * 1e12, "A_f": 1.6 * 1e4 / 1e-3}
    assert got == pytest.approx(want, rel=1e-12)
    g = {"gamma": 3.0, "alpha": 100.0, "beta": 5.0, "g": 7.0}
    got = find_unit_scaling(get_model("duffing-gain")).apply(g, 2.0, 10.0)
    assert got == pytest.approx({**g, "beta": 5.0 / 100.0, "g": 7.0 * 10.0 / 2.0}, rel=1e-12)
    from duffsym.derive.units import A, B
    from duffsym.effects import CATALOGUE, apply_effects

    lagged = find_unit_scaling(apply_effects(get_model("mr-damper", 5), [CATALOGUE["output-lag"]]))
    assert lagged.diagonal and lagged.state_scales == (A, A, B)  # the lagged force carries the output's unit
    assert lagged.apply({**p, "lag_tau": 0.01}, 1e-3, 1e4) == pytest.approx({**want, "lag_tau": 0.01}, rel=1e-12)
    plain = find_unit_scaling(get_model("duffing"))  # unit input gain, output the state: only a = b
    assert plain.exists and plain.same_units and not plain.applies(2.0, 10.0) and plain.applies(10.0, 10.0)


def test_model_without_a_map_says_so(generated):
    from duffsym.identify.unitscale import unit_plan

    rec = _record(generated, 1e6, 1e6)
    plan = unit_plan(Problem(get_model("bingham"), rec))
    assert not plan.applied and (plan.a, plan.b) == (1e6, 1e6)
    assert "far from unit scale" in plan.note and "bingham" in plan.note
    unit = unit_plan(Problem(get_model("bingham"), _record(generated, 1.0, 1.0)))
    assert (unit.a, unit.b, unit.applied, unit.note) == (1.0, 1.0, False, "")


def test_start_and_bounds_in_the_record_units_are_carried_over(fits, generated):
    """A partial start and a bound given in the record's units (input and output x 1e-6) reach the same fit."""
    unit = fits[(1.0, 1.0)]
    a = 1e-6
    rec = _record(generated, a, a)
    # c3 is unchanged by this change of units (c3 a^-4 moved back by the A_f gauge's s^-4, s = 1/a)
    res = fit(Problem(get_model("mr-damper", 5), rec, bounds={"c3": (0.0, 1e3)}), {"c3": 300.0})
    assert res.success and res.settings["unit_scaling"]["normalised"] is True
    assert res.nrmse == pytest.approx(unit.nrmse, rel=1e-6)
    assert res.params["c3"] == pytest.approx(unit.params["c3"], rel=1e-6)
    assert res.settings["start"]["c3"] == pytest.approx(300.0, rel=1e-12)  # the start reported in the record's units
