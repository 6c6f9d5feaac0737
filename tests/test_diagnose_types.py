"""The typed pieces of a diagnosis and the options objects: each reproduces the JSON it replaced, screening
marks a candidate with a status instead of a string in its prediction slot, and every options-taking function
rejects an unknown setting by name while keyword calls keep working."""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

from duffsym.diagnose import BaseCheck, CandidateRun, DiagnoseOptions, LadderOptions, SindyCheck, Split
from duffsym.diagnose.parts import FitOutcome
from duffsym.options import resolve
from duffsym.status import Status


# ------------------------------------------------------------------------------------------ options
def test_resolve_merges_options_and_keywords_and_names_an_unknown_setting():
    base = DiagnoseOptions(holdout=0.25, screen=None)
    o = resolve(DiagnoseOptions, base, {"sindy": False}, "diagnose")
    assert (o.holdout, o.screen, o.sindy, o.bic_threshold) == (0.25, None, False, -10.0)
    assert resolve(DiagnoseOptions, None, {}, "diagnose") == DiagnoseOptions()
    with pytest.raises(TypeError, match="diagnose.*'holdouts'"):
        resolve(DiagnoseOptions, None, {"holdouts": 0.2}, "diagnose")
    with pytest.raises(TypeError, match="must be a DiagnoseOptions"):
        resolve(DiagnoseOptions, LadderOptions(), {}, "diagnose")


def test_every_options_function_rejects_an_unknown_setting_before_any_work():
    from duffsym.control import invert
    from duffsym.diagnose import diagnose, ladder
    from duffsym.uncertainty import sample

    # the records are never looked at: the settings are checked first
    with pytest.raises(TypeError, match="'candidate_maxiter'"):
        diagnose(None, candidate_maxiter=3)
    with pytest.raises(TypeError, match="'max_step'"):
        ladder(None, max_step=2)
    with pytest.raises(TypeError, match="'walkers'"):
        sample(None, None, walkers=8)
    with pytest.raises(TypeError, match="'limit'"):
        invert(None, {}, [0.0, 1.0], np.zeros((2, 1)), [0.0, 0.0], limit=(0, 1))


def test_the_ladder_passes_diagnose_settings_on_as_rules_and_keeps_its_own():
    from duffsym.diagnose.ladder import _ladder_options

    o = _ladder_options(None, {"max_steps": 1, "screen": 2, "sindy": False})
    assert o.max_steps == 1 and dict(o.rules) == {"screen": 2, "sindy": False}
    o2 = _ladder_options(LadderOptions(rules={"decimate": False}), {"screen": None})
    assert dict(o2.rules) == {"decimate": False, "screen": None}
    with pytest.raises(TypeError, match="'start'"):  # the ladder sets each step's start itself
        _ladder_options(None, {"start": {}})


# ------------------------------------------------------------------------------------------ the JSON pieces
def test_split_and_base_check_give_the_dicts_they_replaced_and_read_like_them():
    s = Split(n_fit=841, n_heldout=360, t_split=4.2)
    assert json.dumps(s.to_dict()) == '{"n_fit": 841, "n_heldout": 360, "t_split": 4.2}'
    assert s["n_fit"] == 841 and dict(s) == s.to_dict()
    c = BaseCheck(
        reference="the given fit",
        nrmse_fit_part=0.1,
        reference_nrmse_fit_part=0.09,
        start="given start",
        as_good=False,
        budget=("base fit",),
        stable=True,
        stability="",
    )
    assert list(c.to_dict()) == [
        "reference",
        "nrmse_fit_part",
        "reference_nrmse_fit_part",
        "start",
        "as_good",
        "budget",
        "stable",
        "stability",
    ]
    assert c.to_dict()["budget"] == ["base fit"] and c.get("as_good") is False


