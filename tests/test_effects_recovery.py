"""Each catalogued effect, hidden at a known value in synthetic Table 2 data (rows 0.2-0.8 V, dt = 0.005 s,
1 % output noise, steady state: 1 s simulated before the record starts) is recovered by fitting the
extended model (collocation + IPOPT) from the base fit and the effect's data-based initial guess
(:func:`duffsym.identify.extended_start`), and the free-run NRMSE falls at least twofold, to the noise.

A_f is fixed at its true value: the scaling symmetry x -> s x leaves the base output unchanged but
rescales effects acting on the internal velocity x' (friction, asymmetry), so with A_f = max|y|
those would be recovered in rescaled units.

Lag, delay and shift are tested under a multisine up to 10 Hz: under one 2 Hz sine in steady state
the base parameters absorb most of a 10 ms lag or delay (measured for the lag: base NRMSE 0.0125,
extended 0.0096, noise 0.010), which is a fact about the data, not a failure of the fit.
"""

from __future__ import annotations

import numpy as np
import pytest

from duffsym import Sine, mr_damper
from duffsym.data import synthetic_record
from duffsym.data.record import Record
from duffsym.effects import CATALOGUE, apply_effects
from duffsym.excitation import Multisine
from duffsym.identify import Problem, extended_start, fit, fit_with_effects
from duffsym.model.presets import table2_params
from duffsym.simulate import simulate

M = mr_damper()
TRUTH = table2_params(0.4)
FIXED = {"A_f": TRUTH["A_f"]}
NOISE = 0.01
SINE = Sine(1.0, 2.0)
MULTISINE = Multisine((0.7, 0.25, 0.1), (1.0, 2.5, 5.0), (0.0, 1.0, 2.0))
FAST = Multisine((0.6, 0.3, 0.15), (1.0, 4.0, 10.0), (0.0, 1.0, 2.0))  # up to dt*f = 0.05

#: effect -> (Table 2 row (V), hidden parameter values, excitation). Rows differ from the model
#: defaults (the 0.4 V row) except for inertia, so no fit starts at the truth by accident.
CASES = {
    "force-offset": (0.8, {"off_y0": 0.3}, SINE),
    "gas-accumulator": (0.2, {"off_y0": 0.1, "gas_k": 0.2}, SINE),
    "inertia": (0.4, {"inertia_m": 0.002}, MULTISINE),
    "coulomb-friction": (0.6, {"fric_mu": 20.0}, SINE),
    "asymmetry": (0.8, {"asym_a": 0.15}, SINE),
    "output-lag": (0.2, {"lag_tau": 0.01}, FAST),  # one sine: base NRMSE only 0.0125 -> 0.0096
    "input-delay": (0.6, {"delay_tau": 0.01}, FAST),  # one 2 Hz sine absorbs it in the base parameters
    "input-shift": (0.2, {"shift_tau": 0.0025}, FAST),
    "backlash": (0.3, {"bl_h": 0.05}, SINE),
}


def base_then_extended(record, effect, fixed):
    """Base fit, then the extended fit from :func:`extended_start` (the base optimum + the effect's
    initial guess, or the base re-guessed on the effect-corrected record, whichever runs closer)."""
    base = fit(Problem(M, record, fixed=fixed))
    assert base.success, base.message
    ext_model = apply_effects(M, [effect])
    problem = Problem(ext_model, record, fixed=fixed)
    start = extended_start(ext_model, effect, record, base.params, base.y_sim[0], fixed=fixed)
    guess = effect.initial_guess(record, base.y_sim[0])
    return base, fit(problem, x0={k: start[k] for k in problem.free}), guess


def noise_nrmse(record) -> float:
    return record.metadata["noise_std"] / float(np.std(record.y))


@pytest.mark.parametrize("name", list(CASES))
def test_hidden_effect_is_recovered_and_the_error_halves(name):
    volt, values, exc = CASES[name]
    effect = CATALOGUE[name]
    truth = {**table2_params(volt), **values}
    fixed = {"A_f": truth["A_f"]}
    record = synthetic_record(
        apply_effects(M, [effect]),
        truth,
        exc,
        dt=0.005,
        duration=1.5 if exc is SINE else 2.0,
        noise=NOISE,
        rng=11,
        settle=1.0,
    )
    base, ext, guess = base_then_extended(record, effect, fixed)
    assert ext.success, ext.message
    for k, true in values.items():
        err = abs(ext.params[k] - true)
        # a few standard errors, or 3 % where the Laplace stderr is below the discretisation bias
        assert err <= max(4 * ext.stderr[k], 0.03 * abs(true)), (k, true, ext.params[k], ext.stderr[k], guess)
    assert ext.nrmse <= base.nrmse / 2, (base.nrmse, ext.nrmse)
    assert ext.nrmse <= 1.3 * noise_nrmse(record)  # down to the noise


