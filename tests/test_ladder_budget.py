"""The ladder that finishes and keeps what it did (issue 22): a time budget, steps written as they complete, the
end product never a failed fit, inactive effects flagged, the joint refit of several effects, the play of a real
friction damper. Records come from the independent generator (tests/independent_sim.py, no duffsym code) and
from the real friction damper in ../shared/data/external (skipped when absent)."""

import json
import math

import numpy as np
import pytest

import independent_sim as gen
from _external import BRFD, BRFD_RECORDS, external_file
from duffsym.data.record import Record
from duffsym.errors import DataError


def record(effects, seed, **kw):
    g = gen.scenario(effects, seed, **kw)
    return Record(t=g.t, d=g.d, y=g.y, name=f"{effects}-{seed}", source="independent_sim"), g


# ------------------------------------------------------------------------------------------- JSON loader
def test_friction_damper_json_is_read_with_its_columns_and_rate(tmp_path):
    from duffsym.data.loaders import load_friction_damper_json

    t = np.arange(50) / 1024.0
    w = 2 * np.pi * 50.0  # two cycles of a 50 Hz sine
    rows = np.column_stack([t, np.sin(w * t), 2 * np.cos(w * t), w * np.cos(w * t), 0 * t, 0 * t]).tolist()
    p = tmp_path / "rec.json"
    p.write_text(json.dumps({"data": rows, "dt": 1 / 1024, "displacement units": "in", "friction force units": "kip"}))
    rec = load_friction_damper_json(p)
    assert rec.n_times == 50 and rec.dt == pytest.approx(1 / 1024)
    assert rec.y[3] == pytest.approx(2 * math.cos(w * t[3])) and rec.d_dot[3] == pytest.approx(w * math.cos(w * t[3]))
    assert rec.units["d"] == "in" and rec.units["y"] == "kip"
    (tmp_path / "bad.json").write_text(json.dumps({"rows": [[1, 2]]}))
    with pytest.raises(DataError, match="'data' is a list of rows"):
        load_friction_damper_json(tmp_path / "bad.json")


def test_real_friction_damper_json_loads_at_1024_hz():
    from duffsym.data.loaders import load_friction_damper_json

    rec = load_friction_damper_json(external_file(BRFD, "0.5Hz30lbtension1amplitude.json"))
    assert rec.n_times == 14337 and 1 / rec.dt == pytest.approx(1024.0)
    assert 1.9 < np.ptp(rec.d) < 2.1  # a 1 in amplitude sine (SOURCE.md)


# ------------------------------------------------------------------------------------------- inactive effects
def _seal_model():
    from duffsym.effects import CATALOGUE, apply_effects
    from duffsym.model.library import mr_damper

    return apply_effects(mr_damper(), [CATALOGUE["seal-friction"]])


def test_seal_friction_added_to_a_record_without_it_is_flagged_inactive():
    from duffsym.diagnose import diagnose
    from duffsym.diagnose.search import inactive_effects

    model = _seal_model()
    rec, _ = record("clean", 3)  # no friction in the generator's device
    dg = diagnose(rec, model, candidates=[], sindy=False)
    flagged = inactive_effects(model, rec, dg.base_fit.params, dg.base_fit.stderr)
    assert "seal-friction" in flagged  # measured: seal_F = 0 (its lower bound)
    # the switch cannot run off: seal_eps stays within the record's velocity range
    vmax = float(np.max(np.abs(rec.velocity())))
    assert dg.base_fit.params["seal_eps"] <= vmax * (1 + 1e-6)


@pytest.mark.slow
def test_seal_friction_is_not_flagged_where_it_acts_and_is_where_it_only_absorbs_noise():
    from duffsym.diagnose import diagnose
    from duffsym.diagnose.search import inactive_effects

    model = _seal_model()
    rec, g = record("seal-friction", 0)
    dg = diagnose(rec, model, candidates=[], sindy=False)
    assert inactive_effects(model, rec, dg.base_fit.params, dg.base_fit.stderr) == {}
    assert dg.base_fit.params["seal_F"] == pytest.approx(g.truth["physics"]["seal_friction"], rel=0.25)
    rec, _ = record("force-offset", 3)  # measured: seal_F = 0.037 +- 0.055 (the model lacks the offset)
    dg = diagnose(rec, model, candidates=[], sindy=False)
    assert (
        "not distinguishable from zero"
        in inactive_effects(model, rec, dg.base_fit.params, dg.base_fit.stderr)["seal-friction"]
    )


