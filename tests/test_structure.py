"""The structure model (a mass whose restoring force includes the Duffing-like element): composition,
coupled derivations checked against statements typed here, and identification on records of the
independent simulator (tests/independent_bw.py, numpy only)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

import independent_bw as B
from duffsym.data.record import Record
from duffsym.derive.coupled import coupled_analysis, coupled_certificate
from duffsym.errors import ModelError
from duffsym.model.library import duffing, get_model, mr_damper
from duffsym.model.structure import structure

#: A mass (q in mm, F in N) with a Duffing-like element whose force is ~20 N.
TRUTH = dict(m=2e-3, c=0.01, k=50.0, c1=100.0, c2=200.0, c3=0.05, k1=2e4, k2=8e4, k3=0.0, A_f=0.5)


def _sym(name):
    return sp.Symbol(name, real=True)


def test_composed_equations_match_an_independent_statement():
    model = get_model("structure", 3)
    q1, q2, x1, x2, F = (_sym(s) for s in ("q1", "q2", "x1", "x2", "F"))
    m, c, k, c1, c2, c3, k1, k2, k3, Af = (_sym(s) for s in ("m", "c", "k", "c1", "c2", "c3", "k1", "k2", "k3", "A_f"))
    expected = [
        q2,
        (F - c * q2 - k * q1 - Af * x2) / m,
        x2,
        k1 * (q1 - x1) + c1 * (q2 - x2) - c2 * x2 - k2 * x1 - k3 * x1**3 - c3 * x2**3,
    ]
    assert [sp.simplify(a - b) for a, b in zip(model.rhs, expected)] == [0, 0, 0, 0]
    assert model.output == q1 and [c.name for c in model.inputs] == ["F"]
    assert model.param_names == ("m", "c", "k", "c1", "c2", "c3", "k1", "k2", "k3", "A_f")


def test_composition_refuses_what_it_cannot_compose():
    with pytest.raises(ModelError, match="driven by d and d_dot"):
        from duffsym.effects import CATALOGUE, apply_effects

        structure(apply_effects(mr_damper(3), [CATALOGUE["inertia"]]))
    with pytest.raises(ModelError, match="must contain the element force H"):
        q, F = _sym("q"), _sym("F")
        structure(mr_damper(3), equation=sp.Eq(q, F), params=())
    with pytest.raises(ModelError, match="driven by d and d_dot"):
        structure(duffing())  # driven by a force F, not by a displacement


def test_effects_act_on_either_part():
    from duffsym.effects import CATALOGUE, apply_effects

    el = apply_effects(mr_damper(3), [CATALOGUE["force-offset"]])
    composed = structure(el)
    assert "off_y0" in composed.param_names and "off_y0" in str(composed.rhs[1])
    outer = apply_effects(get_model("structure", 3), [CATALOGUE["cubic-damping"]])
    assert outer.effects == ("cubic-damping",)
    assert outer.param_names[10:] == ("cdamp_c",)
    assert sp.Symbol("cdamp_c", real=True) in outer.rhs[1].free_symbols
    assert outer.rhs[1] != get_model("structure", 3).rhs[1]  # the term lands on the structure's velocity


def test_coupled_lyapunov_matches_hand_derivation():
    an = coupled_analysis(get_model("structure", 3))
    q1, q2, x1, x2 = (_sym(s) for s in ("q1", "q2", "x1", "x2"))
    m, c, k, c1, c2, c3, k1, k2, k3, Af = (_sym(s) for s in ("m", "c", "k", "c1", "c2", "c3", "k1", "k2", "k3", "A_f"))
    # typed here: V = (c1/A_f)(m q'^2/2 + k q^2/2) + x'^2/2 + (k1+k2) x^2/2 + k3 x^4/4
    V = c1 / Af * (m * q2**2 / 2 + k * q1**2 / 2) + x2**2 / 2 + (k1 + k2) * x1**2 / 2 + k3 * x1**4 / 4
    Vdot = -c * c1 / Af * q2**2 - (c1 + c2) * x2**2 - c3 * x2**4 + k1 * q1 * x2
    assert sp.simplify(an.V - V) == 0
    assert sp.simplify(an.V_dot - Vdot) == 0
    assert sp.simplify(an.remainder - k1 * q1 * x2) == 0
    assert "does not close" in an.conclusion


def test_coupled_argument_closes_without_the_input_spring():
    # with k1 = 0 the remainder vanishes: the energy argument is global; otherwise local (Hurwitz)
    model = get_model("structure", 3)
    cert0 = coupled_certificate(model, {**TRUTH, "k1": 0.0})
    cert1 = coupled_certificate(model, TRUTH)
    assert cert0.holds_global and cert0.holds_local
    assert not cert1.holds_global and cert1.holds_local


def _jacobian_at_zero(params, eps=1e-7):
    p = {**params, "n": 3}
    J = np.zeros((4, 4))
    for j in range(4):
        e = np.zeros(4)
        e[j] = eps
        J[:, j] = (B._dl_rhs(e, 0.0, p) - B._dl_rhs(-e, 0.0, p)) / (2 * eps)
    return J


def test_characteristic_polynomial_matches_the_independent_simulator():
    model = get_model("structure", 3)
    an = coupled_analysis(model)
    lam = sp.Symbol("lambda")
    subs = {model.param(k).symbol: v for k, v in TRUTH.items()}
    roots = np.roots([float(c) for c in sp.Poly(an.char_poly.xreplace(subs), lam).all_coeffs()])
    eig = np.linalg.eigvals(_jacobian_at_zero(TRUTH))
    assert np.allclose(np.sort_complex(roots), np.sort_complex(eig), rtol=1e-5)
    # an unstable set: negative structure damping beyond the element's -> a Hurwitz determinant fails
    bad = {**TRUTH, "c": -5.0}
    assert max(np.linalg.eigvals(_jacobian_at_zero(bad)).real) > 0
    assert not coupled_certificate(model, bad).holds_local


def test_energy_per_cycle_on_independent_steady_state():
    fs, f0, n_per = 2000.0, 20.0, 100
    t = np.arange(6 * n_per) / fs
    u = 30.0 * np.sin(2 * math.pi * f0 * t)
    S = B.simulate_duffing_like_structure(u, fs, {**TRUTH, "n": 3}, substeps=20)
    sl = slice(5 * n_per, 6 * n_per + 1)
    S, u = np.vstack([S, S[-1:]])[sl], np.append(u, u[0])[sl]
    cyc = lambda v: float(np.sum(v[:-1]) / fs)  # noqa: E731  (periodic: the trapezoid rule over one period)
    q, v, x, w = S.T
    work = cyc(u * v)
    viscous = cyc(TRUTH["c"] * v**2)
    element = cyc(TRUTH["A_f"] * w * v)
    W_e = (TRUTH["c1"] + TRUTH["c2"]) * w**2 + TRUTH["c3"] * w**4
    element_rhs = TRUTH["A_f"] / TRUTH["c1"] * (cyc(W_e) + TRUTH["k1"] * cyc(x * v))
    assert work > 0 and element > 0
    assert work == pytest.approx(viscous + element, rel=2e-3)
    assert element == pytest.approx(element_rhs, rel=2e-3)
    an = coupled_analysis(get_model("structure", 3))
    assert "c*q2**2" in str(an.structure_cycle) and "k1*Integral(q2*x1" in str(an.element_cycle)


def _record(n, seed, noise=0.01):
    u = B.multisine(n, 750.0, seed=seed)
    S = B.simulate_duffing_like_structure(np.r_[u, u], 750.0, {**TRUTH, "n": 3}, substeps=10)[n:]
    rng = np.random.default_rng(seed)
    q = S[:, 0] + noise * S[:, 0].std() * rng.standard_normal(n)
    return Record(t=np.arange(n) / 750.0, d=u, y=q), S


def test_fit_recovers_the_independent_structure():
    """Equation-error start (from the element's defaults and random starts), then the collocation fit."""
    from duffsym.identify import Problem, fit
    from duffsym.identify.structure import equation_error_start, scaled_to

    rec, _ = _record(800, seed=1)
    model = get_model("structure", 3).with_params(A_f=TRUTH["A_f"])
    start = equation_error_start(rec, model)
    assert start.pop("_equation_nrmse") < 0.1
    r = fit(Problem(scaled_to(model, start), rec, fixed={"A_f": TRUTH["A_f"], "k3": 0.0}), start)
    assert r.success, r.message
    assert r.nrmse < 0.015  # the 1 % noise
    for name in ("m", "k", "c1", "c2", "k1", "k2"):
        assert r.params[name] == pytest.approx(TRUTH[name], rel=0.08), name
    assert r.params["c3"] == pytest.approx(TRUTH["c3"], rel=0.25)


@pytest.mark.slow
def test_fit_recovers_the_independent_structure_from_the_defaults():
    """The collocation fit alone, from the element's default parameters (~40-500 s on a busy machine)."""
    from duffsym.identify import Problem, fit

    rec, _ = _record(1500, seed=1)
    r = fit(Problem(get_model("structure", 3), rec, fixed={"A_f": TRUTH["A_f"], "k3": 0.0}))
    assert r.success, r.message
    assert r.nrmse < 0.015
    for name in ("m", "k", "c1", "c2", "k1", "k2"):
        assert r.params[name] == pytest.approx(TRUTH[name], rel=0.08), name


@pytest.mark.slow
@pytest.mark.ci
def test_bouc_wen_mass_recovered_and_prediction_beats_linear():
    """A mass with a Bouc-Wen element (the benchmark's constants, independent simulator): the structure
    model recovers the mass and stiffness scale and predicts a new record better than the linear structure."""
    from duffsym.identify.structure import equation_error_start
    from duffsym.simulate import simulate

    def bw_record(n, seed):
        u = B.multisine(n, 750.0, seed=seed)
        S = B.simulate_bouc_wen(np.r_[u, u], 750.0, substeps=10)[n:]
        return Record(t=np.arange(n) / 750.0, d=u, y=1e3 * S[:, 0]), u  # q in mm

    from duffsym.benchmark.bouc_wen import bouc_wen_model

    est, _ = bw_record(4096, seed=3)
    val, u_val = bw_record(2048, seed=4)
    model = bouc_wen_model()  # a cubic spring and the element
    start = equation_error_start(est, model)
    assert start.pop("_equation_nrmse") < 0.2
    assert start["m"] == pytest.approx(2e-3, rel=0.05)  # 2 kg in N/(mm/s^2)
    # linear reference: m q'' + c q' + k q = F by least squares on the same data, the element switched off
    from duffsym.identify.structure import structure_initial_guess

    lin = {**start, "A_f": 1e-9}
    lin.update({k: v for k, v in structure_initial_guess(est, model).items() if k in ("m", "c", "k")})

    def rmse(p):
        tr = simulate(model, p, np.arange(3 * 2048) / 750.0, {"F": np.tile(u_val, 3)}, on_failure="return")
        return float(np.sqrt(np.mean((tr.y[-2048:] - val.y) ** 2)))

    assert rmse(start) < 0.7 * rmse(lin)


def test_structure_state_guess_from_data():
    from duffsym.identify.states import initial_states

    rec, S = _record(400, seed=2, noise=0.0)
    model = get_model("structure", 3)
    X = initial_states(model, rec, model.param_vector(TRUTH))
    inner = slice(40, 360)
    assert np.allclose(X[inner, 0], S[inner, 0])
    assert np.corrcoef(X[inner, 1], S[inner, 1])[0, 1] > 0.999
    # the element simulated from the measured motion: its velocity follows the truth after its transient
    assert np.corrcoef(X[200:, 3], S[200:, 3])[0, 1] > 0.99
