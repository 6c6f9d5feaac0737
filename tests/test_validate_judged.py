"""``validate`` judges its answer as ``fit`` does (issue 24): a prediction worse than the record's mean is
not a success; an initial state far outside the record's states is not used to absorb a level
difference; the added effects are named. Records from the independent simulator (tests/independent_sim.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import independent_sim as sim
from duffsym.cli import main
from duffsym.data.record import Record
from duffsym.identify import Problem, fit, validate
from duffsym.model import get_model

TRUTH = sim.table2(0.4)


def _record(phys=None, seed=0, amp=1.0):
    inp = sim.SumOfSines((amp,), (2.0,), (0.0,))
    g = sim.generate(TRUTH, phys or sim.Physics(), inp, dt=0.005, duration=3.0, noise=0.01, rng=seed)
    return Record(t=g.t, d=g.d, y=g.y, name=f"rec{seed}")


@pytest.fixture(scope="module")
def fitted():
    model = get_model("mr-damper", 5)
    res = fit(Problem(model, _record(), fixed={"A_f": TRUTH["A_f"]}))
    assert res.success and res.nrmse < 0.05
    return model, res


def test_a_good_prediction_is_a_success(fitted):
    model, res = fitted
    val = validate(res, _record(seed=1), model)
    assert val.success and val.message == "ok" and val.r2 > 0.99


def test_a_prediction_worse_than_the_mean_is_not_a_success(fitted):
    """The force of another device (sign reversed): R2 < 0 must be a failure with a message."""
    model, res = fitted
    other = _record(seed=2)
    flipped = Record(t=other.t, d=other.d, y=-other.y, name="flipped")
    val = validate(res, flipped, model)
    assert val.r2 < 0 and not val.success
    assert "worse than the record's mean" in val.message and "FAILED" in val.summary()
    assert val.to_dict()["success"] is False


def test_a_level_difference_is_not_absorbed_by_the_initial_state(fitted):
    """A load-cell offset of 3x the force amplitude: the first-period estimate of x0 would absorb it."""
    model, res = fitted
    rec = _record(sim.Physics(offset=3.0 * TRUTH["A_f"]), seed=3)
    val = validate(res, rec, model)
    X = np.array(val.x0)
    from duffsym.identify.states import initial_states

    Xd = initial_states(model, rec, model.param_vector(res.params))
    span = Xd.max(axis=0) - Xd.min(axis=0)
    assert np.all((X >= Xd.min(axis=0) - 2 * span) & (X <= Xd.max(axis=0) + 2 * span))
    assert not val.success or "absorb a level difference" in val.message


def test_cli_validate_names_the_effects_and_fails_on_r2_below_0(tmp_path, capsys):
    rec = _record(sim.Physics(offset=0.2 * TRUTH["A_f"]), seed=4)
    path = tmp_path / "r.csv"
    np.savetxt(
        path, np.column_stack([rec.t, rec.d, rec.y]), delimiter=",", header="time,displacement,force", comments=""
    )
    assert main(["fit", str(path), "--add", "force-offset", "--out", str(tmp_path / "f.json"), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["validate", str(tmp_path / "f.json"), str(path)]) == 0
    assert "mr-damper + force-offset" in capsys.readouterr().out
    flipped = tmp_path / "flipped.csv"
    np.savetxt(
        flipped, np.column_stack([rec.t, rec.d, -rec.y]), delimiter=",", header="time,displacement,force", comments=""
    )
    assert main(["validate", str(tmp_path / "f.json"), str(flipped), "--json"]) == 1
    out = json.loads(capsys.readouterr().out)
    assert out["success"] is False and out["effects"] == ["force-offset"] and out["r2"] < 0
