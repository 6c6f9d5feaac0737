"""Effects for command-driven models (issue 17, the Dyke record): a viscous damper in parallel with the fluid
element (``parallel-damping``, field-dependent on a command model) and a field that rises and decays at
different rates (``field-asymmetry``); and the default start of a command model extended by effects. Data
from the independent generator (tests/independent_current_sim.py, numpy only), the effect's term added
to its output by hand."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import independent_current_sim as gen
from duffsym.data.record import Record
from duffsym.effects import CATALOGUE, apply_effects
from duffsym.errors import ModelError
from duffsym.identify import Problem, fit, initial_guess
from duffsym.model import get_model

DISP = gen.Sines((0.45, 0.25, 0.12), (0.7, 1.6, 2.7), (0.0, 1.0, 2.0))
SWITCH = gen.Switching(0.05, 0.95, gen.Sines((1.0, 0.7, 0.5), (0.4, 0.9, 1.4), (0.3, 2.0, 4.0)), sharp=2.0)
#: s12's damper (force grows with the current).
TRUTH = dict(
    c1=4.0,
    c2=20.0,
    c3=400.0,
    k1=20.0,
    k2=300.0,
    k3=0.0,
    A_f=1.0,
    c1_u=40.0,
    c2_u=-10.0,
    c3_u=-300.0,
    k1_u=30.0,
    k2_u=100.0,
    A_f_u=0.0,
    eta=100.0,
)


def _record(extra=lambda g: 0.0, duration=3.0) -> Record:
    g = gen.generate(TRUTH, DISP, SWITCH, dt=0.005, duration=duration, seed=3)
    y = g["y"] + extra(g)
    return Record(t=g["t"], d=g["d"], y=y, d_dot=g["d_dot"], command=g["command"], command_name="current")


def test_parallel_damping_adds_a_field_dependent_viscous_term_on_a_command_model():
    """Analytic: y = A_f (1 + A_f_u u) x' + (pd_c + pd_c_u u) d' on mr-damper-current; y = A_f x' + pd_c d' on
    mr-damper (no field, no slope)."""
    cur = get_model("mr-damper-current")
    m = CATALOGUE["parallel-damping"].apply(cur)
    c, cu = m.param("pd_c").symbol, m.param("pd_c_u").symbol
    u, dd = cur.states[2], cur.input_symbols[1]
    assert sp.expand(m.output - cur.output - (c + cu * u) * dd) == 0
    assert m.rhs == cur.rhs
    base = get_model("mr-damper")
    m0 = CATALOGUE["parallel-damping"].apply(base)
    assert "pd_c_u" not in m0.param_names
    assert sp.expand(m0.output - base.output - m0.param("pd_c").symbol * base.input_symbols[1]) == 0


def test_field_asymmetry_gives_different_rise_and_decay_rates():
    """Analytic: u' = -eta (1 + a) (u - i) while the field rises (i > u, |i - u| >> eps) and -eta (1 - a) (u - i)
    while it decays; only for a model with a field."""
    cur = get_model("mr-damper-current")
    m = CATALOGUE["field-asymmetry"].apply(cur)
    f = sp.lambdify(
        [m.states[2], m.input_symbols[2], m.param("eta").symbol, m.param("fa_a").symbol, m.param("fa_eps").symbol],
        m.rhs[2],
    )
    assert f(0.0, 1.0, 100.0, 0.3, 1e-3) == pytest.approx(100.0 * 1.3 * 1.0)
    assert f(1.0, 0.0, 100.0, 0.3, 1e-3) == pytest.approx(-100.0 * 0.7 * 1.0)
    assert f(0.5, 0.5, 100.0, 0.3, 1e-3) == 0.0
    with pytest.raises(ModelError, match="field"):
        CATALOGUE["field-asymmetry"].apply(get_model("mr-damper"))


def test_command_model_with_an_offset_and_parallel_damping_recovers_both_from_the_default_start():
    """Independent data with a force offset and a field-dependent parallel damper added to the output
    (y += y0 + (c0 + c0_u u) d', u the generator's field): the default start of the extended model (the
    base model's equation-error start, then each effect's guess from its free run) leads the fit to the
    truth: every parameter within 3 standard errors, the fit at the noise (1 %)."""
    y0, c0, c0u = -0.3, 0.2, 0.3
    rec = _record(lambda g: y0 + (c0 + c0u * g["field"]) * g["d_dot"])
    model = apply_effects(get_model("mr-damper-current"), [CATALOGUE["force-offset"], CATALOGUE["parallel-damping"]])
    truth = {**TRUTH, "off_y0": y0, "pd_c": c0, "pd_c_u": c0u}
    start = initial_guess(rec, model, fixed={"A_f": 1.0, "k3": 0.0})
    assert abs(start["off_y0"] - y0) < 0.1, start
    res = fit(Problem(model, rec, fixed={"A_f": 1.0}))
    assert res.success, res.message
    z = {n: (res.params[n] - truth[n]) / res.stderr[n] for n in res.free}
    assert max(abs(v) for v in z.values()) < 3.0, z
    assert res.nrmse < 0.012


def test_parallel_damping_base_output_uses_a_constant_current_label():
    """On a constant-current record (current as a label, no command column) the field is the label:
    the term removed is (pd_c + pd_c_u I) d', as the model adds it."""
    from duffsym.data.record import Record
    from duffsym.effects import CATALOGUE

    t = np.linspace(0.0, 3.0, 601)
    d, v = np.sin(2 * np.pi * t), 2 * np.pi * np.cos(2 * np.pi * t)
    rec = Record(t=t, d=d, d_dot=v, y=v, current=0.5)
    out = CATALOGUE["parallel-damping"].base_output(np.zeros_like(t), rec, {"pd_c": 2.0, "pd_c_u": 4.0})
    np.testing.assert_allclose(out, -(2.0 + 4.0 * 0.5) * v)
