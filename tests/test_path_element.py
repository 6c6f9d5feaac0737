"""The rate-independent (path-time) Duffing-like element: its loop does not depend on the drive's rate
(checked against the element integrated in the drive's phase by tests/independent_bw.py, numpy only), the
coupled derivations carry its path rate, and identification recovers known parameters from a record of
the independent simulator of a mass carrying it."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

import independent_bw as B
from duffsym.data.record import Record
from duffsym.errors import ModelError
from duffsym.model.library import mr_damper, path_epsilon, path_time
from duffsym.model.structure import structure

#: An element with O(1) coefficients per unit of path, its force A_f w of order 1.
ELEMENT = dict(c1=1.5, c2=0.5, c3=0.4, k1=2.0, k2=1.0, k3=0.0, A_f=1.0, n=3)


def _sym(name):
    return sp.Symbol(name, real=True)


def test_path_element_equations_match_an_independent_statement():
    eps = 0.25
    el = path_time(mr_damper(3), eps)
    x1, x2, d, dd = (_sym(s) for s in ("x1", "x2", "d", "d_dot"))
    c1, c2, c3, k1, k2, k3, Af = (_sym(s) for s in ("c1", "c2", "c3", "k1", "k2", "k3", "A_f"))
    rho = sp.sqrt(dd**2 + sp.Rational(1, 16))
    expected = [rho * x2, rho * (k1 * (d - x1) - c1 * x2 - c2 * x2 - k2 * x1 - k3 * x1**3 - c3 * x2**3) + c1 * dd]
    assert [sp.simplify(a - b) for a, b in zip(el.rhs, expected)] == [0, 0]
    assert el.output == Af * x2 and el.name == "mr-damper-path" and path_epsilon(el) == pytest.approx(eps)
    with pytest.raises(ModelError, match="epsilon must be a positive"):
        path_time(mr_damper(3), 0.0)


def _loop(model, params, amplitude, freq, per_cycle=400, cycles=3):
    from duffsym.simulate import simulate

    t = np.arange(cycles * per_cycle + 1) / (per_cycle * freq)
    w = 2 * math.pi * freq
    tr = simulate(model, params, t, {"d": amplitude * np.sin(w * t), "d_dot": amplitude * w * np.cos(w * t)})
    return tr.y


def test_loop_is_rate_independent_and_matches_the_phase_integration():
    """Driven by d = A sin(2 pi f t) at f = 0.5 Hz and 50 Hz (100x), the path element's force at the same
    phases coincides, and equals the element integrated in the phase (independent, eps = 0); the paper's
    rate-dependent element driven the same way gives loops that differ by far more."""
    A = 1.0
    p = {k: v for k, v in ELEMENT.items() if k != "n"}
    _, _, ref = B.path_element_loop(A, ELEMENT, per_cycle=400, cycles=3)
    eps = 1e-4 * A * 2 * math.pi * 0.5  # 1e-4 of the slow drive's velocity amplitude
    el = path_time(mr_damper(3), eps)
    slow, fast = _loop(el, p, A, 0.5), _loop(el, p, A, 50.0)
    scale = np.max(np.abs(ref))
    assert scale > 0.5
    assert np.max(np.abs(slow - fast)) < 1e-4 * scale  # measured 1e-6
    assert np.max(np.abs(slow - ref)) < 5e-4 * scale  # measured 3e-5
    rate = mr_damper(3)
    r_slow, r_fast = _loop(rate, p, A, 0.5), _loop(rate, p, A, 50.0)
    assert np.max(np.abs(r_slow - r_fast)) > 0.3 * max(np.max(np.abs(r_slow)), np.max(np.abs(r_fast)))


def test_coupled_argument_of_the_path_element():
    """V = (c1/A_f) E_s + E_e as for Eq. 12; dV/dt has the element's dissipation times the path rate rho."""
    from duffsym.derive.coupled import RHO, coupled_analysis, coupled_certificate

    model = structure(path_time(mr_damper(3), 0.5))
    an = coupled_analysis(model)
    q1, q2, x1, x2 = (_sym(s) for s in ("q1", "q2", "x1", "x2"))
    m, c, k, c1, c2, c3, k1, k2, k3, Af = (_sym(s) for s in ("m", "c", "k", "c1", "c2", "c3", "k1", "k2", "k3", "A_f"))
    V = c1 / Af * (m * q2**2 / 2 + k * q1**2 / 2) + x2**2 / 2 + (k1 + k2) * x1**2 / 2 + k3 * x1**4 / 4
    Vdot = -c * c1 / Af * q2**2 + RHO * (-(c1 + c2) * x2**2 - c3 * x2**4 + k1 * q1 * x2)
    assert sp.simplify(an.V - V) == 0
    assert sp.simplify(an.V_dot - Vdot) == 0
    assert sp.simplify(an.path_rate.rhs - sp.sqrt(q2**2 + sp.Rational(1, 4))) == 0
    assert "does not close" in an.conclusion
    truth = dict(m=2e-3, c=0.01, k=50.0, **{k: v for k, v in ELEMENT.items() if k != "n"})
    assert coupled_certificate(model, {**truth, "k1": 0.0}).holds_global
    cert = coupled_certificate(model, truth)
    assert not cert.holds_global and cert.holds_local


