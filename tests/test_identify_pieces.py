"""The named pieces of the fit, each on its own (issue 14): the start, the NLP built once and solved from
several starts, the choice of the best run, the bound-restart policy. Noise-free Table 2 data (0.4 V,
2 Hz), whose optimum is the truth."""

import math

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


class _StallingNLP:
    """An NLP whose bound restart stalls: its solve runs the guard on slow, ill-conditioned iterations the
    way IPOPT's callback would, and returns what the guard stopped (issue 24: a restart on 3000 Silverbox
    samples ran 35-130 s per iteration at a Hessian regularisation of 1e11-1e13 and lost the converged fit)."""

    lo, hi, n_slots, y_norm = np.array([0.0, -1.0]), np.array([10.0, 1.0]), 2, 1.0
    slot_names = ("k1", "c1")

    def __init__(self, times, regs):
        self.times, self.regs, self.seen = times, regs, []

    def solve(self, th, *, max_iter, progress=None, label="", deadline=None, guard=None, w_start=None):
        from duffsym.identify.nlp import IterationLog

        log = IterationLog(0.0)
        for k, (dt, reg) in enumerate(zip(self.times, self.regs)):
            log.times.append(dt)
            log.reg.append(reg)
            self.seen.append(k + 1)
            reason = guard(log) if guard else ""
            if reason:
                return Run(
                    "User_Requested_Stop", False, k + 1, np.array([5.0, 0.5]), 9.0, "stopped", log.summary(), reason
                )
        return Run("Solve_Succeeded", True, len(self.times), np.array([5.0, 0.5]), 0.5, "ok", log.summary(), "")


def _first_on_bound():
    from duffsym.identify.nlp import IterationLog

    log = IterationLog(0.0)
    log.times += [0.3] * 24
    log.reg += [0.0] * 24
    return Run("Solve_Succeeded", True, 24, np.array([0.0, 0.2]), 1.0, "IPOPT converged", log.summary(), "")


@pytest.mark.parametrize(
    "times, regs, why",
    [
        ([0.3, 0.3, 35.0, 130.0], [0.0, 0.0, 1e11, 1e13], "took 35.0 s"),  # a slow iteration
        ([0.3] * 10, [0.0, 1e11, 1e12, 1e13, 1e12, 0.0, 0.0, 0.0, 0.0, 0.0], "regularisation"),  # ill-conditioned
        ([0.3] * 500, [0.0] * 500, "72 iterations without converging"),  # 3 x the first run's 24
    ],
)
def test_a_stalling_bound_restart_stops_early_and_keeps_the_converged_run(times, regs, why):
    first = _first_on_bound()
    nlp = _StallingNLP(times, regs)
    kept, note = bound_restart_policy(nlp, first, np.array([3.0, 0.2]), max_iter=500)
    assert kept.success and kept.cost == first.cost and np.array_equal(kept.w, first.w)
    assert note["kept"] == "first" and why in note["stopped"] and "was stopped after" in kept.message
    assert max(nlp.seen) < len(times) or len(times) == 4 and max(nlp.seen) == 3


def test_an_improving_restart_is_still_kept():
    kept, note = bound_restart_policy(
        _StallingNLP([0.3] * 20, [0.0] * 20), _first_on_bound(), np.array([3.0, 0.2]), max_iter=500
    )
    assert note["kept"] == "restart" and kept.cost == 0.5 and note["stopped"] is None


def test_the_time_limit_stops_the_fit_with_a_message_naming_the_phase(problem):
    res = fit(problem, {k: TRUTH[k] * 3.0 for k in problem.slot_names}, max_wall_time=1e-6)
    assert not res.success and res.status == "Wall_Time_Exceeded"
    assert all(np.isnan(v) for v in res.stderr.values())  # not an optimum: no standard errors
    assert "time limit" in res.message and "in the IPOPT solve" in res.message and "try:" in res.message
    it = res.settings["iterations"][0]
    assert it["n"] == 1 and it["seconds_max"] > 0