@pytest.mark.parametrize(
    "evidence",
    [
        {
            "verdict": "consistent",
            "conclusive": True,
            "missing_terms": [],
            "absent_model_terms": ["x"],
            "reasons": ["r"],
            "message": "m",
        },
        {"verdict": "not applicable", "conclusive": False, "missing_terms": [], "message": "could not run"},
        {
            "verdict": "missing-terms",
            "conclusive": True,
            "missing_terms": [
                {"term": "tanh(x'/eps)", "effect": "coulomb-friction", "supported": True},
                {"term": "x^3", "effect": None, "supported": False},
            ],
            "absent_model_terms": [],
            "reasons": [],
            "message": "m",
            "later_key": 1.5,
        },
    ],
)
def test_sindy_check_round_trips_the_evidence_byte_for_byte(evidence):
    check = SindyCheck.from_evidence(evidence)
    assert json.dumps(check.to_dict()) == json.dumps(evidence)
    assert [m["term"] for m in check.supported_terms] == [
        m["term"] for m in evidence["missing_terms"] if m["supported"]
    ]


# ------------------------------------------------------------------------------------------ candidate runs
def _fake_fit(status: str, success: bool = False):
    return SimpleNamespace(status=status, success=success, params={"a": 1.0}, settings={}, message=status)


def test_screening_continues_the_best_and_marks_the_others_screened_out_without_a_fit():
    from duffsym.diagnose.search import _screen_and_continue

    runs = [
        CandidateRun(name=n, effect=None, model=None, ss=ss, fit=_fake_fit(st, ok), seconds=1.0)
        for n, ss, st, ok in [
            ("slow", 3.0, "Maximum_Iterations_Exceeded", False),
            ("done", 0.5, "Solve_Succeeded", True),
            ("best", 1.0, "Maximum_Iterations_Exceeded", False),
            ("broke", 0.1, "Infeasible_Problem_Detected", False),
            ("worst", 9.0, "Maximum_CpuTime_Exceeded", False),
        ]
    ]
    continued = []

    def job(task):
        continued.append((task.name, task.budget))
        return FitOutcome(ss=0.2, fit=_fake_fit("Solve_Succeeded", True), y=np.zeros(3), seconds=2.0)

    _screen_and_continue(runs, 1, 30, 100, job, None, lambda *a, **k: None)
    by = {r.name: r for r in runs}
    assert [r.name for r in runs] == ["broke", "done", "best", "slow", "worst"]  # sorted by free-run error
    assert continued == [("best", 100)]
    assert by["best"].converged and by["best"].seconds == 3.0 and by["best"].ss == 0.2
    for name, rank in (("slow", 2), ("worst", 3)):
        r = by[name]
        assert r.fit is None and r.y is None and r.status is Status.SCREENED_OUT
        assert r.message.startswith("screened out") and f"ranks {rank} of the 3" in r.message
    # converged and failed runs take no part in the screening
    assert by["done"].status is None and by["broke"].fit_status is Status.INFEASIBLE


def test_a_continuation_that_raises_or_runs_out_of_time_leaves_no_fit_and_says_why():
    from duffsym.diagnose.search import NOT_TRIED, _screen_and_continue

    runs = [
        CandidateRun(name="a", effect=None, model=None, ss=1.0, fit=_fake_fit("Maximum_Iterations_Exceeded")),
        CandidateRun(name="b", effect=None, model=None, ss=2.0, fit=_fake_fit("Maximum_Iterations_Exceeded")),
    ]
    outcomes = iter(
        [
            FitOutcome(error="bad bounds", status=Status.UNKNOWN, seconds=0.5),
            FitOutcome(error=NOT_TRIED, status=Status.TIME_LIMIT),
        ]
    )
    _screen_and_continue(runs, 4, 30, 100, lambda task: next(outcomes), None, lambda *a, **k: None)
    assert [(r.fit, r.status, r.message) for r in runs] == [
        (None, Status.UNKNOWN, "bad bounds"),
        (None, Status.TIME_LIMIT, NOT_TRIED),
    ]


