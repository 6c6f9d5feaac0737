"""Eq. 1 with an input gain (``duffing-gain``), the input shift on a model driven by F alone, and the
polynomial effects (quadratic stiffness, cubic damping): equations, identifiability, recovery."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from duffsym.data import Record
from duffsym.effects import CATALOGUE, apply_effects
from duffsym.errors import ModelError
from duffsym.model.library import MODELS, duffing, get_model
from duffsym.simulate import simulate

TRUE = dict(gamma=40.0, alpha=1.6e5, beta=6e5, g=1.5e5)


def _sym(model, name):
    return model.param(name).symbol


def test_duffing_default_unchanged():
    m = duffing()
    assert m.name == "duffing" and m.param_names == ("gamma", "alpha", "beta")
    x1, x2 = m.states
    F = m.inputs[0].symbol
    g, a, b = (m.param(n).symbol for n in ("gamma", "alpha", "beta"))
    assert sp.simplify(m.rhs[1] - (F - g * x2 - a * x1 - b * x1**3)) == 0


def test_duffing_gain_equation_and_registry():
    m = get_model("duffing-gain")
    assert "duffing-gain" in MODELS and m.name == "duffing-gain"
    assert m.param_names == ("gamma", "alpha", "beta", "g")
    x1, x2 = m.states
    F = m.inputs[0].symbol
    assert m.inputs[0].signal == "F" and m.output == x1
    expected = _sym(m, "g") * F - _sym(m, "gamma") * x2 - _sym(m, "alpha") * x1 - _sym(m, "beta") * x1**3
    assert sp.simplify(m.rhs[1] - expected) == 0
    with pytest.raises(ModelError):
        get_model("duffing-gain", 5)


def test_duffing_gain_has_no_scaling_symmetry():
    from duffsym.derive.symmetry import find_scaling_symmetry

    assert not find_scaling_symmetry(get_model("duffing-gain")).exists


def test_static_response_solves_the_cubic():
    """A constant force settles at g F = alpha x + beta x^3 (the real root), an analytic reference."""
    m = get_model("duffing-gain")
    t = np.arange(0, 0.6, 1 / 610.35)
    F = 0.2
    tr = simulate(m, m.param_vector(TRUE), t, {"F": np.full(t.size, F)})
    roots = np.roots([TRUE["beta"], 0.0, TRUE["alpha"], -TRUE["g"] * F])
    x_static = float(roots[np.argmin(np.abs(roots.imag))].real)
    assert tr.y[-1] == pytest.approx(x_static, rel=1e-4)


def test_input_shift_on_a_model_driven_by_the_force_alone():
    m = get_model("duffing-gain")
    ext = CATALOGUE["input-shift"].apply(m)
    assert [c.name for c in ext.inputs] == ["F", "F_dot"]
    F, Fd = (c.symbol for c in ext.inputs)
    tau = _sym(ext, "shift_tau")
    assert sp.simplify(ext.rhs[1] - m.rhs[1].subs(F, F - tau * Fd)) == 0
    # a model that has the rate already keeps the former behaviour (rate shifted by the acceleration)
    dl = CATALOGUE["input-shift"].apply(get_model("duffing-like"))
    assert [c.name for c in dl.inputs] == ["d", "d_dot", "d_ddot"]


def test_polynomial_effects_equations():
    m = get_model("duffing-gain")
    x1, x2 = m.states
    q = CATALOGUE["quadratic-stiffness"].apply(m)
    c = CATALOGUE["cubic-damping"].apply(m)
    assert sp.simplify(q.rhs[1] - (m.rhs[1] - _sym(q, "quad_k") * x1**2)) == 0
    assert sp.simplify(c.rhs[1] - (m.rhs[1] - _sym(c, "cdamp_c") * x2**3)) == 0
    # applicable to the MR damper too (mechanical states), not twice
    CATALOGUE["cubic-damping"].apply(get_model("mr-damper"))
    with pytest.raises(ModelError):
        CATALOGUE["cubic-damping"].apply(c)


def test_input_curvature_equation_and_guess():
    m = get_model("duffing-gain")
    e = CATALOGUE["input-curvature"]
    ext = e.apply(m)
    assert [c.name for c in ext.inputs] == ["F", "F_ddot"]
    F, Fdd = (c.symbol for c in ext.inputs)
    assert sp.simplify(ext.rhs[1] - m.rhs[1].subs(F, F + _sym(ext, "curv_k") * Fdd)) == 0
    # with a rate channel already there (input-shift first): only F is corrected, F_ddot not duplicated
    both = apply_effects(m, [CATALOGUE["input-shift"], e])
    assert [c.name for c in both.inputs] == ["F", "F_dot", "F_ddot"]
    rec = _record(m, TRUE, n=200)
    assert e.initial_guess(rec, rec.y) == {"curv_k": pytest.approx(-(rec.dt**2) / 12)}


def test_linear_interpolation_flattening_is_what_curvature_restores():
    """The reasoning of input-curvature, checked numerically: the linear interpolant of a sampled
    sine of theta rad per sample carries it with amplitude sinc^2(theta/2) ~ 1 - theta^2/12."""
    dt, theta = 1.0, 0.8
    t = np.arange(0, 4096) * dt
    fine = np.linspace(0, t[-1], 64 * t.size)
    lin = np.interp(fine, t, np.sin(theta * t))
    amp = 2 * abs(np.mean(lin * np.exp(-1j * theta * fine)))
    assert amp == pytest.approx(np.sinc(theta / 2 / np.pi) ** 2, rel=2e-3)
    assert amp == pytest.approx(1 - theta**2 / 12, abs=0.01)


def _record(model, params, n=1500, noise=0.0, seed=0):
    rng = np.random.default_rng(seed)
    dt = 1 / 610.35
    t = np.arange(n) * dt
    # a band-limited random force (sum of sines up to 120 Hz)
    f = np.arange(1, 121, 3.0)
    ph = rng.uniform(0, 2 * np.pi, f.size)
    F = 0.08 * np.sum(np.sin(2 * np.pi * f[:, None] * t[None, :] + ph[:, None]), axis=0) / np.sqrt(f.size / 2)
    tr = simulate(model, model.param_vector(params), t, {"F": F})
    y = tr.y + noise * rng.standard_normal(n)
    return Record(t=t, d=F, y=y, units={"t": "s", "d": "V", "y": "V"}, name="synthetic silverbox-like")


def test_fit_recovers_duffing_gain_and_cubic_damping():
    """Synthetic Silverbox-like data (610 Hz, force to 120 Hz) with a hidden cubic damping: the
    extended model's fit recovers all five parameters; the base model cannot reach the noise."""
    from duffsym.identify import Problem, fit

    ext = apply_effects(get_model("duffing-gain"), [CATALOGUE["cubic-damping"]])
    truth = dict(TRUE, cdamp_c=2e-3)
    rec = _record(ext, truth, noise=2e-4)
    base = fit(Problem(get_model("duffing-gain"), rec), max_iter=200)
    start = {**base.params, "cdamp_c": 0.0}
    r = fit(Problem(ext, rec), start, max_iter=200)
    assert r.success
    for k, v in truth.items():
        assert r.params[k] == pytest.approx(v, rel=0.05), k
    assert r.nrmse < 0.5 * base.nrmse
