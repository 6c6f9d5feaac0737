"""Physics outside the catalogue (issue 22), on records of the independent generator (tests/independent_sim.py,
numpy only): the generator's new effects act where they are placed; discovery names a Stribeck friction
and a stroke-dependent friction; a heating record is seen to drift, and the parameter that drifts follows
the dissipated energy; the verdict sentences that propose discovery and that name the drift."""

import numpy as np
import pytest
import sympy as sp

import independent_sim as gen
from duffsym.data.record import Record
from duffsym.diagnose import diagnose
from duffsym.diagnose.discover import alias_groups, derivative_order, discover_term, library_matrix, without_base
from duffsym.effects import CATALOGUE, apply_effects
from duffsym.effects.discovered import resembles
from duffsym.effects.drift import ParameterDrift, from_name
from duffsym.model.library import mr_damper
from duffsym.model.symbols import state_symbol


def _record(effect, seed, **kw):
    g = gen.scenario(effect, seed, **kw)
    return Record(t=g.t, d=g.d, y=g.y, name=f"{effect}-{seed}", source="independent_sim"), g


def _floor(rec, g, dg):
    return g.noise_std / float(np.std(np.asarray(rec.y)[dg.split["n_fit"] :]))


# ---------------------------------------------------------------------------------------------- generator
def test_outside_forces_add_to_the_measured_force_exactly_as_written():
    """Without a load-cell lag the piston forces add to the fluid force: the difference between a record
    with Stribeck friction + orifice + gas spring and one without is the written formula of the piston motion."""
    p, inp = gen.table2(0.4), gen.SumOfSines((1.0,), (2.0,), (0.0,))
    t = 0.005 * np.arange(201)
    ph = gen.Physics(
        stribeck_coulomb=0.05,
        stribeck_static=0.15,
        stribeck_velocity=0.5,
        orifice=0.002,
        gas_spring=0.1,
        gas_spring_length=1.5,
    )
    y1, ex = gen.simulate_device(p, ph, inp, t)
    y0, _ = gen.simulate_device(p, gen.Physics(), inp, t)
    v, d = inp(t, 1), inp(t)
    eps = 0.01 * float(np.max(np.abs(inp(0.005 * 0.5 * np.arange(401 * 20), 1))))
    want = (
        (0.05 + 0.10 * np.exp(-((v / 0.5) ** 2))) * np.tanh(v / eps)
        + 0.002 * v * np.abs(v)
        + 0.1 * ((1.5 / (1.5 - d)) ** 1.4 - 1)
    )
    assert np.max(np.abs((y1 - y0) - want)) < 1e-3 * np.max(np.abs(y0))


