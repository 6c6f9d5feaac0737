"""The command-driven MR damper whose element runs in the path of the drive (``mr-damper-current-path-viscous``,
issue 17 item 2): its limits are the existing models (symbolic), and identification recovers known parameters
from records of an independent numpy simulator (tests/independent_path_current_sim.py)."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import independent_path_current_sim as gen
from duffsym.data.record import Record
from duffsym.identify import Problem, fit
from duffsym.model import get_model
from duffsym.model.library import at_constant_command, mr_damper, mr_damper_current, mr_damper_current_path, path_time

NAME = "mr-damper-current-path-viscous"


def _s(model, name):
    return model.param(name).symbol


def test_at_a_constant_command_without_viscosity_it_is_the_path_element_with_the_coefficients_at_that_current():
    """u = i held, c0 = c0_u = 0, v_eps = eps: the equations are mr_damper's path element (path_time) with each
    coefficient theta + theta_u i and A_f (1 + A_f_u i); the field still follows the command in clock time."""
    m = get_model(NAME)
    eps = sp.Rational(1, 8)
    const = at_constant_command(m)
    i = const.param("i").symbol
    zero = {_s(m, "c0"): 0, _s(m, "c0_u"): 0, _s(m, EPS): eps}
    el = path_time(mr_damper(5), 0.125)
    subs = {_s(el, k): _s(el, k) + _s(m, k + "_u") * i for k in gen.FIELD}
    for got, want in zip(const.rhs, el.rhs):
        assert sp.simplify(got.xreplace(zero) - want.xreplace(subs)) == 0
    af, afu = _s(m, "A_f"), _s(m, "A_f_u")
    assert sp.expand(const.output.xreplace(zero) - af * (1 + afu * i) * el.states[1]) == 0
    assert sp.expand(m.rhs[2] - (-_s(m, "eta") * (m.states[2] - m.input_symbols[2]))) == 0


EPS = "v_eps"


def test_a_large_transition_velocity_gives_back_the_clock_time_model():
    """v_eps -> oo with c -> c/v_eps, k -> k/v_eps^2, c3 -> c3 v_eps^(n-2) (n = 5), A_f -> A_f v_eps, z = v_eps x2
    (the clock-time velocity): the equations and output tend to mr-damper-current's (c0 = c0_u = 0)."""
    m, ref = mr_damper_current_path(5, viscous=True), mr_damper_current(5)
    h = sp.Symbol("h", positive=True)  # 1 / v_eps
    x1, x2, u = m.states
    z = sp.Symbol("z", real=True)
    subs = {_s(m, EPS): 1 / h, x2: z * h, _s(m, "c0"): 0, _s(m, "c0_u"): 0, _s(m, "A_f"): _s(m, "A_f") / h}
    powers = {"c1": 1, "c2": 1, "k1": 2, "k2": 2, "k3": 2, "c3": 2 - 5}  # theta_path = theta_clock * h^power
    for k, power in powers.items():
        for name in (k, k + "_u") if k != "k3" else (k,):
            subs[_s(m, name)] = _s(m, name) * h**power
    dx1 = sp.limit(m.rhs[0].xreplace(subs), h, 0)
    dz = sp.limit((m.rhs[1].xreplace(subs) / h).expand(), h, 0)  # dz/dt = v_eps dx2/dt
    out = sp.limit(m.output.xreplace(subs), h, 0)
    assert sp.simplify(dx1 - z) == 0
    assert sp.simplify(dz - ref.rhs[1].xreplace({ref.states[1]: z})) == 0
    assert sp.simplify(out - ref.output.xreplace({ref.states[1]: z})) == 0
    assert m.rhs[2] == ref.rhs[2]


