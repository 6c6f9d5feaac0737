"""The rate candidates of issue 23 (duffsym.effects.rate) against an independent numpy RK4 of their written-out
equations (no duffsym import in the reference): the Maxwell branch's force and the field-yield term on a
command-driven model, with the field integrated from the command in numpy."""

from __future__ import annotations

import numpy as np

from duffsym.effects import apply_effects
from duffsym.effects.rate import FieldYield, MaxwellBranch
from duffsym.model import get_model
from duffsym.simulate import simulate
from independent_current_sim import TRUTH, Sines, Switching

DT, T_END = 0.001, 2.0
DISP = Sines((0.5, 0.2), (1.3, 3.1), (0.0, 0.7))
CMD = Switching(0.0, 1.0, Sines((1.0, 0.6), (0.7, 1.9), (-np.pi / 2, 0.3)), sharp=8.0)
MX = dict(mx_k=40.0, mx_k_u=25.0, mx_tau=0.03)
FY = dict(fy_F=0.3, fy_F_u=0.5, fy_eps=0.2)


def _reference(rhs, s0, substeps=10):
    """Fine RK4 of ``rhs(t, s)`` over the samples, analytic inputs at every stage."""
    t = np.arange(0.0, T_END, DT)
    h = DT / substeps
    s = np.array(s0, dtype=float)
    out = np.empty((t.size, s.size))
    out[0] = s
    for k in range(t.size - 1):
        for j in range(substeps):
            t0 = t[k] + j * h
            q1 = rhs(t0, s)
            q2 = rhs(t0 + h / 2, s + h / 2 * q1)
            q3 = rhs(t0 + h / 2, s + h / 2 * q2)
            q4 = rhs(t0 + h, s + h * q3)
            s = s + h / 6 * (q1 + 2 * q2 + 2 * q3 + q4)
        out[k + 1] = s
    return t, out


def _field_and_branch(t_, s):
    """(u, z): u' = -eta (u - i), z' = (k + k_u u) d' - z / tau."""
    u, z = s
    return np.array([-TRUTH["eta"] * (u - CMD(t_)), (MX["mx_k"] + MX["mx_k_u"] * u) * DISP(t_, 1) - z / MX["mx_tau"]])


def _inputs(t):
    return {"d": DISP(t), "d_dot": DISP(t, 1), "command": CMD(t)}


def test_maxwell_branch_matches_independent_integration():
    t, ref = _reference(_field_and_branch, [CMD(np.array([0.0]))[0], 0.0])
    model = apply_effects(get_model("mr-damper-current"), [MaxwellBranch()])
    p = {**TRUTH, **MX}
    tr = simulate(model, p, t, _inputs(t), x0=[0.0, 0.0, ref[0, 0], 0.0])
    z = np.asarray(tr.x)[:, 3]
    assert np.max(np.abs(z - ref[:, 1])) < 1e-3 * np.max(np.abs(ref[:, 1]))
    base = simulate(get_model("mr-damper-current"), TRUTH, t, _inputs(t), x0=[0.0, 0.0, ref[0, 0]])
    assert np.max(np.abs(tr.y - base.y - ref[:, 1])) < 1e-3 * np.max(np.abs(ref[:, 1]))
    assert np.max(np.abs(ref[:, 1])) > 0.2 * np.max(np.abs(base.y))  # the branch is not negligible here


def test_field_yield_matches_written_out_term():
    t, ref = _reference(lambda t_, s: np.array([-TRUTH["eta"] * (s[0] - CMD(t_))]), [CMD(np.array([0.0]))[0]])
    model = apply_effects(get_model("mr-damper-current"), [FieldYield()])
    tr = simulate(model, {**TRUTH, **FY}, t, _inputs(t), x0=[0.0, 0.0, ref[0, 0]])
    base = simulate(get_model("mr-damper-current"), TRUTH, t, _inputs(t), x0=[0.0, 0.0, ref[0, 0]])
    term = (FY["fy_F"] + FY["fy_F_u"] * ref[:, 0]) * np.tanh(DISP(t, 1) / FY["fy_eps"])
    assert np.max(np.abs(tr.y - base.y - term)) < 1e-4 * np.max(np.abs(term))