def test_the_fit_reports_its_iteration_times_and_regularisation(problem):
    lines = []
    res = fit(problem, {k: TRUTH[k] * 1.5 for k in problem.slot_names}, compute_stderr=False, progress=lines.append)
    it = res.settings["iterations"][0]
    # IPOPT reports its iteration 0 (the start) too
    assert res.success and it["n"] == res.n_iter + 1 and 0 < it["seconds_median"] <= it["seconds_max"]
    assert it["seconds_max"] <= it["seconds_total"] <= res.timings["solve"]
    assert it["regularisation_max"] >= 0 and it["ill_conditioned"] == 0
    assert any("iteration median" in x for x in lines)
    import json

    assert json.loads(json.dumps(res.to_dict()))["settings"]["iterations"][0]["n"] == res.n_iter + 1


def test_fit_options_and_keywords_are_the_same_settings(problem):
    """``fit``'s settings are one FitOptions; the keywords callers use replace its fields, an unknown keyword
    is refused by name, and the statuses are the Status members with IPOPT's strings."""
    from duffsym.identify import FitOptions
    from duffsym.status import Status

    start = {k: TRUTH[k] * 1.5 for k in problem.slot_names}
    with pytest.raises(TypeError, match="'max_iters'"):
        fit(problem, start, max_iters=5)
    with pytest.raises(TypeError, match="FitOptions"):
        fit(problem, start, {"max_iter": 5})
    by_kw = fit(problem, start, max_iter=3, compute_stderr=False, flags=False)
    by_opts = fit(problem, start, FitOptions(max_iter=3, compute_stderr=False, flags=False))
    mixed = fit(problem, start, FitOptions(max_iter=500, compute_stderr=False), max_iter=3, flags=False)
    for r in (by_kw, by_opts, mixed):
        assert r.status is Status.MAX_ITER and r.status == "Maximum_Iterations_Exceeded" and not r.success
        assert r.n_iter == 3 and r.settings["max_iter"] == 3
        assert "max_iter=3" in r.message
    assert by_opts.cost == by_kw.cost == mixed.cost
    assert FitOptions().max_iter == 500 and FitOptions().tol == 1e-10 and FitOptions().param_stride == 8


def _crawl_log(gain: float, mu: float = 1e-9, move: float = 0.1, n: int = 60):
    """An iteration log of ``n`` iterations whose cost falls by ``gain`` (relative) over the last 50 and whose
    first parameter grows by ``move`` (relative) over them, the second fixed."""
    from duffsym.identify.nlp import IterationLog

    log = IterationLog(0.0)
    k = np.arange(n, dtype=float)
    log.obj += list(37.0 * (1 - gain * k / 50))
    log.mu += [mu] * n
    log.inf_pr += [1e-6] * n
    log.params += [np.array([2000.0 * (1 + move * i / 50), 0.08]) for i in k]
    return log


def test_a_crawl_at_the_final_barrier_is_a_ridge_naming_what_still_moves():
    """The ridge rule (UTFSM campaign: the cost fell ~1 % per 50 iterations at mu 1e-8.6 while c3 grew):
    stops below a 1 % gain with a parameter moving, names it with its values; nothing else stops."""
    names, scale = ("c3", "k1"), np.array([300.0, 30.0])
    said = _crawl_log(0.005).ridge(names, scale)
    assert said.startswith("ridge:") and "0.5 %" in said and "c3 6.108e+05 -> 6.708e+05" in said and "k1" not in said
    assert _crawl_log(0.02).ridge(names, scale) == ""  # the cost still falls by 2 %: IPOPT goes on
    assert _crawl_log(0.005, mu=1e-3).ridge(names, scale) == ""  # not yet at the final barrier
    assert _crawl_log(0.005, move=0.001).ridge(names, scale) == ""  # nothing moves: converging, not crawling
    assert _crawl_log(0.005, n=50).ridge(names, scale) == ""  # fewer iterations than the window
    # a parameter far below its typical scale moves relative to its own size (the Dyke record's final ladder fit:
    # k2, typical 500, moved -12.05 -> -9.56 over 50 iterations while the cost fell 0.007 %; it ran to max_iter)
    small = _crawl_log(0.00007)
    small.params[:] = [np.array([(-12.05 + 2.486 * (i - 9) / 50) / 500, 0.08]) for i in range(60)]
    said = small.ridge(("k2", "k1"), np.array([500.0, 30.0]))
    assert said.startswith("ridge:") and "k2 -12.05 -> -9.564" in said and "k1" not in said