def test_a_run_without_a_usable_fit_becomes_a_failed_candidate_with_its_reason():
    from duffsym.diagnose.search import _not_judged
    from duffsym.effects import CATALOGUE

    eff = CATALOGUE["backlash"]
    run = CandidateRun(name="backlash", effect=eff, model=None, seconds=4.0)
    run.drop(Status.SCREENED_OUT, "screened out: ranks 5 of 5")
    c = _not_judged(run)
    assert (c.effect, c.success, c.message, c.seconds, c.diverged) == (
        "backlash",
        False,
        "screened out: ranks 5 of 5",
        4.0,
        False,
    )
    assert math.isnan(c.nrmse_after) and c.physics == eff.physics
    diverged = CandidateRun(name="backlash", effect=eff, model=None, fit=_fake_fit("Solve_Succeeded", True), y=None)
    assert _not_judged(diverged).diverged
    assert (
        _not_judged(
            CandidateRun(name="backlash", effect=eff, model=None, fit=_fake_fit("Solve_Succeeded", True), y=np.zeros(3))
        )
        is None
    )


def test_on_an_engine_the_costliest_runs_are_submitted_first_and_results_come_back_in_task_order():
    # LPT scheduling: the second starts of the Dyke diagnosis were submitted in catalogue order, so the
    # 35-s backlash fit started last and one of the two workers sat idle for ~24 s at the end of the phase
    from duffsym.diagnose.search import _second_starts
    from duffsym.engine import Outcome

    class Recording:
        submitted: list = []

        def as_completed(self, func, items):
            self.submitted = [t.name for t in items]
            for i in reversed(range(len(items))):  # any completion order
                yield Outcome(i, value=func(items[i]))

    runs = [
        CandidateRun(
            name=n,
            effect=SimpleNamespace(parameters=list),
            model=None,
            ss=5.0,
            fit=_fake_fit("Maximum_Iterations_Exceeded"),
            seconds=s,
        )
        for n, s in [("cheap", 3.0), ("dear", 40.0), ("middle", 12.0)]
    ]
    ss_of = {"cheap": 1.0, "dear": 2.0, "middle": 3.0}

    def job(task):
        return FitOutcome(ss=ss_of[task.name], fit=_fake_fit("Solve_Succeeded", True), y=np.zeros(3), seconds=1.0)

    engine = Recording()
    _second_starts(runs, 4.0, SimpleNamespace(params={}, success=False), 30, job, engine, lambda *a, **k: None)
    assert engine.submitted == ["dear", "middle", "cheap"]
    assert [(r.name, r.ss, r.seconds, r.fit.settings["candidate_start"]) for r in runs] == [
        ("cheap", 1.0, 4.0, 2),
        ("dear", 2.0, 41.0, 2),
        ("middle", 3.0, 13.0, 2),
    ]


def test_with_screening_an_unfinished_run_better_than_the_base_gets_no_second_start():
    # on the Dyke record 7 of 11 second starts went to runs that were only unfinished at the screening budget
    # and already better than the base: 62 s of CPU, none of their errors changed by more than 2 %
    from duffsym.diagnose.search import _second_starts

    def runs():
        return [
            CandidateRun(
                name=n,
                effect=SimpleNamespace(parameters=list),
                model=None,
                ss=ss,
                fit=_fake_fit(st, st == "Solve_Succeeded"),
                seconds=1.0,
            )
            for n, ss, st in [
                ("open-better", 3.0, "Maximum_Iterations_Exceeded"),
                ("timed-out-better", 3.5, "Maximum_CpuTime_Exceeded"),
                ("open-worse", 5.0, "Maximum_Iterations_Exceeded"),
                ("broke", 1.0, "Infeasible_Problem_Detected"),
                ("done-worse", 6.0, "Solve_Succeeded"),
                ("done-better", 2.0, "Solve_Succeeded"),
            ]
        ]

    for screening, want in [
        (True, ["open-worse", "broke", "done-worse"]),
        (False, ["open-better", "timed-out-better", "open-worse", "broke", "done-worse"]),
    ]:
        started: list[str] = []

        def job(task, started=started):
            started.append(task.name)
            return FitOutcome(ss=9.0, fit=_fake_fit("Maximum_Iterations_Exceeded"), y=np.zeros(3), seconds=1.0)

        _second_starts(
            runs(), 4.0, SimpleNamespace(params={}, success=False), 30, job, None, lambda *a, **k: None, screening
        )
        assert started == want


