"""Energy per cycle and loop area: derived identities against the paper's model typed here, and
against simulated steady cycles."""

import numpy as np
import pytest
import sympy as sp

from duffsym import Sine, simulate
from duffsym.derive import cycle_energy, energy_balance, linear_loop_area, linear_loop_area_value, loop_area
from duffsym.errors import DataError
from duffsym.model import duffing_like, mr_damper
from duffsym.model.library import N_SYMBOL
from duffsym.model.presets import FIG3_BASE, FIG3_N, TABLE2, TABLE2_N

t_ = sp.Symbol("t", real=True)
T_ = sp.Symbol("T", positive=True)
x_ = sp.Function("x", real=True)(t_)
d_ = sp.Function("d", real=True)(t_)
gamma, alpha, k1, c1, A_f, delta = sp.symbols("gamma alpha k1 c1 A_f delta", real=True)


def test_by_parts_relation_is_derived():
    n = N_SYMBOL
    eb = energy_balance(duffing_like(n))
    xd, dd = sp.diff(x_, t_), sp.diff(d_, t_)
    # c1 * oint x' d' dt - k1 * oint x d' dt = oint (gamma x'^2 + delta x'^(n+1)) dt
    got = {sp.simplify(g): c for c, g in eb.by_parts}
    assert set(got) == {sp.simplify(xd * dd), sp.simplify(x_ * dd)}
    assert sp.simplify(got[sp.simplify(xd * dd)] - c1) == 0
    assert sp.simplify(got[sp.simplify(x_ * dd)] + k1) == 0
    w = eb.by_parts_equation.rhs.function
    assert sp.simplify(sp.powsimp(sp.expand(w - gamma * xd**2 - delta * xd ** (n + 1)), combine="exp")) == 0
    # loop area = A_f/c1 * (oint W dt + k1 oint x d' dt)
    assert sp.simplify(eb.loop_area_equation.lhs.function - A_f * xd * dd) == 0


def test_linear_closed_form_is_derived():
    lla = linear_loop_area(duffing_like(3))
    s, a, w = sp.Symbol("s"), sp.Symbol("a", positive=True), sp.Symbol("omega", positive=True)
    H = (c1 * s + k1) / (s**2 + gamma * s + alpha)
    assert sp.simplify(lla.transfer - H) == 0
    paper = A_f * sp.pi * a**2 * w * sp.re(sp.expand_complex(H.subs(s, sp.I * w)))
    assert sp.simplify(lla.loop_area - paper) == 0
    assert lla.equal


def steady(model, params, freq, periods, dt, substeps):
    t = np.arange(0.0, periods / freq + dt / 2, dt)
    return simulate(model, params, t, Sine(1.0, freq), substeps=substeps)


@pytest.mark.parametrize("voltage", [0.0, 0.4, 0.8])
def test_cycle_identities_on_table2_rows(voltage):
    model = mr_damper(TABLE2_N)
    traj = steady(model, TABLE2[voltage], 2.0, 6, 5e-4, 2)
    ce = cycle_energy(traj, 0.5, model)
    assert ce.dissipated > 0
    # energy balance: input work = dissipated + V(T) - V(0)  (quadrature + integration error only)
    assert abs(ce.balance_residual) < 1e-4 * ce.input_work
    assert abs(ce.delta_v) < 1e-4 * ce.input_work  # periodic steady state
    assert ce.by_parts == pytest.approx(ce.input_work, rel=1e-5)
    assert ce.loop_area == pytest.approx(ce.loop_area_predicted, rel=1e-4)


def test_cycle_identities_on_fig3_benchmark():
    model = duffing_like(FIG3_N)
    traj = steady(model, FIG3_BASE, 1.0, 6, 5e-4, 2)
    ce = cycle_energy(traj, 1.0, model)
    assert ce.dissipated > 0
    assert abs(ce.balance_residual) < 1e-4 * ce.input_work
    assert ce.loop_area == pytest.approx(ce.loop_area_predicted, rel=1e-4)


def test_linear_limit_loop_area_matches_simulation():
    model = mr_damper(TABLE2_N)
    lin = dict(TABLE2[0.4], c3=0.0, k3=0.0)
    traj = steady(model, lin, 2.0, 6, 5e-4, 2)
    ce = cycle_energy(traj, 0.5, model)
    closed = linear_loop_area_value(lin, model, 1.0, 2.0)
    assert ce.loop_area == pytest.approx(closed, rel=1e-4)


def test_loop_area_of_an_ellipse():
    t = np.linspace(0.0, 1.0, 2001)[:-1]
    d = 0.7 * np.sin(2 * np.pi * t)
    y = 1.3 * np.cos(2 * np.pi * t)  # clockwise in the d-y plane: positive area pi*a*b
    assert loop_area(t, d, y) == pytest.approx(np.pi * 0.7 * 1.3, rel=1e-5)
    assert loop_area(t, d, -y) == pytest.approx(-np.pi * 0.7 * 1.3, rel=1e-5)


def test_loop_area_bad_input():
    with pytest.raises(DataError, match="same length"):
        loop_area([0, 1, 2], [0, 1], [0, 1, 2])
    with pytest.raises(DataError, match="strictly increasing"):
        loop_area([0, 2, 1], [0, 1, 2], [0, 1, 2])
    with pytest.raises(DataError, match="non-finite"):
        loop_area([0, 1, 2], [0, np.nan, 2], [0, 1, 2])
