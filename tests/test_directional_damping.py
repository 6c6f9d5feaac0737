"""The directional damping of a path-time element (``duffsym.effects.mechanical.DirectionalDamping``): its
equations against a hand statement; with the element's springs and c3 at zero it is the Bouc-Wen element
of exponent 1 (checked against the independent numpy simulator of the benchmark's oscillator,
tests/independent_bw.py); identification recovers known parameters, the directional one included, from a
record of the independent simulator of a mass carrying the element."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import independent_bw as B
from duffsym.data.record import Record
from duffsym.effects.mechanical import DirectionalDamping
from duffsym.errors import ModelError
from duffsym.model.library import mr_damper, path_time
from duffsym.model.structure import mass_spring_damper, structure


def _sym(name):
    return sp.Symbol(name, real=True)


def test_directional_damping_equations_match_an_independent_statement():
    x1, x2, d, dd = (_sym(s) for s in ("x1", "x2", "d", "d_dot"))
    c1, c2, c3, k1, k2, k3, cd = (_sym(s) for s in ("c1", "c2", "c3", "k1", "k2", "k3", "dir_c"))
    rho = sp.sqrt(dd**2 + sp.Rational(1, 16))
    base = rho * (k1 * (d - x1) - c1 * x2 - c2 * x2 - k2 * x1 - k3 * x1**3 - c3 * x2**3) + c1 * dd
    ab = lambda u: sp.sqrt(u**2 + sp.Rational(1, 10**6)) - sp.Rational(1, 1000)  # noqa: E731
    for shape, g in (("velocity", ab(x2)), ("velocity-quadratic", ab(x2) * x2), ("position", ab(x1))):
        el = DirectionalDamping(shape=shape).apply(path_time(mr_damper(3), 0.25))
        assert sp.simplify(el.rhs[0] - rho * x2) == 0
        assert sp.simplify(sp.nsimplify(el.rhs[1] - base + cd * dd * g)) == 0, shape
        assert el.effects == ("directional-damping",) and "dir_c" in el.param_names
    with pytest.raises(ModelError, match="shape must be one of"):
        DirectionalDamping(shape="speed").apply(mr_damper(3))


def _benchmark_as_path_model(eps=0.05):
    """The benchmark's Bouc-Wen oscillator in the model's units (mm, N): A_f = 50 N, c1 = alpha/A_f per mm,
    c1 + c2 = beta gamma per mm, dir_c = beta delta per mm, springs of the element at zero."""
    eq, params = mass_spring_damper()
    model = structure(DirectionalDamping().apply(path_time(mr_damper(3), eps)), equation=eq, params=params)
    bw = B.BOUC_WEN
    A_f = 50.0
    p = dict(
        m=bw["m"] * 1e-3,
        c=bw["c"] * 1e-3,
        k=bw["k"] * 1e-3,
        A_f=A_f,
        c1=bw["alpha"] * 1e-3 / A_f,
        c2=(bw["beta"] * bw["gamma"] - bw["alpha"] / A_f) * 1e-3,
        dir_c=bw["beta"] * bw["delta"] * 1e-3,
        c3=0.0,
        k1=0.0,
        k2=0.0,
        k3=0.0,
    )
    return model, p


def test_without_springs_it_is_the_bouc_wen_element():
    """Driven by the same multisine, the mass with the path element + directional damping (springs and c3 at
    zero) moves as the independent simulator of the benchmark's Bouc-Wen oscillator."""
    from duffsym.simulate import simulate

    fs, n = 750.0, 3000
    u = B.multisine(n, fs, seed=3, rms=50.0)
    y_ref = B.simulate_bouc_wen(u, fs, substeps=20)[:, 0] * 1e3  # mm
    model, p = _benchmark_as_path_model()
    tr = simulate(model, p, np.arange(n) / fs, {"F": u})
    assert tr.success
    err = np.sqrt(np.mean((tr.y - y_ref) ** 2)) / np.std(y_ref)
    assert err < 0.01  # (measured 0.25 %; eps of |x'| 1e-4: 0.03 %, 1e-2: 2.5 %)
    p_off = {**p, "dir_c": 0.0}
    off = simulate(model, p_off, np.arange(n) / fs, {"F": u})
    assert np.sqrt(np.mean((off.y - y_ref) ** 2)) / np.std(y_ref) > 10 * err  # the term matters


