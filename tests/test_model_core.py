"""The symbolic model: state-space extraction against the paper's typed matrices, validation, composition."""

import numpy as np
import pytest
import sympy as sp

from duffsym import ModelError, duffing, duffing_like, get_model, mr_damper, state_space
from duffsym.model.library import N_SYMBOL
from duffsym.model.presets import TABLE1_BASE, TABLE2, table2_params


def syms(*names):
    return [sp.Symbol(n, real=True) for n in names]


x1, x2, d, dd = syms("x1", "x2", "d", "d_dot")


def assert_same(a, b):
    diff = sp.simplify(sp.Matrix(a) - sp.Matrix(b))
    assert diff == sp.zeros(*diff.shape), diff


@pytest.mark.parametrize("n", [1, 3, 5, 7, N_SYMBOL])
def test_duffing_like_state_space_is_eq4_eq5(n):
    """Eq. 4–5, typed from the paper, against the form extracted from Eq. 3."""
    gamma, alpha, beta, delta, k1, c1, af = syms("gamma", "alpha", "beta", "delta", "k1", "c1", "A_f")
    ss = state_space(duffing_like(n))
    if n == 1:  # x^1 is linear: beta and delta join A
        assert_same(ss.A, [[0, 1], [-alpha - beta, -gamma - delta]])
        assert_same(ss.f, [[0], [0]])
    else:
        assert_same(ss.A, [[0, 1], [-alpha, -gamma]])
        assert_same(ss.f, [[0], [-beta * x1**n - delta * x2**n]])
    assert_same(ss.B, [[0, 0], [k1, c1]])
    assert_same(ss.C, [[0, af]])
    assert ss.h == 0 and ss.D == sp.zeros(1, 2)
    model = duffing_like(n)
    assert_same(ss.rhs(), sp.Matrix(model.rhs))


@pytest.mark.parametrize("n", [3, 5, N_SYMBOL])
def test_mr_damper_state_space_is_eq13_eq14(n):
    c1, c2, c3, k1, k2, k3, af = syms("c1", "c2", "c3", "k1", "k2", "k3", "A_f")
    ss = state_space(mr_damper(n))
    assert_same(ss.A, [[0, 1], [-k1 - k2, -c1 - c2]])
    assert_same(ss.f, [[0], [-c3 * x2**n - k3 * x1**n]])
    assert_same(ss.B, [[0, 0], [k1, c1]])
    assert_same(ss.C, [[0, af]])


def test_separate_powers_for_x_and_xdot():
    c3, k3 = syms("c3", "k3")
    ss = state_space(mr_damper(n_x=3, n_v=5))
    assert_same(ss.f, [[0], [-c3 * x2**5 - k3 * x1**3]])
    assert dict(mr_damper(n_x=3, n_v=5).structural) == {"n_x": 3, "n_v": 5}


def test_physical_mr_damper_divides_by_mass():
    m, c1, c2, k1, k2 = syms("m", "c1", "c2", "k1", "k2")
    ss = state_space(mr_damper(physical=True))
    assert_same(ss.A, [[0, 1], [-(k1 + k2) / m, -(c1 + c2) / m]])
    assert_same(ss.B, [[0, 0], [k1 / m, c1 / m]])


def test_duffing_eq1():
    gamma, alpha, beta, F = syms("gamma", "alpha", "beta", "F")
    model = duffing()
    ss = state_space(model)
    assert_same(ss.A, [[0, 1], [-alpha, -gamma]])
    assert_same(ss.f, [[0], [-beta * x1**3]])
    assert_same(ss.B, [[0], [1]])
    assert_same(ss.C, [[1, 0]])


@pytest.mark.parametrize("bad", [0, -3, 2, 4, 2.5, "3", True])
def test_bad_power_is_rejected_with_reason(bad):
    with pytest.raises(ModelError, match="odd|positive odd integer"):
        mr_damper(bad)


def test_even_power_allowed_only_on_request():
    with pytest.raises(ModelError, match=r"n must be odd .* got 4; use 3 or 5"):
        mr_damper(4)
    assert dict(mr_damper(4, allow_even=True).structural)["n_v"] == 4