def test_a_fit_flags_an_added_effect_that_does_nothing_and_not_one_that_acts():
    from duffsym.identify import Problem, fit

    model = _seal_model()
    rec, _ = record("clean", 2)  # no friction in the generator's device
    flags = {f["flag"]: f for f in fit(Problem(model, [rec])).flags}
    assert flags["inactive-effect"]["effects"] == ["seal-friction"]  # measured: seal_F = 0, on its bound
    assert "seal-friction: its force is negligible" in flags["inactive-effect"]["message"]
    rec, g = record("seal-friction", 0)
    res = fit(Problem(model, [rec]))
    assert "inactive-effect" not in {f["flag"] for f in res.flags}
    assert res.params["seal_F"] == pytest.approx(g.truth["physics"]["seal_friction"], rel=0.25)  # measured 0.0718


def test_field_yield_activity_names_a_negligible_a_flat_and_an_insignificant_yield():
    from duffsym.effects import EXTENSIONS

    fy = EXTENSIONS["field-yield"]
    t = np.arange(400) * 0.01
    rec = Record(t=t, d=np.sin(2 * np.pi * t), y=10 * np.cos(2 * np.pi * t), current=0.5)  # max|d'| = 2 pi
    acting = dict(fy_F=1.0, fy_F_u=2.0, fy_eps=0.1)  # a yield of 2 against a force spread of 7.07
    assert fy.activity(rec, acting, {"fy_F": 0.1, "fy_F_u": 0.1}) == ""
    assert "negligible" in fy.activity(rec, dict(acting, fy_F=0.0, fy_F_u=0.01), {})
    assert "flat over the record" in fy.activity(rec, dict(acting, fy_eps=4.0), {})
    said = fy.activity(rec, acting, {"fy_F": 1.0, "fy_F_u": 2.0})
    assert "fy_F = 1 ± 1" in said and "fy_F_u = 2 ± 2" in said
    assert fy.activity(rec, acting, {"fy_F": 1.0, "fy_F_u": 0.1}) == ""  # one magnitude is significant


# ------------------------------------------------------------------------------------------- budget
def test_a_tiny_budget_stops_the_ladder_with_its_finished_steps_written(tmp_path):
    from duffsym.cli import main
    from duffsym.data import write_csv

    rec, _ = record(("force-offset", "output-lag"), 1)
    csv = tmp_path / "rec.csv"
    write_csv(rec, csv)
    out, rep = tmp_path / "fit.json", tmp_path / "report"
    code = main(
        [
            "ladder",
            str(csv),
            "--budget",
            "4",
            "--no-sindy",
            "--candidates",
            "force-offset,output-lag",
            "--report",
            str(rep),
            "--out",
            str(out),
            "--quiet",
            "--json",
        ]
    )
    doc = json.loads((rep / "ladder.json").read_text())
    assert len(doc["steps"]) >= 1 and (rep / "step0" / "diagnosis.md").is_file()
    assert doc["budget"] == 4.0
    assert doc["final"]["success"] and code == 0 and out.is_file()  # never a failed fit as the end product
    if not doc["complete"]:  # stopped by the budget: said so, honestly
        assert doc["stopped"].startswith("stopped at step") and "time budget" in doc["stopped"]
    # every fit had its share: nothing ran longer than the budget plus the final fit's reserve by much
    assert doc["timings"]["total"] < 60


