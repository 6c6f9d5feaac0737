"""The diagnosis on records made by the independent generator (tests/independent_sim.py, no duffsym
code): effects placed where the physics acts, pre-filtered and noise-free variants (issue 16)."""

import numpy as np
import pytest

import independent_sim as gen
from duffsym.data.record import Record
from duffsym.diagnose import diagnose
from duffsym.diagnose.residuals import has_noise_floor, noise_level
from duffsym.model.library import mr_damper


def record(effects, seed, **kw):
    g = gen.scenario(effects, seed, **kw)
    return Record(t=g.t, d=g.d, y=g.y, name=f"{effects}-{seed}", source="independent_sim"), g


@pytest.mark.parametrize("seed", [pytest.param(6, marks=pytest.mark.slow), 8])
def test_fitted_play_half_width_within_10_percent_of_the_exact_play(seed):
    rec, g = record("backlash", seed)  # exact play on the actuator path, 20 RK4 substeps per sample
    c = diagnose(rec, candidates=["backlash"], sindy=False).candidates[0]
    h = g.truth["physics"]["backlash"]
    assert c.success and abs(c.params["bl_h"] - h) < 0.10 * h  # measured 4.8 % (seed 6), 6.0 % (seed 8)


@pytest.mark.slow
@pytest.mark.claim  # README: the diagnosis names the hidden effect among several candidates on independent records
def test_piston_seal_friction_is_found_as_seal_friction_not_as_internal_friction():
    rec, g = record("seal-friction", 0)
    dg = diagnose(rec, candidates=["coulomb-friction", "seal-friction", "backlash"], sindy=False)
    assert dg.needed == ("seal-friction",)
    c = dg.best
    noise = g.noise_std / np.std(rec.y[dg.split["n_fit"] :])
    assert c.nrmse_after < 1.3 * noise and dg.nrmse_heldout > 2 * noise  # measured 0.0101, noise 0.0102, base 0.0218
    assert c.params["seal_F"] == pytest.approx(g.truth["physics"]["seal_friction"], rel=0.15)


def test_noise_estimate_on_raw_and_prefiltered_force():
    raw, g = record("clean", 0)
    assert has_noise_floor(raw.y, raw.dt)
    assert noise_level(raw.y) == pytest.approx(g.noise_std, rel=0.2)
    filt, gf = record("clean", 0, filter_kind="lowpass", filter_width=15.0)
    assert not has_noise_floor(filt.y, filt.dt)
    assert noise_level(filt.y) < 0.1 * gf.noise_std  # the third differences see a smooth signal, not the noise
    dg = diagnose(filt, candidates=["force-offset", "inertia"], sindy=False)
    assert dg.noise_method.startswith("held-out residual floor")
    assert "not measurable" in dg.verdict and "lowest held-out RMS of any fitted model" in dg.verdict
    assert "the measurement noise" not in dg.verdict
    # an upper bound of the noise left in the record, and no claim of a residual thousands of times the noise
    assert gf.noise_std <= dg.noise and dg.residuals.excess < 5


def test_noise_free_record_is_said_to_fit_exactly():
    rec, _ = record("clean", 1, noise=0.0)
    dg = diagnose(rec, candidates=["force-offset", "output-lag"], sindy=False)
    assert dg.verdict.startswith("The model fits the record exactly")
    assert dg.needed == ()


@pytest.mark.slow
@pytest.mark.claim  # the diagnosis adds no effect to a clean record (no false positive) on independent data
def test_clean_noisy_record_is_said_to_fit_to_the_noise_first():
    rec, g = record("clean", 0)
    dg = diagnose(rec, candidates=["force-offset", "output-lag", "seal-friction"], sindy=False)
    assert dg.verdict.startswith("The model fits to the noise")
    assert "third differences" in dg.verdict and dg.needed == ()


def test_base_fit_is_as_good_as_a_plain_fit_even_from_a_poor_start():
    rec, _ = record("clean", 2)
    poor = {**mr_damper().defaults(), "k2": 0.0, "c3": 1.0, "c1": 500.0}
    dg = diagnose(rec, candidates=["force-offset"], start=poor, sindy=False)
    check = dg.base_check
    assert check["as_good"] and check["nrmse_fit_part"] <= 1.05 * check["reference_nrmse_fit_part"]


def test_candidate_outside_the_stability_certificate_is_marked_and_not_needed():
    rec, _ = record("seal-friction", 0)  # measured: cubic damping fits with cdamp_c = -159 (energy-producing)
    dg = diagnose(rec, candidates=["cubic-damping"], sindy=False)
    c = dg.candidates[0]
    assert c.success and c.params["cdamp_c"] < 0
    assert c.stable is False and "cdamp_c" in c.stability and not c.needed
    assert "outside the stability certificate" in dg.summary()


