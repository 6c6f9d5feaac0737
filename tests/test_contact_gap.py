"""The contact gap (a linkage play in series with the element; issue 22, item 3): its smooth deadzone against the
exact one, when the diagnosis tries it, and its fit on records of the independent friction-play generator
(``tests/independent_friction_sim.py``, numpy only) and on the real friction damper."""

import math

import numpy as np
import pytest
import sympy as sp

import independent_friction_sim as fgen
import independent_sim as gen
from _external import BRFD, BRFD_RECORDS, external_file
from duffsym.data.record import Record
from duffsym.effects import CATALOGUE, apply_effects
from duffsym.effects.gap import smooth_deadzone
from duffsym.model.library import mr_damper


def exact_deadzone(y, w):
    return np.sign(y) * np.maximum(np.abs(y) - w, 0.0)


def friction_play_record(seed=0, **kw):
    t, a, y, yc = fgen.generate(seed=seed, **kw)
    return Record(t=t, d=a, y=y, name=f"friction-play-{seed}", source="independent_friction_sim"), yc


def test_smooth_deadzone_is_within_half_its_corner_of_the_exact_one_and_monotone():
    w, delta = 1.3, 0.26
    y = np.linspace(-6, 6, 4001)
    z = smooth_deadzone(y, w, delta)
    err = np.abs(z - exact_deadzone(y, w))
    assert err.max() <= delta / 2 + 1e-12  # largest at the corners |y| = w: (delta - (sqrt(4w^2+delta^2) - 2w))/2
    far = np.abs(np.abs(y) - w) > 1.0
    assert err[far].max() < delta**2 / 4  # away from the corners it is the exact deadzone to second order
    slope = np.diff(z) / np.diff(y)
    assert slope.min() >= 0 and slope.max() <= 1 + 1e-9 and np.allclose(z, -smooth_deadzone(-y, w, delta))
    assert slope[np.abs(y[1:]) < 0.05].max() < 0.03  # flat in the gap: delta^2 / (2 w^2) = 0.02


def test_contact_gap_replaces_the_output_by_the_deadzone_of_the_element_force():
    m = apply_effects(mr_damper(), [CATALOGUE["contact-gap"]])
    assert m.param_names[-1] == "gap_w" and m.rhs == mr_damper().rhs  # the state equations are untouched
    f = sp.lambdify([m.param("A_f").symbol, sp.Symbol("x2", real=True), m.param("gap_w").symbol], m.output)
    ye = np.linspace(-4, 4, 9)
    w = 1.1  # the output at A_f x2 = ye, written out here: y + (sqrt((y-w)^2 + (w/5)^2) - sqrt((y+w)^2 + (w/5)^2))/2
    want = ye + (np.sqrt((ye - w) ** 2 + (w / 5) ** 2) - np.sqrt((ye + w) ** 2 + (w / 5) ** 2)) / 2
    assert np.allclose([f(2.0, v / 2.0, w) for v in ye], want, rtol=1e-12)


def test_the_diagnosis_tries_the_gap_only_where_zero_force_plateaus_are():
    gap = CATALOGUE["contact-gap"]
    rec, _ = friction_play_record()
    assert gap.relevance(rec) == ""
    g = gen.scenario("clean", 0)  # an MR damper without play: the force crosses zero as soon as d turns
    clean = Record(t=g.t, d=g.d, y=g.y, name="clean", source="independent_sim")
    assert "no zero-force plateau" in gap.relevance(clean)
    from duffsym.diagnose.search import _candidate_names

    said = []
    names = _candidate_names(None, mr_damper(), clean, said.append)
    assert "contact-gap" not in names and "backlash" in names and any("contact-gap: not tried" in s for s in said)
    assert "contact-gap" in _candidate_names(["contact-gap"], mr_damper(), clean)  # named: always tried


@pytest.fixture(scope="module")
def friction_play_diagnosis():
    from duffsym.diagnose import diagnose
    from duffsym.model.library import get_model

    rec, _ = friction_play_record(seed=0)  # true half-width 0.1 in, Jenkins element k = 30, F_c = 2.2, 1 % noise
    return rec, diagnose(rec, get_model("mr-damper-path"), candidates=["backlash", "contact-gap"], sindy=False)


