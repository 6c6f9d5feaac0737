"""The scaling symmetry x -> s x, found from the model, against the hand-derived transform and
against simulation."""

import numpy as np
import pytest
import sympy as sp

from duffsym import Sine, simulate
from duffsym.derive import find_scaling_symmetry, normalize_af
from duffsym.errors import ModelError
from duffsym.model import ParamSpec, duffing, duffing_like, mr_damper
from duffsym.model.library import N_SYMBOL
from duffsym.model.presets import TABLE2, TABLE2_N

s = sp.Symbol("s", positive=True)
c1, c2, c3, k1, k2, k3, A_f = sp.symbols("c1 c2 c3 k1 k2 k3 A_f", real=True)
gamma, alpha, beta, delta = sp.symbols("gamma alpha beta delta", real=True)


def mr_hand(n):
    """Hand-derived: x -> s x needs c1, k1 -> s c1, s k1 (input terms scale with x), c1 + c2 and k1 + k2
    unchanged (linear terms), n-th power terms times s^(1-n), and A_f -> A_f / s (y = A_f x')."""
    return {
        "c1": s * c1,
        "c2": c1 + c2 - s * c1,
        "k1": s * k1,
        "k2": k1 + k2 - s * k1,
        "c3": c3 * s ** (1 - n),
        "k3": k3 * s ** (1 - n),
        "A_f": A_f / s,
    }


@pytest.mark.parametrize("n", [5, 3, N_SYMBOL])
def test_mr_damper_symmetry_matches_hand_derivation(n):
    sym = find_scaling_symmetry(mr_damper(n))
    assert sym.exists
    for name, expr in mr_hand(n).items():
        assert sp.simplify(sym.mapping[name] - expr) == 0, name
    # design.md's form is the same family with s -> 1/s
    design = {"c1": c1 / s, "A_f": A_f * s, "c3": c3 * s ** (n - 1)}
    for name, expr in design.items():
        assert sp.simplify(sym.mapping[name].subs(s, 1 / s) - expr) == 0


def test_duffing_like_symmetry():
    sym = find_scaling_symmetry(duffing_like(3))
    hand = {
        "gamma": gamma,
        "alpha": alpha,
        "beta": beta / s**2,
        "delta": delta / s**2,
        "k1": s * k1,
        "c1": s * c1,
        "A_f": A_f / s,
    }
    for name, expr in hand.items():
        assert sp.simplify(sym.mapping[name] - expr) == 0, name
    assert sym.tangent["gamma"] == 0 and sp.simplify(sym.tangent["beta"] + 2 * beta) == 0


def test_no_symmetry_when_the_output_or_a_term_fixes_the_scale():
    assert not find_scaling_symmetry(duffing()).exists  # output is x itself, and F enters with gain 1
    base = mr_damper(5)
    mu = ParamSpec("t_mu", r"\mu", 1.0, 0.0, 10.0)
    fric = base.extend(
        effect="friction", params=(mu,), rhs_add={base.velocity: -mu.symbol * sp.tanh(base.velocity / sp.Float(0.01))}
    )
    sym = find_scaling_symmetry(fric)
    assert not sym.exists
    with pytest.raises(ModelError, match="no scaling symmetry"):
        sym.apply(TABLE2[0.4] | {"t_mu": 1.0}, 2.0)
    # with eps a parameter the friction scales too: eps -> s eps, mu -> s mu
    eps = ParamSpec("t_eps", r"\varepsilon", 0.01, 1e-6, 1.0)
    fric2 = base.extend(
        effect="friction", params=(mu, eps), rhs_add={base.velocity: -mu.symbol * sp.tanh(base.velocity / eps.symbol)}
    )
    sym2 = find_scaling_symmetry(fric2)
    assert sym2.exists
    assert sp.simplify(sym2.mapping["t_eps"] - s * eps.symbol) == 0
    assert sp.simplify(sym2.mapping["t_mu"] - s * mu.symbol) == 0


def test_transformed_parameters_give_the_same_output():
    model = mr_damper(TABLE2_N)
    sym = find_scaling_symmetry(model)
    row = TABLE2[0.4]
    t = np.arange(0.0, 2.0, 0.005)
    exc = Sine(1.0, 2.0)
    y0 = simulate(model, row, t, exc, substeps=4)
    for scale in (2.5, 0.4):
        p = sym.apply(row, scale)
        assert p["A_f"] == pytest.approx(row["A_f"] / scale, rel=1e-15)
        tr = simulate(model, p, t, exc, substeps=4)
        assert np.max(np.abs(tr.y - y0.y)) <= 1e-12 * np.max(np.abs(y0.y))
        assert np.allclose(tr.x, scale * y0.x, rtol=1e-11, atol=1e-13)  # the hidden state scales


def test_normalize_af():
    model = mr_damper(TABLE2_N)
    row = TABLE2[0.8]
    p = normalize_af(model, row, 1.0)
    assert p["A_f"] == pytest.approx(1.0, rel=1e-14)
    assert p["c1"] == pytest.approx(row["c1"] * 2.0, rel=1e-14)  # s = A_f / target = 2
    assert p["c1"] + p["c2"] == pytest.approx(row["c1"] + row["c2"], rel=1e-14)
    t = np.arange(0.0, 1.0, 0.005)
    a = simulate(model, row, t, Sine(1.0, 2.0), substeps=4).y
    b = simulate(model, p, t, Sine(1.0, 2.0), substeps=4).y
    assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(a))
    with pytest.raises(ModelError, match="same sign"):
        normalize_af(model, row, -1.0)