@pytest.mark.slow
@pytest.mark.parametrize("h, tol", [(0.03, 0.25), (0.05, 0.1), (0.1, 0.1)])
def test_backlash_effect_explains_the_exact_play_of_the_rig(h, tol):
    """Data made with the exact play operator (synthetic_record(backlash=h), paper Fig. 8), fitted with
    the smooth catalogue form. Measured (seeds 2, 3): h = 0.02 -> 0.0161, 0.0140; 0.03 -> 0.0249, 0.0241;
    0.05 -> 0.0479, 0.0478; 0.1 -> 0.0971, 0.0973 (the smooth play's h underestimates a small exact
    gap); NRMSE 0.035-0.097 -> 0.010-0.014 (0.018 once at h = 0.02), noise level 0.010."""
    record = synthetic_record(M, TRUTH, SINE, dt=0.005, duration=1.5, noise=NOISE, backlash=h, rng=2)
    base, ext, _ = base_then_extended(record, CATALOGUE["backlash"], FIXED)
    assert ext.success and abs(ext.params["bl_h"] / h - 1) < tol
    assert ext.nrmse <= base.nrmse / 2 and ext.nrmse <= 1.5 * noise_nrmse(record)


@pytest.mark.slow
def test_gas_stiffness_and_inertia_separate_under_a_multisine():
    """Under one sine d'' = -w^2 d makes them one term; a multisine separates them."""
    effects = [CATALOGUE["gas-accumulator"], CATALOGUE["inertia"]]
    model = apply_effects(M, effects)
    values = {"off_y0": 0.1, "gas_k": 0.3, "inertia_m": 0.002}
    record = synthetic_record(model, {**TRUTH, **values}, MULTISINE, dt=0.005, duration=2.0, noise=NOISE, rng=5)
    base = fit(Problem(M, record, fixed=FIXED))
    problem = Problem(model, record, fixed=FIXED)
    x0 = {k: float(np.clip(v, *problem.bounds[k])) for k, v in base.params.items() if k in problem.free}
    for e in effects:
        x0.update(e.initial_guess(record, base.y_sim[0]))
    ext = fit(problem, x0=x0)  # base optimum + both guesses
    assert ext.success
    for k, true in values.items():
        assert abs(ext.params[k] - true) <= max(4 * ext.stderr[k], 0.03 * abs(true)), (k, ext.params[k])
    assert ext.nrmse <= 1.3 * noise_nrmse(record)


@pytest.mark.parametrize("name", ["input-shift", "input-delay"])
def test_a_held_input_is_found_as_half_a_sample_of_delay(name):
    """Data simulated with a zero-order hold of the sampled input; the fit interpolates linearly.
    Measured: base NRMSE 0.079; input-shift 0.0125 (2.70 ms), input-delay 0.0103 (2.81 ms)."""
    dt = 0.005
    t = np.arange(0.0, 2.0, dt)
    tr = simulate(M, TRUTH, t, {"d": FAST(t), "d_dot": FAST.derivative(t, 1)}, reconstruction="hold")
    y = tr.y + NOISE * np.std(tr.y) * np.random.default_rng(0).standard_normal(t.size)
    record = Record(t=t, d=FAST(t), d_dot=FAST.derivative(t, 1), y=y)
    base, ext, _ = base_then_extended(record, CATALOGUE[name], FIXED)
    tau = ext.params[f"{CATALOGUE[name].prefix}tau"]
    assert ext.success and tau == pytest.approx(dt / 2, rel=0.2)
    assert ext.nrmse <= base.nrmse / 5