def _log(times, reg, inf_pr):
    from duffsym.identify.nlp import IterationLog

    log = IterationLog(0.0)
    log.times += list(times)
    log.reg += list(reg)
    log.inf_pr += list(inf_pr)
    return log


def test_a_run_whose_iterate_leaves_the_dynamics_has_diverged():
    """The divergence rule, on the numbers of the Dyke fit at 500 Hz (duffsym fit --model mr-damper-current): the
    collocation defect sat at ~2e2 from 17, then one step took it to 1.1e11; a transient climb to 3.2e3 (the Dyke
    input-delay candidate, which came back) and a start that is infeasible from the outset are not divergence."""
    n = 52
    dyke = _log([0.3] * n, [0.0] * n, [17.0] * 40 + [206.0] * 11 + [1.09e11])
    said = dyke.diverged()
    assert said.startswith("diverged:") and "1.1e+11" in said and "6.4e+09 times" in said
    assert dyke.stalled() == ""  # no slow, ill-conditioned iteration yet
    assert _log([0.1] * 16, [0.0] * 16, [16.9] * 15 + [3.23e3]).diverged() == ""
    assert _log([0.1] * 3, [0.0] * 3, [5e9, 4e9, 3e9]).diverged() == ""  # far from the dynamics, but falling
    assert _log([0.1] * 2, [0.0] * 2, [1e-3, 2e8]).diverged().startswith("diverged:")


def test_a_run_slowed_by_ill_conditioned_iterations_has_stalled():
    """The stall rule, on the Dyke fit's second start (--starts 3): iterations of 0.3-0.8 s, then 6, 7, 19, 22 s
    with the Hessian regularisation at 1e8 or more from the third of those. It stops at the third slow iteration that
    is also ill-conditioned; slow iterations alone, or ill-conditioned fast ones (the play of the friction damper:
    lg(rg) 4-10 at nearly every iteration), do not stop a run."""
    times = [0.8, 0.4, 0.5, 0.6, 0.7, 0.5, 1.4, 6.0, 6.9, 19.0, 22.0, 26.0]
    reg = [0.0] * 7 + [1e4, 1e7, 1.3e8, 3.5e8, 1.2e8]
    start2 = _log(times, reg, [1.0] * 12)
    said = start2.stalled()
    assert said.startswith("stalled: 3 iterations") and "up to 26 s" in said
    assert _log(times[:11], reg[:11], [1.0] * 11).stalled() == ""  # two of them so far
    assert _log(times, [0.0] * 12, [1.0] * 12).stalled() == ""  # slow, but well conditioned
    assert _log([0.3] * 12, [1e10] * 12, [1.0] * 12).stalled() == ""  # ill-conditioned, but not slow
    fast = _log([0.01] * 9 + [1.5] * 3, [1e9] * 12, [1.0] * 12)  # 150x its median, but under the 2 s floor
    assert fast.stalled() == ""