@pytest.mark.slow
@pytest.mark.ci
def test_contact_gap_on_the_rate_independent_element_fits_an_independent_friction_damper_with_play(
    friction_play_diagnosis,
):
    from duffsym.diagnose.verdict import play_half_width

    rec, dg = friction_play_diagnosis
    c = next(c for c in dg.candidates if c.effect == "contact-gap")
    assert c.success, c.message
    h, se = play_half_width(c, rec, dg.y_candidates["contact-gap"])
    # measured: h = 0.104 +- 0.013; held-out 0.144 -> 0.034 (noise 0.010: the smooth element's corner against the
    # Jenkins element's sharp one)
    assert h == pytest.approx(fgen.FrictionPlay().h, rel=0.10) and math.isfinite(se) and se < 0.2 * h
    assert c.nrmse_after < 0.35 * dg.nrmse_heldout and c.nrmse_after < 5 * 0.01
    assert set(dg.needed) & {"contact-gap", "backlash"}  # a play is named


@pytest.mark.slow
@pytest.mark.ci
def test_the_diagnosis_names_the_gap_and_its_true_half_width_on_an_independent_friction_damper_with_play(
    friction_play_diagnosis,
):
    from duffsym.diagnose.verdict import play_half_width, play_sentence

    # measured: the gap named, h = 0.104 +- 0.014, held-out 0.144 -> 0.034; the input play (backlash) stays at 0.147.
    # Which of the two is named rests on the backlash fit's path, not on the ranking: with IPOPT's own initial
    # barrier parameter (0.1, before nlp.MU_INIT) backlash reached held-out 0.0282 with h = 0.136 +- 0.0003 and was
    # named (this test was a strict xfail then); the ranking still does not weigh the zero-force plateau.
    rec, dg = friction_play_diagnosis
    assert dg.needed == ("contact-gap",)
    c = next(c for c in dg.candidates if c.effect == "contact-gap")
    h, se = play_half_width(c, rec, dg.y_candidates["contact-gap"])
    assert f"h = {h:.3g} ± {se:.2g}" in dg.verdict and "mr-damper-path" not in dg.verdict
    advice = play_sentence(dg.candidates, rec, dg.y_candidates, rate_independent=False)
    assert "try the rate-independent element too (`--model mr-damper-path`)" in advice  # said on mr-damper


@pytest.mark.slow
@pytest.mark.parametrize(
    "name",
    BRFD_RECORDS,
)
def test_contact_gap_names_and_fits_the_play_of_the_real_friction_damper(name):
    from duffsym.data.loaders import load_friction_damper_json
    from duffsym.diagnose import diagnose
    from duffsym.diagnose.verdict import play_half_width
    from duffsym.effects.inputs import plateau_half_width
    from duffsym.model.library import get_model

    rec = load_friction_damper_json(external_file(BRFD, f"{name}.json"))
    dg = diagnose(rec, get_model("mr-damper-path"), candidates=["backlash", "contact-gap"], sindy=False)
    c = next(c for c in dg.candidates if c.effect == "contact-gap")
    assert c.success, c.message
    assert dg.needed == ("contact-gap",)
    h, se = play_half_width(c, rec, dg.y_candidates["contact-gap"])
    # measured (h / plateau; held-out before -> after): 0.95, 0.180 -> 0.082; 0.79, 0.197 -> 0.147;
    # 0.94, 0.300 -> 0.117; 0.89, 0.184 -> 0.096; standard errors 3-7 % of h
    assert 0.7 < h / plateau_half_width(rec) < 1.1 and se < 0.1 * h
    assert c.nrmse_after < 0.8 * dg.nrmse_heldout


@pytest.mark.slow
@pytest.mark.ci
def test_the_ladder_switches_to_the_rate_independent_element_when_a_contact_gap_is_found():
    from duffsym.diagnose import ladder

    rec, _ = friction_play_record(seed=1, second=0.15)  # a third harmonic: no two cycles alike
    lad = ladder(rec, candidates=["backlash", "contact-gap"], discover=False, budget=None)
    first, last = lad.steps[0], lad.steps[-1]
    assert first.model == "mr-damper" and last.model == "mr-damper-path" and last.effects == ("contact-gap",)
    assert "replaced by its rate-independent form mr-damper-path" in last.element
    # measured: held-out 0.129 (mr-damper) -> 0.028 (mr-damper-path + contact-gap; noise 0.010)
    assert last.nrmse_heldout < 0.35 * first.nrmse_heldout and last.nrmse_heldout < 5 * 0.01
    assert "mr-damper-path + contact-gap" in lad.summary() and lad.to_dict()["steps"][-1]["model"] == "mr-damper-path"