TRUTH = dict(m=2e-3, c=0.01, k=50.0, c1=1.5, c2=0.5, c3=0.4, k1=2.0, k2=1.0, k3=0.0, A_f=20.0, c_dir=-0.8)
EPS = 0.1


@pytest.mark.slow
@pytest.mark.ci
def test_fit_recovers_the_directional_damping_from_an_independent_record():
    """Equation-error start from O(1) element values (c_dir from 0), then the collocation fit, on 1 % noise
    of the independent simulator (exact |w|, the model's |.| is smoothed at 0.01)."""
    from duffsym.identify import Problem, fit
    from duffsym.identify.structure import equation_error_start, scaled_to

    n, seed = 1200, 7
    u = B.multisine(n, 750.0, seed=seed, rms=20.0)
    S = B.simulate_path_structure(np.r_[u, u], 750.0, {**TRUTH, "n": 3, "eps": EPS}, substeps=10)[n:]
    rng = np.random.default_rng(seed)
    rec = Record(t=np.arange(n) / 750.0, d=u, y=S[:, 0] + 0.01 * S[:, 0].std() * rng.standard_normal(n))
    model = structure(DirectionalDamping().apply(path_time(mr_damper(3), EPS)))
    base = {
        **model.defaults(),
        "c1": 1.0,
        "c2": 1.0,
        "c3": 1.0,
        "k1": 1.0,
        "k2": 1.0,
        "k3": 0.0,
        "dir_c": 0.0,
        "A_f": TRUTH["A_f"],
    }
    model = scaled_to(model, base)
    fixed = {"A_f": TRUTH["A_f"], "k3": 0.0}
    start = equation_error_start(rec, model, n_random=4, fixed=fixed, starts=[base])
    assert start.pop("_equation_nrmse") < 0.1
    r = fit(Problem(scaled_to(model, start), rec, fixed=fixed), start, compute_stderr=False)
    assert r.success, r.message
    assert r.nrmse < 0.015  # the 1 % noise
    for name in ("m", "k", "c1", "c2", "k1", "k2"):  # measured: all within 1 %
        assert r.params[name] == pytest.approx(TRUTH[name], rel=0.03), name
    assert r.params["dir_c"] == pytest.approx(TRUTH["c_dir"], rel=0.03)  # measured -0.797
    assert r.params["c3"] == pytest.approx(TRUTH["c3"], rel=0.1)  # measured 0.399


def test_coupled_argument_names_the_directional_remainder():
    """V = (c1/A_f) E_s + E_e as without the term; dV/dt gains -dir_c q2 x2 |x2| (hand statement), which has no
    sign: the argument does not close, and the certificate of the benchmark-like parameters fails."""
    from duffsym.derive.coupled import RHO, coupled_analysis, coupled_certificate

    model = structure(DirectionalDamping().apply(path_time(mr_damper(3), 0.5)))
    an = coupled_analysis(model)
    q1, q2, x1, x2 = (_sym(s) for s in ("q1", "q2", "x1", "x2"))
    m, c, k, c1, c2, c3, k1, k2, k3, Af, cd = (
        _sym(s) for s in ("m", "c", "k", "c1", "c2", "c3", "k1", "k2", "k3", "A_f", "dir_c")
    )
    V = c1 / Af * (m * q2**2 / 2 + k * q1**2 / 2) + x2**2 / 2 + (k1 + k2) * x1**2 / 2 + k3 * x1**4 / 4
    absx2 = sp.sqrt(x2**2 + sp.Rational(1, 10**6)) - sp.Rational(1, 1000)
    Vdot = -c * c1 / Af * q2**2 + RHO * (-(c1 + c2) * x2**2 - c3 * x2**4 + k1 * q1 * x2) - cd * q2 * x2 * absx2
    assert sp.simplify(an.V - V) == 0
    assert sp.simplify(sp.nsimplify(an.V_dot - Vdot)) == 0
    assert cd in an.remainder.free_symbols and "does not close" in an.conclusion
    _, p = _benchmark_as_path_model()
    assert not coupled_certificate(model, p).holds_global
