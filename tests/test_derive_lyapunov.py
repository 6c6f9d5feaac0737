"""Lyapunov functions (Eq. 6, 8) and their derivatives (Eq. 7, 9), derived from the models and
compared with the paper's results typed here independently."""

import sympy as sp

from duffsym.derive import energy_lyapunov, lyapunov_analysis, state_based_lyapunov, time_derivative
from duffsym.model import ParamSpec, duffing, duffing_like, mr_damper
from duffsym.model.library import N_SYMBOL

x1, x2 = sp.symbols("x1 x2", real=True)
d, d_dot = sp.symbols("d d_dot", real=True)
gamma, alpha, beta, delta, k1, c1 = sp.symbols("gamma alpha beta delta k1 c1", real=True)
c2, c3, k2, k3, m = sp.symbols("c2 c3 k2 k3 m", real=True)


def same(a, b):
    return sp.simplify(sp.powsimp(sp.expand(a - b), combine="exp")) == 0


def paper_v(a, b, n):
    """Eq. 6 = Eq. 8 as printed: alpha/2 x^2 + 1/2 x'^2 + beta/(n+1) x^(n+1)."""
    return a / 2 * x1**2 + x2**2 / 2 + b / (n + 1) * x1 ** (n + 1)


def test_duffing_like_eq6_eq8_eq7_integer_and_symbolic_n():
    for n in (3, 5, N_SYMBOL):
        lya = lyapunov_analysis(duffing_like(n))
        assert same(lya.v_state, paper_v(alpha, beta, n))
        assert same(lya.v_energy, paper_v(alpha, beta, n))
        assert lya.identical
        assert same(lya.v_dot, -gamma * x2**2 - delta * x2 ** (n + 1))
        assert same(lya.v_dot_forced, -gamma * x2**2 - delta * x2 ** (n + 1) + (k1 * d + c1 * d_dot) * x2)
        assert same(lya.forcing, k1 * d + c1 * d_dot)
        assert lya.P == sp.Matrix([[alpha, 0], [0, 1]])


def test_mr_damper_with_gamma_c1_plus_c2():
    for n in (5, N_SYMBOL):
        lya = lyapunov_analysis(mr_damper(n))
        assert same(lya.v_energy, paper_v(k1 + k2, k3, n))
        assert same(lya.v_state, lya.v_energy)
        assert same(lya.v_dot, -(c1 + c2) * x2**2 - c3 * x2 ** (n + 1))
        assert same(lya.restoring, (k1 + k2) * x1 + k3 * x1**n)


def test_physical_mr_damper_energy_per_unit_mass():
    lya = lyapunov_analysis(mr_damper(5, physical=True))
    assert same(lya.v_energy, x2**2 / 2 + ((k1 + k2) / 2 * x1**2 + k3 / 6 * x1**6) / m)
    assert same(lya.v_dot, -((c1 + c2) * x2**2 + c3 * x2**6) / m)


def test_chain_rule_matches_a_direct_time_derivative_on_a_trajectory():
    # independent check of time_derivative: d/dt V(x(t)) along x(t) solving the unforced ODE, by sympy series
    model = duffing_like(3)
    V = energy_lyapunov(model)
    Vdot = time_derivative(model, V)
    vals = {alpha: 2, beta: 3, gamma: sp.Rational(1, 2), delta: 5, k1: 1, c1: 1}
    t = sp.Symbol("t")
    # Taylor expansion of the solution from x = 1/2, x' = -1/3 to second order
    f = sp.Lambda((x1, x2), model.rhs[1].subs({d: 0, d_dot: 0}).subs(vals))
    x0, v0 = sp.Rational(1, 2), -sp.Rational(1, 3)
    a0 = f(x0, v0)
    xt = x0 + v0 * t + a0 * t**2 / 2
    vt = v0 + a0 * t
    dVdt = sp.diff(V.subs(vals).subs({x1: xt, x2: vt}), t).subs(t, 0)
    assert sp.simplify(dVdt - Vdot.subs(vals).subs({x1: x0, x2: v0})) == 0


def test_duffing_equation_one():
    lya = lyapunov_analysis(duffing())
    assert same(lya.v_energy, paper_v(alpha, beta, 3))
    assert same(lya.v_dot, -gamma * x2**2)


def test_extra_friction_term_adds_a_nonpositive_contribution():
    base = mr_damper(5)
    mu = ParamSpec("t_mu", r"\mu", 1.0, 0.0, 10.0)
    eps = ParamSpec("t_eps", r"\varepsilon", 0.01, 1e-6, 1.0)
    model = base.extend(
        effect="test-friction",
        params=(mu, eps),
        rhs_add={base.velocity: -mu.symbol * sp.tanh(base.velocity / eps.symbol)},
    )
    lya = lyapunov_analysis(model)
    expected = -(c1 + c2) * x2**2 - c3 * x2**6 - mu.symbol * x2 * sp.tanh(x2 / eps.symbol)
    assert same(lya.v_dot, expected)
    V, _ = state_based_lyapunov(model)
    assert same(V, lyapunov_analysis(base).v_energy)  # the friction does not change V
    fric = [t for t in lya.dissipation_terms if t.force.has(sp.tanh)]
    assert len(fric) == 1
    assert fric[0].shape_nonnegative is True
    assert fric[0].assumptions == (eps.symbol,)  # decided taking eps > 0
    assert sp.simplify(fric[0].condition.lhs - mu.symbol) == 0 and fric[0].condition.rel_op == ">="


def test_position_equation_must_be_kinematic():
    import pytest

    from duffsym.errors import ModelError

    base = duffing_like(3)
    bad = base.extend(effect="drift", rhs_add={base.position: sp.Integer(1) * base.position})
    with pytest.raises(ModelError, match="position equation"):
        lyapunov_analysis(bad)