def test_a_second_start_is_bounded_by_the_base_fits_iterations():
    """Each second start carries the base fit's iteration summary (its median iteration raised to the candidate's
    own first run's when that was slower); none when the base fit failed. On the 6 s Dyke command record the
    candidates' second starts took 40 s unbounded, 22 s bounded."""
    from duffsym.diagnose.search import _second_starts

    def first(median):
        fit = _fake_fit("Maximum_Iterations_Exceeded")
        fit.settings = {"iterations": [{"seconds_median": median}]} if median is not None else {}
        return fit

    def lost_runs():
        return [
            CandidateRun(name=n, effect=SimpleNamespace(parameters=list), model=None, ss=5.0, fit=first(m), seconds=1.0)
            for n, m in [("slow-first", 0.3), ("fast-first", 0.01), ("no-log", None)]
        ]

    base = SimpleNamespace(params={}, success=True, n_iter=40, settings={"iterations": [{"seconds_median": 0.05}]})
    for b, want in [
        (base, {"slow-first": (0.3, 40), "fast-first": (0.05, 40), "no-log": (0.05, 40)}),
        (SimpleNamespace(params={}, success=False), {"slow-first": None, "fast-first": None, "no-log": None}),
    ]:
        seen: dict = {}

        def job(task, seen=seen):
            bound = task.bounded_by
            seen[task.name] = None if bound is None else (bound[0]["seconds_median"], bound[1])
            return FitOutcome(error="not tried")

        _second_starts(lost_runs(), 4.0, b, 30, job, None, lambda *a, **k: None)
        assert seen == want


def test_a_bounded_candidate_fit_stops_when_its_iterations_turn_slow(monkeypatch):
    """The bound reaches IPOPT: with every iteration counted as slow (floor 0, a median of 1 ns) the candidate's
    fit stops after its first iteration, not a success, and says why; unbounded, the same fit converges."""
    from duffsym import Sine, mr_damper
    from duffsym.data import synthetic_record
    from duffsym.diagnose.search import CandidateTask, _CandidateFit
    from duffsym.effects import CATALOGUE, apply_effects
    from duffsym.identify import nlp as nlp_mod
    from duffsym.model.presets import table2_params

    monkeypatch.setattr(nlp_mod, "RESTART_SLOW_FLOOR", 0.0)
    m = mr_damper()
    truth = {**table2_params(0.4), "off_y0": 0.2}
    ext = apply_effects(m, [CATALOGUE["force-offset"]])
    record = synthetic_record(ext, truth, Sine(1.0, 2.0), dt=0.005, duration=2.0, noise=0.01, rng=1, settle=1.0)
    n, fixed = len(record.t), {"A_f": truth["A_f"]}
    job = _CandidateFit(record, n, record, table2_params(0.4), np.zeros(n), fixed, None, None)
    start = {**table2_params(0.4), "off_y0": 0.0}
    free = job(CandidateTask("force-offset", ext, 200, start))
    bounded = job(CandidateTask("force-offset", ext, 200, start, ({"seconds_median": 1e-9}, 10)))
    assert free.fit.success and free.fit.n_iter > 1
    assert not bounded.fit.success and bounded.fit.n_iter <= 1
    assert "an iteration took" in bounded.fit.message