def test_param_vector_validation():
    model = mr_damper()
    with pytest.raises(ModelError, match=r"unknown parameter\(s\) \['c4'\].*known: c1, c2"):
        model.param_vector({**TABLE2[0.4], "c4": 1.0})
    with pytest.raises(ModelError, match=r"missing value\(s\) for \['A_f'\]"):
        model.param_vector({k: v for k, v in TABLE2[0.4].items() if k != "A_f"})
    with pytest.raises(ModelError, match=r"\['c3'\] are not finite"):
        model.param_vector({**TABLE2[0.4], "c3": float("nan")})
    with pytest.raises(ModelError, match="got a vector of length 3"):
        model.param_vector([1.0, 2.0, 3.0])
    vec = model.param_vector({"c3": 300.0}, fill_defaults=True)
    assert vec[model.param_names.index("c3")] == 300.0
    assert vec[model.param_names.index("k1")] == model.param("k1").default


def test_tables_and_lookup():
    assert table2_params(0.4)["k2"] == 480
    with pytest.raises(ModelError, match=r"0.35 V is not a row of Table 2; choose one of 0, 0.2"):
        table2_params(0.35)
    assert set(TABLE1_BASE) == set(mr_damper().param_names)
    with pytest.raises(ModelError, match=r"unknown model 'bouc'; choose one of"):
        get_model("bouc")


def test_unknown_symbol_in_equation_is_reported():
    model = mr_damper()
    stray = sp.Symbol("q", real=True)
    with pytest.raises(ModelError, match=r"unknown symbol\(s\) \['q'\] in the equation of state x2"):
        model.extend(effect="broken", rhs_add={model.velocity: stray})


def test_extend_adds_state_param_and_keeps_order():
    from duffsym.effects import CoulombFriction, OutputLag, apply_effects

    model = apply_effects(mr_damper(), [CoulombFriction(), OutputLag()])
    assert model.param_names[:7] == mr_damper().param_names
    assert model.param_names[7:] == ("fric_mu", "lag_tau")
    assert model.state_names == ("x1", "x2", "z_lag")
    assert model.effects == ("coulomb-friction", "output-lag")
    mu = model.param("fric_mu").symbol
    # the friction term enters the acceleration equation and nothing else
    added = sp.simplify(model.rhs[1] - mr_damper().rhs[1])
    assert sp.simplify(added + mu * sp.tanh(x2 / sp.Float(0.01))) == 0
    with pytest.raises(ModelError, match="already applied"):
        CoulombFriction().apply(model)
    # the key (cache of generated code) changes with the equations
    assert model.key != mr_damper().key


def test_coulomb_friction_changes_simulated_force_by_expected_amount():
    """With friction mu, the quasi-static force shift equals A_f*mu/(c1+c2) at steady high velocity (linear case)."""
    from duffsym import simulate
    from duffsym.effects import CoulombFriction

    base = duffing_like(1)  # linear: x'' + (gamma+delta) x' + (alpha+beta) x = k1 d + c1 d'
    p = dict(gamma=10.0, alpha=0.0, beta=0.0, delta=0.0, k1=0.0, c1=10.0, A_f=1.0)
    t = np.linspace(0, 2, 2001)
    ramp = {"d": 0.5 * t**2, "d_dot": t}  # d' = t: slowly increasing velocity, x' ~ d' c1/gamma - ...
    y0 = simulate(base, p, t, ramp).y
    model = CoulombFriction().apply(base)
    y1 = simulate(model, {**p, "fric_mu": 2.0}, t, ramp).y
    # once x' >> eps the friction force is -mu: x'' + gamma x' = c1 d' - mu, so y shifts by -mu/gamma
    # (after the start-up transient exp(-gamma t) has decayed: e^-18 at t = 1.8 s)
    np.testing.assert_allclose(y1[-200:] - y0[-200:], -2.0 / 10.0, rtol=1e-6)