def test_fit_with_effects_recovers_where_the_base_fit_failed():
    """Inertia hidden under a band-limited random input (0.2 V row): the base fit fails (NRMSE 0.29,
    c3 = 0); started from it the extended fit stays there (measured 0.29), while fit_with_effects'
    second start (the base re-guessed by the paper's procedure) reaches the noise."""
    from duffsym.excitation import BandLimitedRandom

    truth = {**table2_params(0.2), "inertia_m": 0.002}
    fixed = {"A_f": truth["A_f"]}
    effect = CATALOGUE["inertia"]
    model = apply_effects(M, [effect])
    record = synthetic_record(
        model,
        truth,
        BandLimitedRandom(rms=0.5, f_max=5.0, seed=3),
        dt=0.005,
        duration=2.0,
        noise=NOISE,
        rng=1,
        settle=1.0,
    )
    base = fit(Problem(M, record, fixed=fixed))
    assert base.nrmse > 0.2  # the failure this test is about
    ext = fit_with_effects(Problem(model, record, fixed=fixed), [effect], base.params, base.y_sim[0])
    assert ext.success and ext.settings["effect_start"] == 2
    assert abs(ext.params["inertia_m"] - 0.002) <= max(4 * ext.stderr["inertia_m"], 0.03 * 0.002)
    assert ext.nrmse <= 1.3 * noise_nrmse(record)


def test_the_second_start_of_fit_with_effects_is_bounded_by_the_converged_first(monkeypatch):
    """After a converged first start, the second runs under bounded_guard: here every iteration counts as slow
    (floor and factor 0), so it stops at once and the first is kept. On the Dyke record the unguarded second
    start of a discovered term took 366 s (iterations of 20-93 s at Hessian regularisation 1e10) after a first
    start of 7 s."""
    import duffsym.identify.extended as ext_mod
    from duffsym.identify import nlp as nlp_mod

    monkeypatch.setattr(nlp_mod, "RESTART_SLOW_FLOOR", 0.0)
    monkeypatch.setattr(nlp_mod, "RESTART_SLOW_FACTOR", 0.0)
    runs = []
    monkeypatch.setattr(ext_mod, "fit", lambda *a, **k: runs.append(fit(*a, **k)) or runs[-1])
    truth = {**table2_params(0.6), "off_y0": 0.2}
    fixed = {"A_f": truth["A_f"]}
    model = apply_effects(M, [CATALOGUE["force-offset"]])
    record = synthetic_record(model, truth, FAST, dt=0.005, duration=2.0, noise=NOISE, rng=4, settle=1.0)
    base = fit(Problem(M, record, fixed=fixed))
    got = fit_with_effects(Problem(model, record, fixed=fixed), [CATALOGUE["force-offset"]], base.params, base.y_sim[0])
    first, second = runs
    assert first.success and first.n_iter > 1
    assert not second.success and second.n_iter <= 1 and "an iteration took" in second.message
    assert got.settings["effect_start"] == 1 and got.params == first.params


@pytest.mark.parametrize("order", [("output-lag", "force-offset"), ("force-offset", "output-lag")])
def test_a_ladder_of_two_hidden_effects(order):
    """Offset and lag hidden together, added one at a time as a ladder does (each step started from the
    previous step's fit), in either order: the error falls at each step, to the noise, and both are
    recovered (measured NRMSE: 0.211 -> 0.135 -> 0.0102 lag first, 0.211 -> 0.180 -> 0.0102 offset first;
    off_y0 0.2009 +- 0.0006, lag_tau 0.01001 +- 0.00004)."""
    truth = {**table2_params(0.6), "off_y0": 0.2, "lag_tau": 0.01}
    fixed = {"A_f": truth["A_f"]}
    record = synthetic_record(
        apply_effects(M, [CATALOGUE[n] for n in order]),
        truth,
        FAST,
        dt=0.005,
        duration=2.0,
        noise=NOISE,
        rng=4,
        settle=1.0,
    )
    model, prev = M, fit(Problem(M, record, fixed=fixed))
    errors = [prev.nrmse]
    for name in order:
        model = apply_effects(model, [CATALOGUE[name]])
        prev = fit_with_effects(Problem(model, record, fixed=fixed), [CATALOGUE[name]], prev.params, prev.y_sim[0])
        assert prev.success
        errors.append(prev.nrmse)
    assert errors[0] > errors[1] > errors[2] and errors[2] <= 1.3 * noise_nrmse(record), errors
    for k in ("off_y0", "lag_tau"):
        assert abs(prev.params[k] - truth[k]) <= max(4 * prev.stderr[k], 0.03 * truth[k]), (k, prev.params[k])