TRUTH = dict(m=2e-3, c=0.01, k=50.0, c1=1.5, c2=0.5, c3=0.4, k1=2.0, k2=1.0, k3=0.0, A_f=20.0)
EPS = 0.1


def _record(n, seed, noise=0.01):
    u = B.multisine(n, 750.0, seed=seed, rms=20.0)
    S = B.simulate_path_structure(np.r_[u, u], 750.0, {**TRUTH, "n": 3, "eps": EPS}, substeps=10)[n:]
    rng = np.random.default_rng(seed)
    q = S[:, 0] + noise * S[:, 0].std() * rng.standard_normal(n)
    return Record(t=np.arange(n) / 750.0, d=u, y=q), S


@pytest.mark.slow
@pytest.mark.ci
def test_fit_recovers_the_independent_path_structure():
    """Equation-error start from O(1) element values, then the collocation fit, on 1 % noise."""
    from duffsym.identify import Problem, fit
    from duffsym.identify.structure import equation_error_start, scaled_to

    rec, S = _record(1200, seed=5)
    assert np.std(S[:, 3]) * TRUTH["A_f"] > 0.2 * np.std(rec.d)  # the element carries a real share of the force
    model = structure(path_time(mr_damper(3), EPS))
    base = {**model.defaults(), "c1": 1.0, "c2": 1.0, "c3": 1.0, "k1": 1.0, "k2": 1.0, "k3": 0.0, "A_f": TRUTH["A_f"]}
    model = scaled_to(model, base)
    start = equation_error_start(rec, model, n_random=4, fixed={"A_f": TRUTH["A_f"], "k3": 0.0})
    assert start.pop("_equation_nrmse") < 0.1
    r = fit(Problem(scaled_to(model, start), rec, fixed={"A_f": TRUTH["A_f"], "k3": 0.0}), start, compute_stderr=False)
    assert r.success, r.message
    assert r.nrmse < 0.015  # the 1 % noise
    for name in ("m", "k", "c1", "c2", "k1", "k2"):
        assert r.params[name] == pytest.approx(TRUTH[name], rel=0.08), name
    assert r.params["c3"] == pytest.approx(TRUTH["c3"], rel=0.25)


def test_single_element_derivations_are_in_its_own_time():
    """derive on a path element: a first item says the derivations are in the path s; they are Eq. 12's."""
    from duffsym.derive.report import derivation_report
    from duffsym.model.library import mr_damper_path

    path, rate = derivation_report(mr_damper_path(3, epsilon=0.01)), derivation_report(mr_damper(3))
    assert path.items[0].key == "path_time" and "rho" in path.items[0].note
    assert path.item("lyapunov_derivative").text == rate.item("lyapunov_derivative").text
    assert path.item("stability_conditions").text == rate.item("stability_conditions").text