@pytest.mark.slow
@pytest.mark.ci
def test_a_candidate_stopped_by_its_cpu_allowance_does_not_skip_the_backward_pass():
    # the CI run of 2026-11-28: backlash ran out of its 30 s CPU allowance on a slower machine (here it stops at
    # max_iter in 15 s), the ladder called that "the time budget ran out" although none was given, marked itself
    # incomplete and skipped the backward pass, so gas-accumulator was kept where the offset it contains does
    from duffsym.diagnose import ladder

    rec, _ = record(("force-offset", "output-lag"), 1)
    # the two converge in < 0.4 s each; backlash needs about 6 s (before its gap state: 10 s, to max_iter)
    lad = ladder(rec, sindy=False, candidates=["gas-accumulator", "output-lag", "backlash"], candidate_cpu_time=1.5)
    assert [s.effects for s in lad.steps[1:3]] == [("gas-accumulator",), ("gas-accumulator", "output-lag")]
    assert lad.complete and lad.steps[-1].simplified == "gas-accumulator -> force-offset"
    assert set(lad.effects) == {"force-offset", "output-lag"}
    assert "backlash: not converged within candidate_cpu_time = 1.5 s" in lad.stopped
    assert "time budget" not in lad.stopped


def test_budget_argument_is_checked():
    from duffsym.cli import main

    assert main(["ladder", "no-such.csv", "--budget", "soon"]) != 0


# ------------------------------------------------------------------------------------------- joint refit
@pytest.mark.slow
def test_play_and_seal_friction_together_end_within_twice_the_noise():
    from duffsym.diagnose import ladder

    rec, g = record(("seal-friction", "backlash"), 0)
    lad = ladder(rec, sindy=False)
    k = lad.steps[-1].diagnosis.split["n_fit"]
    noise = g.noise_std / float(np.std(rec.y[k:]))
    assert {"seal-friction", "backlash"} <= set(lad.effects)
    assert lad.steps[-1].nrmse_heldout < 2 * noise


# ------------------------------------------------------------------------------------------- real play
@pytest.mark.parametrize(
    "name",
    BRFD_RECORDS,
)
def test_plateau_half_width_of_the_real_friction_damper_matches_its_deadzone_mask(name):
    from duffsym.data.loaders import load_friction_damper_json
    from duffsym.effects import CATALOGUE
    from duffsym.effects.inputs import plateau_half_width
    from duffsym.identify.initial import auto_mask

    rec = load_friction_damper_json(external_file(BRFD, f"{name}.json"))
    h = plateau_half_width(rec)
    width = auto_mask(rec)[1]["median_displacement_width"]  # the masked stretch: the gap 2h plus the force's rise
    # measured: h = 0.101-0.113 in, mask widths 0.302-0.354 in, whatever the amplitude (0.5 or 1 in) or frequency
    assert 0.25 * width < h < 0.5 * width and 0.08 < h < 0.13
    # the play candidate starts there (not at the 1 % floor the quarter-range rule alone gives on these loops)
    guess = CATALOGUE["backlash"].initial_guess(rec, np.zeros(rec.n_times))["bl_h"]
    assert guess == pytest.approx(h, rel=0.5)


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="measured: the mr-damper base holds its hysteretic force while the piston "
    "crosses the gap, so base + play cannot make the zero-force plateau; h fixed at the plateau value "
    "0.10 in fits worse (held-out 0.50 vs 0.23), free h runs to its range limits (issue 22 report); the play in "
    "series with the element, contact-gap, is the structure that fits (tests/test_contact_gap.py)",
)
def test_play_of_the_real_friction_damper_matches_its_plateaus():
    from duffsym.data.loaders import load_friction_damper_json
    from duffsym.diagnose import diagnose
    from duffsym.effects.inputs import plateau_half_width

    rec = load_friction_damper_json(external_file(BRFD, "0.5Hz30lbtension1amplitude.json"))
    dg = diagnose(rec, candidates=["backlash"], sindy=False, deadline=None)
    c = dg.candidates[0]
    assert c.success, c.message
    h, se = c.params["bl_h"], c.stderr["bl_h"]
    assert abs(h - plateau_half_width(rec)) < 0.3 * h and se < 0.2 * h
    assert c.nrmse_after < dg.nrmse_heldout


def test_the_play_candidate_converges_where_its_piston_state_did_not():
    # before the gap state (the play's state was the piston position b): IPOPT reached max_iter = 100 on this
    # record in 10 s, its Hessian regularised at nearly every iteration; with z = (d - b) / h' it converges
    from duffsym.diagnose import diagnose

    rec, _ = record(("force-offset", "output-lag"), 1)
    dg = diagnose(rec, candidates=["backlash"], sindy=False)
    (c,) = dg.candidates
    assert c.success, c.message
    assert c.nrmse_after < dg.nrmse_heldout