@pytest.mark.slow
@pytest.mark.claim
def test_the_gas_accumulator_is_named_over_the_offset_it_contains_and_its_stiffness_recovered():
    # history: with the installs of 2026-11-26 the gas-accumulator fit from the base optimum + data guess converged
    # to a set whose free run diverged and force-offset ranked first; a second start from the base solution found
    # it (this test was then "the second start recovers ..." and asserted start == 2). With the install of
    # 2026-11-27 the first start converges when given the full budget (screen=None: start 1, held-out 0.01066
    # against the offset's 0.01155), and since a run merely unfinished at the screening budget is continued
    # instead of restarted (0420eca), the default path reaches the same fit from the first start too. What the
    # second start does is checked on constructed runs in test_diagnose_types.py.
    rec, g = record("gas-accumulator", 0)
    dg = diagnose(rec, candidates=["gas-accumulator", "force-offset"], sindy=False)
    c = dg.best
    assert c.effect == "gas-accumulator" and not c.diverged
    assert c.params["gas_k"] == pytest.approx(g.truth["physics"]["gas_stiffness"], rel=0.2)  # measured 4 %


def test_nested_simpler_effects_come_from_the_parameters():
    from duffsym.diagnose.ladder import _nested

    assert _nested("gas-accumulator", ()) == ["force-offset"]  # off_y0 + gas_k contains off_y0
    assert _nested("gas-accumulator", ("gas-accumulator", "force-offset")) == []
    assert _nested("output-lag", ()) == [] and _nested("not-an-effect", ()) == []


@pytest.mark.slow
@pytest.mark.claim
def test_a_candidate_stopped_half_way_is_not_ranked_against_converged_ones():
    # measured before: on the offset + lag record, with the offset taken (as gas-accumulator), output-lag was
    # still being fitted after the 30 screening iterations, ranked 10 of 11 behind converged candidates and was
    # screened out, so the ladder stopped 2.2x above the noise; continued, it converges to the true lag.
    # Failed on main d580dd2 .. 3434698 (nothing needed); passes since the lag's time constant is bounded by the
    # sampling (lag_tau >= dt/12 = 4.2e-4 s here, not 1e-4: duffsym.identify.problem.sampling_bounds); with that
    # bound lifted the same run still needs nothing (lag_tau 0.0087 fitted but not supported)
    from duffsym.effects import CATALOGUE, apply_effects

    rec, g = record(("force-offset", "output-lag"), 0)
    model = apply_effects(mr_damper(), [CATALOGUE["gas-accumulator"]])
    dg = diagnose(rec, model, sindy=False)
    assert dg.needed == ("output-lag",)
    assert dg.best.params["lag_tau"] == pytest.approx(g.truth["physics"]["lag"], rel=0.1)  # measured 0.0093 / 0.0093


@pytest.mark.slow
@pytest.mark.claim  # the ladder names two hidden effects among the whole catalogue on an independent record
def test_ladder_finds_offset_and_lag_by_their_names():
    # measured before (3 seeds): the ladder ended with gas-accumulator (+ output-lag) in 3/3, the lag screened
    # out in 1/3; now seed 1 ends with exactly force-offset + output-lag at the noise (end / noise 1.0)
    from duffsym.diagnose import ladder

    rec, g = record(("force-offset", "output-lag"), 1)
    lad = ladder(rec, sindy=False)
    assert set(lad.effects) == {"force-offset", "output-lag"}
    k = lad.steps[-1].diagnosis.split["n_fit"]
    assert lad.steps[-1].nrmse_heldout < 1.5 * g.noise_std / np.std(rec.y[k:])


def test_noise_estimate_is_tightened_by_the_fitted_residual_where_the_force_has_sharp_corners():
    # Stribeck friction: a static peak at every reversal, whose sharp corners the force's own third differences
    # count as noise (1.37x the true noise on this record); the base model's free run takes most of them out
    rec, g = record(("stribeck-friction",), 4)
    own = noise_level(rec.y)
    assert own > 1.3 * g.noise_std
    dg = diagnose(rec, candidates=["force-offset"], sindy=False)
    assert dg.noise < own and dg.noise == pytest.approx(g.noise_std, rel=0.3)  # measured 1.27x
    assert "tightened by the third differences of" in dg.noise_method
    assert f"from {dg.noise_method}" in dg.verdict  # whole: the verdict cuts a method at its first colon
    given = diagnose(rec, candidates=["force-offset"], sindy=False, noise=own)
    assert given.noise == own and given.noise_method == "given"