def test_a_run_stopped_on_a_ridge_is_usable_with_its_status_and_flag():
    from duffsym.identify.collocation import _on_ridge, ridge_flag
    from duffsym.status import Status

    why = "ridge: over the last 50 iterations the cost fell by 0.5 % while c3 6e+05 -> 6.6e+05 still moved"
    run = _on_ridge(Run("User_Requested_Stop", False, 120, np.zeros(2), 1.0, "stopped", None, why))
    assert run.status is Status.RIDGE and run.success and "120 iterations" in run.message and "c3" in run.message
    (flag,) = ridge_flag(run)
    assert flag["flag"] == "ridge" and "c3 6e+05 -> 6.6e+05" in flag["message"]
    plain = Run("Maximum_Iterations_Exceeded", False, 500, np.zeros(2), 1.0, "limit", None, "")
    assert _on_ridge(plain) is plain and ridge_flag(plain) == []


def test_a_fit_stopped_by_the_callers_guard_is_not_a_success_and_says_why(problem):
    """``guard`` (FitOptions): asked after every iteration with the iteration log; the reason it returns stops
    IPOPT there, the fit is not a success and its message gives the reason. No standard errors are computed for a
    stopped run (not an optimum); its free run is."""
    res = fit(problem, bound_restart=False, guard=lambda log: "enough" if len(log.times) >= 3 else "")
    assert not res.success and res.n_iter <= 4 and res.message == f"stopped after {res.n_iter} iterations: enough"
    assert all(math.isnan(v) for v in res.stderr.values()) and res.timings["stderr"] < 1e-3, res.stderr
    assert math.isfinite(res.nrmse)
    free = fit(problem, compute_stderr=False, bound_restart=False, guard=lambda log: "")
    assert free.success and free.n_iter > 4


def test_the_ridge_stop_reaches_ipopt_and_the_fit_reports_it(problem, monkeypatch):
    """The wiring, on a real solve: with the rule made to fire on the first 2 iterations (any gain, any mu), IPOPT
    is stopped there, and the fit carries the status, the message and the flag with the parameters that moved."""
    from duffsym.identify import nlp as nlp_mod
    from duffsym.status import Status

    for name, value in (("RIDGE_WINDOW", 2), ("RIDGE_GAIN", 1.0), ("RIDGE_MU", math.inf), ("RIDGE_INF_PR", math.inf)):
        monkeypatch.setattr(nlp_mod, name, value)
    res = fit(problem, compute_stderr=False, bound_restart=False)
    assert res.status is Status.RIDGE and res.n_iter <= 3 and res.settings["stop_rule"] == "ridge"
    (flag,) = [f for f in res.flags if f["flag"] == "ridge"]
    moved = flag["message"].split(" while ")[1]
    assert any(f"{n} " in moved for n in res.free) and " -> " in moved


def test_the_divergence_and_stall_stops_reach_ipopt_and_the_fit_says_why(problem, monkeypatch):
    """The wiring, on a real solve: with each rule made to fire at once, IPOPT stops within a few iterations and
    the fit is not a success, its message giving the rule's reason."""
    from duffsym.identify import nlp as nlp_mod

    monkeypatch.setattr(nlp_mod, "DIVERGED_INF_PR", -math.inf)
    monkeypatch.setattr(nlp_mod, "DIVERGED_GROWTH", 0.0)
    res = fit(problem, compute_stderr=False, bound_restart=False)
    assert not res.success and res.n_iter <= 3 and "diverged: IPOPT's iterate left the dynamics" in res.message
    assert res.message.endswith("Try other starts (--starts 3) or fix parameters the record does not determine (--fix)")
    assert res.settings["stop_rule"] == "diverged"
    monkeypatch.setattr(nlp_mod, "DIVERGED_INF_PR", math.inf)
    for name, value in (("REGULARISATION_ALARM", -1.0), ("STALL_FLOOR", -1.0), ("STALL_FACTOR", 0.0)):
        monkeypatch.setattr(nlp_mod, name, value)
    res = fit(problem, compute_stderr=False, bound_restart=False)
    assert not res.success and res.n_iter <= 7 and "stalled: 3 iterations" in res.message
    assert res.settings["stop_rule"] == "stalled"