def test_heating_lowers_the_damping_as_the_dissipated_energy_grows():
    g = gen.scenario("heating", 1, duration=2.0)
    theta = g.extra["temperature"]
    # E_ref is the clean device's dissipated energy over the record: the temperature ends near 1, rising
    # (the stored elastic energy returns within a cycle: small dips only)
    assert theta[0] == 0 and 0.8 < theta[-1] < 1.3 and 0.3 < theta[theta.size // 2] / theta[-1] < 0.7
    assert np.min(np.diff(theta)) > -0.01 * theta[-1]
    clean = gen.scenario("clean", 1, duration=2.0)
    assert g.truth["physics"]["heating"] > 0.29 and clean.truth["physics"]["heating"] == 0


# ---------------------------------------------------------------------------------------------- library
def test_library_is_the_tensor_product_of_polynomials_and_switches():
    t = np.linspace(0, 2, 401)
    cols = {"d": np.sin(2 * np.pi * t), "d_dot": 2 * np.pi * np.cos(2 * np.pi * t), "x": 0.1 * np.sin(6 * t)}
    terms, Theta = library_matrix(cols)
    d, v = state_symbol("d"), state_symbol("d_dot")
    text = [sp.sstr(x) for x in terms]
    assert any(x.startswith("d**2*tanh(") and "d_dot" in x for x in text)  # friction growing to the stroke ends
    assert any("exp(-" in x and "d_dot**2" in x for x in text)  # Stribeck shapes
    assert d**3 in terms and d * v in terms and Theta.shape == (t.size, len(terms))
    stribeck = next(x for x in terms if x.has(sp.exp) and x.free_symbols == {v})
    assert "Stribeck" in resembles(stribeck)
    stroke = next(x for x in terms if x.has(sp.tanh) and sp.degree(x.as_independent(v)[0], d) == 2)
    assert "stroke" in resembles(stroke)


def test_drift_effect_is_rebuilt_from_its_name_and_substitutes_the_parameter():
    eff = ParameterDrift("c3", "energy", 20.43)
    back = from_name(eff.name)
    assert back == eff and eff.name == "drift: c3·(1 - a·E/20.4)"
    m = eff.apply(mr_damper())
    assert "drift_a" in m.param_names and [c.name for c in m.inputs][-1] == "energy"
    assert m.rhs[m.states.index(m.velocity)].has(state_symbol("energy"))
    rec, _ = _record("clean", 0, duration=1.0)
    e = rec.drift_signal("energy")
    assert e[0] == 0 and e[-1] > 0 and np.all(np.isfinite(e))
    assert rec.drift_signal("time")[-1] == pytest.approx(1.0)


# ---------------------------------------------------------------------------------------------- discovery
@pytest.mark.slow
@pytest.mark.ci
def test_stribeck_friction_is_discovered_and_named():
    """Stribeck friction on the piston (static peak 2.5-4x the kinetic level, decaying with speed), from
    the base model: the sentence proposing discovery; a Stribeck-shaped term in d' is stable and needed,
    named as Stribeck friction, and the held-out error ends within 2x the noise
    (measured: 0.046 -> 0.018, noise 0.0097)."""
    rec, g = _record("stribeck-friction", 1)
    dg = diagnose(rec, candidates=[], sindy=False)
    assert "looks for a term by sparse regression" in dg.verdict
    disc = discover_term(rec, mr_damper(), dg)
    assert disc.needed and "exp(-(d'/" in disc.effect and "tanh(d'/" in disc.effect, disc.summary()
    assert any("Stribeck" in r for r in disc.resembles)
    assert disc.nrmse_after <= 2 * _floor(rec, g, dg) < 0.5 * disc.nrmse_before


def test_discovery_makes_no_fit_once_its_deadline_has_passed():
    import time

    rec, _ = _record("stribeck-friction", 1)  # the record whose Stribeck term is discovered without a deadline
    dg = diagnose(rec, candidates=[], sindy=False)
    disc = discover_term(rec, mr_damper(), dg, deadline=time.monotonic() - 1.0)
    assert not disc.found and "not made: the time budget ran out" in disc.message, disc.message


@pytest.mark.slow
def test_stroke_dependent_friction_is_discovered_on_top_of_seal_friction():
    """Seal friction already in the model (the ladder adds it first): the level that grows toward the stroke
    ends is found as d²·tanh(d'/ε) (measured: 0.065 -> 0.0100, noise 0.0098)."""
    rec, g = _record("stroke-friction", 2)
    model = apply_effects(mr_damper(), [CATALOGUE["seal-friction"]])
    dg = diagnose(rec, model, candidates=[], sindy=False)
    disc = discover_term(rec, model, dg)
    assert disc.needed and "d^2·tanh(d'/" in disc.effect, disc.summary()
    assert any("stroke" in r for r in disc.resembles)
    assert disc.nrmse_after <= 1.5 * _floor(rec, g, dg)


def test_the_base_models_own_refit_is_projected_out_of_the_selection():
    """Frisch-Waugh-Lovell, checked by hand: with the base's sensitivities J = [a, b], a library column 2a - 3b is
    absorbed (left out), a column c orthogonal to J is unchanged, and a residual a + c becomes c."""
    from duffsym.diagnose.discover import without_base

    rng = np.random.default_rng(3)
    a, b, c = rng.standard_normal((3, 400))
    c -= np.column_stack([a, b]) @ np.linalg.lstsq(np.column_stack([a, b]), c, rcond=None)[0]
    Theta = np.column_stack([2 * a - 3 * b, c, a + c])
    Tp, rp, absorbed = without_base(np.column_stack([a, b]), Theta, a + c)
    assert absorbed == {0}
    np.testing.assert_allclose(Tp[:, 1], c, atol=1e-12)
    np.testing.assert_allclose(Tp[:, 2], c, atol=1e-12)
    np.testing.assert_allclose(rp, c, atol=1e-12)


def test_a_term_the_base_mimics_does_not_hide_the_stroke_dependent_friction():
    """Stroke-dependent friction (multisine, seed 1), seal friction already in the model: in the raw residual a
    viscous d' (which the base's own c1 absorbs on refitting) was the stable family and d²·tanh(d'/ε) missed the
    inclusion threshold (0.55), so the ladder stopped at 3.5x the noise. With the base's linearised refit
    projected out, d²·tanh(d'/ε) is found, with the generator's coefficient F0·g/L² = 0.0842 within 10 %
    (measured: 0.0887 ± 0.0010, held-out 0.035 -> 0.011, noise 0.010)."""
    rec, g = _record("stroke-friction", 1)
    model = apply_effects(mr_damper(), [CATALOGUE["seal-friction"]])
    dg = diagnose(rec, model, candidates=[], sindy=False)
    disc = discover_term(rec, model, dg)
    assert disc.needed and "d^2·tanh(d'/" in disc.effect, disc.summary()
    assert "projected out" in disc.selection["base_refit"]
    phys = g.truth["physics"]
    truth = phys["stroke_friction"] * phys["stroke_friction_growth"] / phys["stroke_length"] ** 2
    (coef,) = disc.params.values()
    assert abs(coef / truth - 1) < 0.10, (coef, truth)
    assert disc.nrmse_after <= 1.5 * _floor(rec, g, dg)


def test_heating_is_found_as_a_damping_that_follows_the_dissipated_energy():
    """Heating (c2, c3 fall with a temperature driven by the dissipated power): the diagnosis says the error
    grows and proposes the drift search; windowed refits show c3 falling; c3 following the dissipated energy
    is needed and ends within 2x the noise, and one sentence says so
    (measured: 0.042 -> 0.0125, noise 0.0095; c3 falls by 24 % over the fitting part)."""
    rec, g = _record("heating", 1)
    dg = diagnose(rec, candidates=[], sindy=False)
    assert "grows over the record" in dg.verdict and "drifts" in dg.verdict
    disc = discover_term(rec, mr_damper(), dg)
    assert disc.effect.startswith("drift: c3·(1 - a·E/"), disc.summary()
    windows = disc.selection["windows"]
    assert "c3" in windows["drifting"] and windows["change"]["c3"] < -0.1
    assert disc.needed and disc.nrmse_after <= 2 * _floor(rec, g, dg) < 0.5 * disc.nrmse_before
    assert 0.1 < disc.params["drift_a"] < 0.6
    assert disc.words.startswith("c3 falls by ") and "energy dissipated" in disc.words


def test_heating_on_a_sine_is_found_when_the_windowed_refits_trade_parameters_off():
    """Heating on a 4-cycle sine (seed 9): the three windowed refits move k1 and k2 by 70-80 % and c3 by -13 %
    but no parameter monotonically (once the end: "no parameter changes monotonically", 5.3x the noise). The
    linearised drift of each parameter ranks c3 first; c3 following the dissipated energy is needed and ends
    within 2x the noise (measured: the ladder's end 5.28 -> 1.12x the noise, c3 falls by 27 %)."""
    rec, g = _record("heating", 9)
    assert g.truth["kind"] == "sine"
    dg = diagnose(rec, candidates=[], sindy=False)
    disc = discover_term(rec, mr_damper(), dg)
    windows = disc.selection["windows"]
    assert not windows["drifting"] and abs(windows["change"]["k1"]) > abs(windows["change"]["c3"]), windows
    assert disc.selection["ranked_by_linearised_drift"][0] == "c3", disc.selection
    assert disc.effect.startswith("drift: c3·(1 - a·E/"), disc.summary()
    assert disc.needed and disc.nrmse_after <= 2 * _floor(rec, g, dg) < 0.5 * disc.nrmse_before
    assert 0.1 < disc.params["drift_a"] < 0.6


def test_heating_under_a_moving_average_is_found_when_the_windows_name_other_parameters():
    """Heating on a sine whose force went through a 5-sample moving average (seed 0): the two windowed refits of the
    restored force move c1 by +7 % and k1 by -14 %, c3 by -4.8 % (under the 5 % a drift needs), so the windows name
    c1, k1, k2; on f8970c6 c1 following time was taken (held-out 0.048 -> 0.024, the ladder ended 3.4x the
    noise). The linearised drift ranks c3 first and is tried beside them: c3 following the dissipated energy
    ends at 0.0067."""
    rec, g = _record("heating", 0, filter_kind="movavg", filter_width=5)
    assert g.truth["kind"] == "sine"
    dg = diagnose(rec, candidates=[], sindy=False)
    disc = discover_term(rec, mr_damper(), dg)
    windows = disc.selection["windows"]
    assert "c3" not in windows["drifting"], windows
    assert disc.selection["ranked_by_linearised_drift"] == ["c3"], disc.selection
    assert disc.effect.startswith("drift: c3·(1 - a·E/"), disc.summary()
    assert disc.needed and disc.nrmse_after <= 2 * _floor(rec, g, dg) < 0.5 * disc.nrmse_before


def test_windowed_changes_are_ranked_by_their_standard_errors():
    """The two windowed refits of a heating sine under a moving average (seed 3, measured): c2 +11 % with a
    standard error of 14 % of its value, c3 -6.7 % with 3.6 %. By the relative change c3 came fourth, behind
    k1, k2 and c2, and was not tried (c2 following time ended 7.2x the noise); by significance it is second."""
    from duffsym.diagnose.drift import Windows

    params = {"c1": [10.38, 11.62], "c2": [6.618, 7.416], "c3": [173.3, 162.0]}
    params |= {"k1": [36.53, 28.76], "k2": [431.9, 340.4]}
    stderr = {"c1": [0.238, 0.535], "c2": [0.820, 1.076], "c3": [3.03, 5.31], "k1": [3.82, 6.96], "k2": [37.6, 71.1]}
    change = {n: (v[1] - v[0]) / float(np.mean(np.abs(v))) for n, v in params.items()}
    w = Windows([(0, 300), (300, 600)], params, stderr, change, dict.fromkeys(params, True))
    assert w.significance("c3") == pytest.approx(11.3 / np.hypot(3.03, 5.31))
    assert w.drifting()[:3] == ["c1", "c3", "k2"]
    assert sorted(change, key=lambda n: -abs(change[n]))[:3] == ["k1", "k2", "c2"]  # the old order


def test_forms_of_one_column_are_one_group_and_the_simplest_form_stands_for_it():
    """On a sine d = sin(ωt): d² = 1 - d'²/ω² and d·d'' = -ω²·d², so once a constant is projected out the three
    columns are one (cosine ±1) and are grouped; d³ and d are not (cosine 0 against d² on a full period)."""
    d, dd, ddd = sp.symbols("d d_dot d_ddot")
    t = np.linspace(0, 4 * np.pi, 2001)[:-1]
    w = 3.0
    x, v, a = np.sin(w * t), w * np.cos(w * t), -(w**2) * np.sin(w * t)
    terms = [d**2, dd**2, d * ddd, d**3, d]
    cols = np.column_stack([x**2, v**2, x * a, x**3, x])
    Tp, _, _ = without_base(np.ones((t.size, 1)), cols, np.zeros(t.size))
    groups = alias_groups(terms, Tp)
    assert groups[0] == groups[1] == groups[2] and len({groups[0], groups[3], groups[4]}) == 3, groups
    assert [derivative_order(tm) for tm in terms] == [0, 2, 2, 0, 0]


def test_a_gas_spring_on_a_sine_is_named_by_its_simplest_form_with_the_forms_it_cannot_be_told_from():
    """A polytropic gas spring on a sine (seed 9), the offset already in the model: d² and d'² are one column
    there, and the stability selection split between them (inclusion 0.425 and 0.525, neither stable: "no term
    found" at 1.7x the noise). Grouped, the column is stable (0.95); d² is fitted, named with the forms it
    cannot be told from, and ends at the noise (measured: the ladder's end 1.69 -> 0.97x the noise)."""
    rec, g = _record("gas-spring", 9)
    assert g.truth["kind"] == "sine"
    model = apply_effects(mr_damper(), [CATALOGUE["force-offset"]])
    dg = diagnose(rec, model=model, candidates=[], sindy=False)
    disc = discover_term(rec, model, dg)
    assert disc.effect.endswith("·d^2 on the output"), disc.summary()
    assert disc.selection["aliases"]["d**2"] == ["d'^2", "d·d''", "d''^2"], disc.selection
    assert "the same column as d'^2" in disc.words and disc.needed
    assert disc.nrmse_after <= 1.5 * _floor(rec, g, dg)


def test_no_stable_term_in_the_residual_of_a_clean_record():
    """A clean record (the base model is the generator's device): the residual is noise, no family of terms is
    selected in 60 % of the resampled cycles, nothing is fitted, and the message says so."""
    rec, _ = _record("clean", 2, duration=3.0)
    dg = diagnose(rec, candidates=[], sindy=False)
    disc = discover_term(rec, mr_damper(), dg)
    assert not disc.found and "no term is stable over resampled cycles" in disc.message, disc.message
    assert all(p < 0.6 for p in disc.selection["inclusion"].values())


def test_stribeck_friction_is_discovered_where_the_residual_is_called_white_at_the_noise():
    """Seal friction already in the model: its residual is white and 1.25-1.5x the (tightened) noise, which the
    verdict calls the noise level; the search still runs there and finds the static peak, exp(-(d'/v_s)²)·tanh
    (measured: the ladder ended at 1.5x the true noise with seal friction alone, now at 1.1x)."""
    rec, g = _record("stribeck-friction", 5)
    model = apply_effects(mr_damper(), [CATALOGUE["seal-friction"]])
    dg = diagnose(rec, model, candidates=[], sindy=False)
    assert dg.residuals.at_noise_level and dg.residuals.worth_a_search, dg.residuals.excess
    disc = discover_term(rec, model, dg)
    assert disc.needed and "exp(-(d'/" in disc.effect, disc.summary()
    assert disc.nrmse_after <= 1.3 * _floor(rec, g, dg)


def test_the_held_out_fall_required_near_the_noise_is_half_of_what_the_noise_leaves():
    """10 % of the held-out RMSE, or half the fall the noise leaves possible when that is less."""
    from duffsym.diagnose.options import required_improvement

    assert required_improvement(0.10, 1.1**2, 1.0) == pytest.approx(0.5 * (1 - 1 / 1.1))
    assert required_improvement(0.10, 1.5**2, 1.0) == 0.10  # half of 1/3
    assert required_improvement(0.10, 1.1**2, 1.0, measurable=False) == 0.10  # a floor: the fixed rule
    assert required_improvement(0.10, 0.9**2, 1.0) == 0.0  # below the noise: nothing to fall
    assert required_improvement(0.10, 4.0, 0.0) == 0.10  # no noise measured: the fixed rule


def test_stroke_dependent_friction_is_needed_when_the_model_is_near_the_noise():
    """Seal friction and parallel damping in the model, held-out 1.16x the true noise, the residual not white: the
    stable term d²·d'²·tanh removes ~80 % of the excess error (ΔBIC -71) with a held-out fall of ~9 %, the most
    possible there; the fixed 10 % rule refused it (measured: the ladder ended at 1.16x the noise)."""
    rec, g = _record("stroke-friction", 9)
    model = apply_effects(mr_damper(), [CATALOGUE["seal-friction"], CATALOGUE["parallel-damping"]])
    dg = diagnose(rec, model, candidates=[], sindy=False)
    assert not dg.residuals.white and dg.nrmse_heldout > 1.1 * _floor(rec, g, dg)
    disc = discover_term(rec, model, dg)
    assert disc.needed and disc.improvement < 0.10 and disc.explained > 0.6, disc.summary()
    assert "d^2" in disc.effect and "tanh(d'/" in disc.effect, disc.effect
    assert disc.nrmse_after <= 1.08 * _floor(rec, g, dg)


def test_a_term_below_the_stability_threshold_is_fitted_when_no_stable_set_is_needed():
    """A turbulent orifice force C·d'|d'| with parallel damping in the model (held-out 1.12x the true noise, the
    residual not white): no family reaches 60 % inclusion, the most included (~0.48) is fitted and removes most
    of the excess error; its words say it was below the threshold (measured: the ladder ended with no term)."""
    rec, g = _record("orifice", 0)
    model = apply_effects(mr_damper(), [CATALOGUE["parallel-damping"]])
    dg = diagnose(rec, model, candidates=[], sindy=False)
    disc = discover_term(rec, model, dg)
    assert disc.needed, disc.summary()
    assert "below the stability threshold" in disc.words and "d'" in disc.effect, disc.words
    assert disc.nrmse_after <= 1.06 * _floor(rec, g, dg) < dg.nrmse_heldout


def test_a_term_in_the_models_state_is_written_in_the_measured_motion():
    """measured_form replaces x, x' in a term's polynomial factor by d, d' (coefficients by least squares on the
    base's residual); a state inside a switching function (its ε is on the state's scale) is left alone."""
    from types import SimpleNamespace

    from duffsym.diagnose.discover import measured_form
    from duffsym.effects.discovered import DiscoveredEffect

    d_, x_, v_, xv_ = (sp.Symbol(n, real=True) for n in ("d", "x", "d_dot", "x_dot"))
    t = np.linspace(0, 2, 401)
    rec = Record(t=t, d=np.sin(2 * np.pi * t), y=0.3 * np.sin(2 * np.pi * t) ** 3, name="sine", source="test")
    dg = SimpleNamespace(split={"n_fit": 300}, y_base=np.zeros(t.size), measured=lambda r: np.asarray(r.y))
    dg.judged = lambda y: np.asarray(y, dtype=float)  # no moving average, no band
    got = measured_form(DiscoveredEffect((d_**2 * x_,), (1.0,)), rec, dg)
    assert got.terms == (d_**3,) and got.coefs[0] == pytest.approx(0.3, rel=1e-9)
    merged = measured_form(DiscoveredEffect((d_ * x_, d_**2), (1.0, 1.0)), rec, dg)
    assert merged.terms == (d_**2,)  # d·x and d² are one term in the measured motion
    assert measured_form(DiscoveredEffect((xv_ * sp.tanh(xv_ / 0.08),), (1.0,)), rec, dg) is None
    assert measured_form(DiscoveredEffect((d_**2 * sp.tanh(v_ / 0.3),), (1.0,)), rec, dg) is None  # nothing to write
    cmd = sp.Symbol("command", real=True)
    assert measured_form(DiscoveredEffect((cmd * x_,), (1.0,)), rec, dg) is None  # a command has no form in d here


@pytest.mark.slow
@pytest.mark.ci
def test_stroke_dependent_friction_is_named_in_the_measured_motion():
    """Independent stroke-friction record, seed 6: the selection's d·x·tanh(d'/ε) (the model's state x) and the
    measured d²·tanh(d'/ε) fit within ΔBIC 3.1 (held-out 0.01136 against 0.01111): the measured form, the
    physics' own, is named (before: d·x·tanh)."""
    rec, g = _record("stroke-friction", 6)
    dg = diagnose(rec, candidates=[], sindy=False)
    disc = discover_term(rec, mr_damper(), dg)
    assert disc.needed and "x" not in disc.effect.replace("on the output", ""), disc.effect
    assert "d^2·tanh(d'/" in disc.effect, disc.effect
    assert disc.nrmse_after <= 1.15 * _floor(rec, g, dg)


def test_a_term_in_the_records_input_applies_to_a_force_driven_model():
    """The library's d, d', d'' are the record's input column and its derivatives. A force-driven model calls it F
    (duffing-gain on Silverbox): `duffsym reproduce` stopped in s10 with "model duffing-gain has no signal(s) ['d']"
    when discovery proposed -0.038·d + 2.5e-7·x'² there. The term now reads F (and F'' through a new input channel),
    and its free run adds exactly c·u to the base's."""
    from duffsym.effects.discovered import DiscoveredEffect, driving_signal
    from duffsym.model.library import get_model
    from duffsym.simulate import simulate_record

    d, dd = sp.Symbol("d", real=True), sp.Symbol("d_ddot", real=True)
    base = get_model("duffing-gain")
    assert driving_signal(base) == "F" and driving_signal(mr_damper()) == "d"
    ext = DiscoveredEffect((d, dd), (0.0, 0.0)).apply(base)
    assert [c.name for c in ext.inputs] == ["F", "F_ddot"]
    t = np.arange(2001) * 1e-3
    u = 0.1 * np.sin(2 * np.pi * 5 * t)
    rec = Record(t=t, d=u, y=u, name="u", source="test")
    y0 = simulate_record(base, base.defaults(), rec).y
    p = {**ext.defaults(), "disc1_c1": 2.0, "disc1_c2": 0.0}
    np.testing.assert_allclose(simulate_record(ext, p, rec).y - y0, 2.0 * u, atol=1e-12)
    p = {**ext.defaults(), "disc1_c1": 0.0, "disc1_c2": 1e-3}
    np.testing.assert_allclose(simulate_record(ext, p, rec).y - y0, 1e-3 * rec.acceleration(), atol=1e-12)
