"""The named pieces of the fit, each on its own (issue 14): the start, the NLP built once and solved from
several starts, the choice of the best run, the bound-restart policy. Noise-free Table 2 data (0.4 V,
2 Hz), whose optimum is the truth."""
import numpy as np
import pytest

from duffsym import Sine
from duffsym.data import synthetic_record
from duffsym.identify import Problem, fit
from duffsym.identify.collocation import best_run, bound_restart_policy, parameter_start
from duffsym.identify.nlp import CollocationNLP, Run
from duffsym.model import mr_damper
from duffsym.model.presets import table2_params

MODEL = mr_damper()
TRUTH = table2_params(0.4)


@pytest.fixture(scope="module")
def problem():
    rec = synthetic_record(MODEL, TRUTH, Sine(1.0, 2.0), dt=0.005, duration=1.5, noise=0.0, rng=0)
    return Problem(MODEL, rec, fixed={"A_f": TRUTH["A_f"]})


def _run(status="Solve_Succeeded", success=True, n_iter=10, cost=1.0, w=(1.0, 2.0)):
    return Run(status, success, n_iter, np.array(w), cost, "m")


def test_best_run_picks_the_lowest_converged_cost_even_when_runs_look_alike():
    # equal status, success and iteration count: the old tuple comparison raised on the arrays here
    runs = [_run(cost=2.0), _run(cost=1.0, w=(3.0, 4.0)), _run(cost=1.0, w=(5.0, 6.0)), _run(success=False, cost=0.1)]
    assert best_run(runs) == 1
    assert best_run([_run(success=False, cost=3.0), _run(success=False, cost=1.0)]) == 0


def test_parameter_start_takes_names_fills_guesses_and_checks_bounds(problem):
    start = parameter_start(problem, {"c1": 21.0})
    assert list(start) == list(problem.slot_names) and start["c1"] == 21.0
    assert all(np.isfinite(v) for v in start.values())
    with pytest.raises(Exception, match="outside its bounds"):
        parameter_start(problem, {"c1": -1e9})
    with pytest.raises(Exception, match="unknown parameter"):
        parameter_start(problem, {"c9": 1.0})


def test_the_nlp_is_built_once_and_every_start_reaches_the_truth(problem):
    nlp = CollocationNLP(problem, {k: TRUTH[k] * 1.5 for k in problem.slot_names}, degree=5)
    runs = [nlp.solve(th, max_iter=500) for th in (nlp.th0, nlp.th0 * 0.5, nlp.th0 * 2.0)]
    for r in runs:
        values, x0s = nlp.unscale(r.w)
        assert r.success
        assert max(abs(values[k] / TRUTH[k] - 1) for k in problem.slot_names) < 1e-4
    assert len(x0s) == 1 and len(x0s[0]) == MODEL.n_states
    # the pipeline from the same start gives the same optimum
    res = fit(problem, {k: TRUTH[k] * 1.5 for k in problem.slot_names}, degree=5, compute_stderr=False)
    assert res.cost == pytest.approx(runs[0].cost * 2 * nlp.y_norm**2, rel=1e-9)


def test_bound_restart_policy_leaves_an_interior_optimum_alone(problem):
    nlp = CollocationNLP(problem, {k: TRUTH[k] * 1.5 for k in problem.slot_names})
    run = nlp.solve(nlp.th0, max_iter=500)
    kept, note = bound_restart_policy(nlp, run, nlp.th0, max_iter=500)
    assert kept is run and note is None