def test_the_second_start_follows_the_stop_rule_not_the_message(problem, monkeypatch):
    """A failed fit whose message carries the divergence rule's words but which IPOPT ended on its own
    (``settings["stop_rule"]`` None) is not fitted again: the second start reads the rule, not the words."""
    from dataclasses import replace

    from duffsym.identify import collocation

    real, calls = collocation._fit_from, []

    def fake(pb, x0, opts):
        calls.append(x0)
        res = real(pb, x0, opts)
        assert res.settings["stop_rule"] is None  # this small fit converges on its own
        return replace(res, success=False, message="stopped after 9 iterations: diverged: words, not the rule")

    monkeypatch.setattr(collocation, "_fit_from", fake)
    res = fit(problem, compute_stderr=False)
    assert len(calls) == 1 and not res.success and "second_start" not in res.settings


def test_an_automatic_start_whose_fit_diverges_free_is_fitted_again_from_the_defaults(problem, monkeypatch):
    """The control flow of the second start (the real case, s12's smoke record, runs in
    tests/test_studies_control_smoke.py): a first fit from the automatic start reported as diverging when run
    free is followed by a fit from the model's defaults, kept when usable and said in the message and settings;
    a start the user gave is never replaced."""
    from dataclasses import replace

    from duffsym.identify import collocation
    from duffsym.status import Status

    real, calls = collocation._fit_from, []

    def first_diverges(pb, x0, opts):
        calls.append(x0)
        res = real(pb, x0, opts)
        if len(calls) == 1:
            return replace(res, status=Status.FREE_RUN_FAILED, success=False, message="IPOPT converged but: blew up")
        return res

    monkeypatch.setattr(collocation, "_fit_from", first_diverges)
    res = fit(problem, compute_stderr=False)
    assert calls[0] is None and calls[1] == {n: MODEL.param(n).default for n in problem.free}
    assert res.success and res.settings["second_start"]["kept"] == "defaults"
    assert "from the model's defaults" in res.message and "blew up" in res.message
    assert res.nrmse < 1e-3  # noise-free record: the second fit reaches the truth
    calls.clear()
    given = fit(problem, x0={n: MODEL.param(n).default for n in problem.free}, compute_stderr=False)
    assert len(calls) == 1 and given.status is Status.FREE_RUN_FAILED


@pytest.mark.parametrize("rule", ["diverged", "stalled"])
def test_an_automatic_start_whose_solve_diverges_or_stalls_is_fitted_again_from_the_defaults(
    problem, monkeypatch, rule
):
    """The same second start after the divergence or stall stop (the real case: 6 s of the Dyke record at 500 Hz,
    whose command start diverged at iteration 52 and whose fit from the defaults reached NRMSE 0.197); any other
    failed stop (here the caller's guard) is not fitted again."""
    from dataclasses import replace

    from duffsym.identify import collocation

    real, calls = collocation._fit_from, []

    def first_stops(pb, x0, opts):
        calls.append(x0)
        res = real(pb, x0, opts)
        if len(calls) == 1:
            stopped = {**res.settings, "stop_rule": rule}
            return replace(res, success=False, message=f"stopped after 52 iterations: {rule}: the rule's words",
                           settings=stopped)  # fmt: skip
        return res

    monkeypatch.setattr(collocation, "_fit_from", first_stops)
    res = fit(problem, compute_stderr=False)
    assert calls[0] is None and calls[1] == {n: MODEL.param(n).default for n in problem.free}
    assert res.success and res.settings["second_start"]["kept"] == "defaults" and res.nrmse < 1e-3
    assert f"the automatic start's fit was stopped: {rule}: the rule's words" in res.message
    calls.clear()
    monkeypatch.setattr(
        collocation,
        "_fit_from",
        lambda pb, x0, opts: (
            calls.append(x0)
            or replace(
                res := real(pb, x0, opts),
                success=False,
                message="stopped after 3 iterations: enough",
                settings={**res.settings, "stop_rule": "enough"},
            )
        ),
    )
    assert not fit(problem, compute_stderr=False).success and len(calls) == 1