def test_a_vanishing_transition_velocity_is_rate_independent():
    """v_eps -> 0: the element's equations are |d'| times functions of (x, v, u, d, sign d') plus c1(u) d'; so
    in the path time s (dt = ds/|d'|) they do not involve the drive's speed (the loop is rate-independent)."""
    m = mr_damper_current_path(5, viscous=False)
    dd = m.input_symbols[1]
    a = sp.Symbol("a", positive=True)  # the speed |d'|, d' = a * sgn with sgn = +-1
    for sgn in (1, -1):
        lim = [sp.limit(e.xreplace({dd: sgn * a}), _s(m, EPS), 0, "+") for e in m.rhs[:2]]
        per_path = [sp.simplify(e / a) for e in lim]
        assert all(a not in e.free_symbols for e in per_path), per_path
    clock = mr_damper_current(5)  # the same check on the clock-time model fails: its rates keep the speed
    per_path = [sp.simplify(e.xreplace({clock.input_symbols[1]: a}) / a) for e in clock.rhs[:2]]
    assert any(a in e.free_symbols for e in per_path)


def _record(command, *, seed=0, disp=None, duration=6.0, name="gen") -> Record:
    disp = disp or gen.Sines((0.5, 0.2), (1.0, 2.3), (0.0, 1.0))
    g = gen.generate(gen.TRUTH, disp, command, duration=duration, seed=seed)
    c = np.asarray(g["command"])
    if np.ptp(c) == 0:
        return Record(t=g["t"], d=g["d"], y=g["y"], d_dot=g["d_dot"], current=float(c[0]), name=name)
    return Record(t=g["t"], d=g["d"], y=g["y"], d_dot=g["d_dot"], command=c, command_name="current", name=name)


@pytest.mark.slow
@pytest.mark.ci
def test_recovers_the_parameters_from_tests_at_three_constant_currents_at_different_rates():
    """A campaign from the independent simulator (1 % noise): three tests at 0.2, 0.5, 0.8 A whose drives differ in
    frequency (x1, x2.5, x0.4), one parameter set (eta held: a constant current does not show the lag). Every free
    parameter, the transition velocity v_eps and the viscous c0, c0_u included, within 3 standard errors of the
    truth, with standard errors under 5 % of the value (20 % for the field slopes), so the check can fail. The start
    is every parameter 0.6-1.6x off the truth: from the model's defaults the fit does not converge (as on the UTFSM
    campaign, where ``path_start`` from a clock-time fit is the start that works)."""
    recs = [
        _record(
            gen.constant(c),
            seed=k,
            duration=3.0,
            name=f"{c}A",
            disp=gen.Sines((0.5, 0.2), (1.0 * f, 2.3 * f), (0.3 * k, 1.0 + k)),
        )
        for k, (c, f) in enumerate(((0.2, 1.0), (0.5, 2.5), (0.8, 0.4)))
    ]
    model = get_model(NAME)
    free = [k for k in model.param_names if k not in ("A_f", "eta", "k3")]
    factors = np.exp(np.random.default_rng(1).uniform(np.log(0.6), np.log(1.6), len(free)))
    x0 = {k: gen.TRUTH[k] * f for k, f in zip(free, factors)}  # every parameter 0.6-1.6x off the truth
    res = fit(
        Problem(model, recs, free=free, fixed={"A_f": gen.TRUTH["A_f"], "eta": gen.TRUTH["eta"], "k3": 0.0}), x0=x0
    )
    assert res.success, res.message
    z = {n: (res.params[n] - gen.TRUTH[n]) / res.stderr[n] for n in res.free}
    assert max(abs(v) for v in z.values()) < 3.0, z
    rel = {n: res.stderr[n] / abs(gen.TRUTH[n]) for n in res.free}
    # measured: |z| <= 1.96; relative errors 0.2-3.7 % for the base coefficients, c0, c0_u, v_eps, A_f_u, 2-14 % for
    # the field slopes of c1..k2
    assert all(v < (0.2 if n.endswith("_u") and n != "A_f_u" else 0.05) for n, v in rel.items()), rel
    assert res.nrmse < 0.02
