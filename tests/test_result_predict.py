"""``IdentificationResult.predict`` / ``.simulate`` (issue 27, item 2): the fitted model on a new record, as
``duffsym validate`` computes it. Records from the independent simulator (tests/independent_sim.py), with noise
and a load-cell offset the fit models by ``force-offset``."""

from __future__ import annotations

import json

import numpy as np
import pytest

import independent_sim as sim
from duffsym.cli import main
from duffsym.data import read_csv
from duffsym.data.record import Record
from duffsym.effects import CATALOGUE
from duffsym.identify import Problem, fit, load_result, nrmse
from duffsym.identify.validation import model_from_result
from duffsym.model import get_model

TRUTH = sim.table2(0.4)


def _csv(path, seed: int):
    inp = sim.SumOfSines((1.0, 0.3), (2.0, 5.0), (0.0, 0.7))
    g = sim.generate(TRUTH, sim.Physics(offset=0.15 * TRUTH["A_f"]), inp, dt=0.005, duration=3.0, noise=0.01, rng=seed)
    np.savetxt(path, np.column_stack([g.t, g.d, g.y]), delimiter=",", header="time,displacement,force", comments="")
    return path


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    folder = tmp_path_factory.mktemp("predict")
    train, test = _csv(folder / "train.csv", 0), _csv(folder / "test.csv", 1)
    model = CATALOGUE["force-offset"].apply(get_model("mr-damper", 5))
    res = fit(Problem(model, read_csv(train), fixed={"A_f": TRUTH["A_f"]}))
    assert res.success and res.nrmse < 0.05
    res.save(folder / "FIT.json")
    return res, folder / "FIT.json", test


def test_the_result_keeps_the_model_object(fitted):
    res, path, _ = fitted
    assert res.model == "mr-damper" and res.to_dict()["model"] == "mr-damper"  # the name in the contract
    assert res.model_obj is res.fitted_model and res.model_obj.effect_objects == (CATALOGUE["force-offset"],)
    assert model_from_result(res) is res.model_obj
    loaded = load_result(path)
    assert loaded.fitted_model is None and loaded.model_obj == res.model_obj  # rebuilt from model_spec


def test_predict_is_what_validate_computes(fitted, capsys):
    """The prediction of the fit in memory and of the fit read back from FIT.json both give the NRMSE that
    ``duffsym validate --json`` prints for that record, to 1e-12, from the same initial state."""
    res, path, test = fitted
    capsys.readouterr()
    assert main(["validate", str(path), str(test), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert "data_sanity" not in out or out["data_sanity"].get("ok", True)
    rec = read_csv(test)
    for result in (res, load_result(path)):
        y = result.predict(rec)
        assert abs(nrmse(rec.y, y) - out["nrmse"]) <= 1e-12
        tr = result.simulate(rec)
        assert tr.success and np.allclose(tr.x[0], out["x0"], rtol=1e-12, atol=0)
    assert out["nrmse"] < 0.05  # a usable prediction on the held-out record (noise 1 %)


def test_simulate_takes_the_initial_state_and_options(fitted):
    res, _, test = fitted
    rec = read_csv(test)
    zero = res.simulate(rec, x0=np.zeros(2))
    assert np.allclose(zero.x[0], 0.0)
    est = res.predict(rec)
    # the estimated start removes the start-up transient that a start from rest leaves
    n = rec.n_times // 6
    assert np.sqrt(np.mean((est[:n] - rec.y[:n]) ** 2)) < np.sqrt(np.mean((zero.y[:n] - rec.y[:n]) ** 2))
    fine = res.simulate(rec, h_lambda=0.02)  # an option of simulate_record: finer RK4 substeps, the same run
    assert fine.substeps.sum() > res.simulate(rec).substeps.sum()
    assert np.allclose(fine.y, est, atol=1e-3 * np.max(np.abs(est)))  # the discretisation error only


def test_predict_uses_the_group_of_the_record():
    """A fit with groups (one parameter set per current): predict takes the record's group."""
    res = _grouped()
    rec = Record(
        t=np.arange(400) * 0.005, d=np.sin(np.arange(400) * 0.05), y=np.cos(np.arange(400) * 0.05), current=0.5
    )
    assert res.group_for(rec) == "0.5A"
    p_half = res.model_obj.param_vector(res.params_for("0.5A"))
    assert np.array_equal(res.simulate(rec, x0=np.zeros(2)).y, res.simulate(rec, x0=np.zeros(2), group="0.5A").y)
    other = res.simulate(rec, x0=np.zeros(2), group="1A").y
    assert not np.allclose(other, res.simulate(rec, x0=np.zeros(2)).y) and p_half[2] == 300.0


def _grouped():
    from duffsym.identify.result import IdentificationResult

    model = get_model("mr-damper", 5)
    base = model.defaults()
    groups = {"0.5A": {**base, "c3": 300.0}, "1A": {**base, "c3": 600.0}}
    return IdentificationResult(
        model=model,
        params=groups["0.5A"],
        free=("c3",),
        fixed={},
        stderr={"c3": 1.0},
        covariance=np.eye(1),
        cost=0.0,
        nrmse=0.1,
        r2=0.99,
        status="Solve_Succeeded",
        success=True,
        message="",
        n_iter=1,
        timings={},
        group_params=groups,
        groups=("0.5A", "1A"),
    )
