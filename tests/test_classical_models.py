"""The classical models (duffsym.model.classical): simulation against an independent Radau run of the exact
nonsmooth laws, parameter recovery from independent records within the standard errors, and the UTFSM authors'
published Spencer parameters re-simulated to their quoted errors."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

import independent_classical_sim as ics
from _external import external_file
from duffsym.data import Record
from duffsym.errors import ModelError
from duffsym.identify import Problem, fit
from duffsym.identify.result import nrmse
from duffsym.model import get_model
from duffsym.model.classical import abs_power, bouc_wen, lugre, smooth_abs, smooth_sign
from duffsym.simulate import simulate

SLOW_DRIVE = ics.Sines((0.1, 0.04), (0.7, 2.1), (0.3, 1.1))  # friction tests (m, m/s)
DAMPER_DRIVE = ics.Sines((1.0, 0.4), (1.5, 4.1), (0.3, 1.1))  # damper tests (cm, cm/s)
#: Spencer's Table 1 with a wider Bouc-Wen transition (gamma, beta / 100, A / 10, alpha rescaled), resolved
#: at 500 Hz: with their gamma = 363 cm^-2 the transition after a reversal spans 0.04 mm of stroke.
SPENCER_TRUTH = dict(get_model("spencer").defaults(), alpha=44.0, alpha_u=220.0, gamma=3.63, beta=3.63, A=30.1)
TRUTH = {
    "bouc-wen": dict(c0=20.0, k0=40.0, x0=0.0, A=4e4, gamma=0.015, beta=0.01),
    "dahl": dict(sigma0=50.0, Fc=2.0, sigma2=0.5),
    "lugre": dict(sigma0=1e3, sigma1=5.0, sigma2=0.5, Fc=1.0, Fs=1.5, vs=0.05),
    "bingham": dict(fc=600.0, c0=40.0, f0=-50.0),
    "biviscous": dict(c_pr=800.0, c_po=40.0, fy=500.0, f0=20.0),
    "spencer": SPENCER_TRUTH,
}


def _command(name):
    return (lambda t: 0.5 + 0.45 * np.sin(2 * np.pi * 0.7 * t + 0.2)) if name == "spencer" else None


def _drive(name):
    return SLOW_DRIVE if name in ("dahl", "lugre") else DAMPER_DRIVE


def test_smooth_forms_are_explicit_and_close():
    v = sp.Symbol("v", real=True)
    assert smooth_abs(v, 1e-3).subs(v, 0) == pytest.approx(1e-3)
    assert float(smooth_abs(v, 1e-3).subs(v, -2.0)) == pytest.approx(2.0, abs=1e-6)
    assert float(smooth_sign(v, 1e-3).subs(v, 0.01)) == pytest.approx(1.0, abs=1e-8)
    assert abs_power(v, 2, 1e-3) == v**2  # an even power is exact
    with pytest.raises(ModelError, match="positive number"):
        smooth_abs(v, 0.0)
    assert "sqrt(d'^2 + 0.001^2)" in get_model("bouc-wen").description


@pytest.mark.parametrize("name", ["bouc-wen", "spencer", "dahl", "lugre", "bingham", "biviscous"])
def test_simulation_matches_independent_radau_of_the_exact_law(name):
    """duffsym's compiled run of the smooth form against scipy Radau of the sharp law (eps 1e-5 for LuGre,
    whose Stribeck velocity here is 1e-3 m/s: its default eps 1e-3 is not small against it, 3 % error)."""
    model = lugre(eps=1e-5) if name == "lugre" else get_model(name)
    p = TRUTH[name] if name != "lugre" else model.defaults()
    drive, cmd = _drive(name), _command(name)
    t = np.arange(0.0, 1.0, 1e-3)
    _, y_ref = ics.simulate(name, p, t, drive, cmd, rtol=1e-8, atol=1e-10, max_step=2e-3)
    U = {"d": drive(t), "d_dot": drive(t, 1)}
    x0 = np.zeros(model.n_states)
    if cmd is not None:
        U["command"] = cmd(t)
        x0[2] = cmd(np.asarray(0.0))
    tr = simulate(model, p, t, U, x0=x0)
    assert tr.success
    assert nrmse(y_ref, tr.y) < {"dahl": 5e-3, "lugre": 5e-3}.get(name, 1e-3)


def test_bouc_wen_general_exponent_matches_radau():
    p = dict(TRUTH["bouc-wen"], gamma=0.02, beta=0.01, A=4e4)
    n = 1.5
    p15 = dict(p, gamma=p["gamma"] * 60.0, beta=p["beta"] * 60.0)  # keeps z's bound near the n = 2 one
    t = np.arange(0.0, 1.0, 1e-3)
    _, y_ref = ics.simulate("bouc-wen", p15, t, DAMPER_DRIVE, n=n, rtol=1e-8, atol=1e-10, max_step=2e-3)
    model = bouc_wen(n)
    assert dict(model.structural)["n"] == sp.Rational(3, 2)
    tr = simulate(model, p15, t, {"d": DAMPER_DRIVE(t), "d_dot": DAMPER_DRIVE(t, 1)})
    assert nrmse(y_ref, tr.y) < 1e-3


def test_models_without_an_exponent_refuse_n():
    with pytest.raises(ModelError, match="no exponent"):
        get_model("dahl", 3)
    with pytest.raises(ModelError, match=r"\[1, 25\]"):
        get_model("bouc-wen", 0.5)


def _record(name, fs=500.0, duration=3.0, seed=0):
    t, d, v, c, y, _ = ics.record(
        name, TRUTH[name], duration=duration, fs=fs, drive=_drive(name), command=_command(name), noise=0.01, seed=seed
    )
    cmd = {"command": c, "command_name": "voltage"} if name == "spencer" else {}
    return Record(t=t, d=d, y=y, d_dot=v, name=f"independent {name}", **cmd)


def _check_recovery(name, fixed=None, fs=500.0):
    truth = TRUTH[name]
    start = {k: v * 1.5 for k, v in truth.items() if k not in (fixed or {})}
    rec = _record(name, fs=fs)
    model = get_model(name)
    res = fit(Problem(model, rec, fixed=fixed), start)
    assert res.success, res.message
    # the floor: the smooth form at the true parameters (1 % noise; the Bingham tanh misses 3 samples within
    # a few eps of a reversal by ~400 N: 0.019)
    x0 = np.zeros(model.n_states)
    if name == "spencer":
        x0[2] = rec.command[0]
    floor = nrmse(rec.y, simulate(model, truth, rec.t, rec.inputs_for(model), x0=x0).y)
    assert 0.0095 < floor < 0.025
    assert res.nrmse <= 1.01 * floor
    for k in res.free:
        se = res.stderr[k]
        assert math.isfinite(se) and se > 0
        assert abs(res.params[k] - truth[k]) < 3.0 * se, (k, res.params[k], truth[k], se)
    return res


@pytest.mark.parametrize("name", ["bouc-wen", "dahl", "bingham"])
def test_recovers_known_parameters(name):
    _check_recovery(name, fixed={"x0": 0.0} if name == "bouc-wen" else None)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["lugre", "biviscous", "spencer"])
def test_recovers_known_parameters_slow(name):
    # Spencer at 400 Hz: converges in ~11 s (idle machine); the same record at 500 Hz hit IPOPT's 500-iteration
    # limit from this start (measured once, 463 s under load) - the collocation fit of Spencer's model is not robust
    res = _check_recovery(
        name, fixed={"A": 30.1} if name == "spencer" else None, fs=400.0 if name == "spencer" else 500.0
    )
    if name == "spencer":
        assert res.params["eta"] == pytest.approx(190.0, rel=0.15)


@pytest.mark.slow
@pytest.mark.ci
def test_spencer_holds_A_by_its_scaling_symmetry():
    rec = _record("spencer", duration=0.2)
    prob = Problem(get_model("spencer"), rec)
    assert "A" not in prob.free and prob.fixed["A"] == 301.0
    assert "alpha" in prob.defaults_applied["A"]
    assert "A" in Problem(get_model("spencer"), rec, free=["A", "alpha"]).free


#: The UTFSM authors' Spencer fit (design.md): p1..p12, A = 300, n = 2, gamma = beta = p7 exp(p8 i).
UTFSM_P = [1.50e-4, 1.239, 2.31e-3, -38.15, 41.51, 15.22, 1.894, -3.656, 7.626, 0.925, 78.34, 9.867]


def utfsm_params(i: float) -> dict:
    p1, p2, p3, p4, p5, p6, p7, p8, p9, p10, p11, p12 = UTFSM_P
    g = p7 * math.exp(p8 * i)
    return dict(
        alpha=p4 * i * i + p5 * i + p6,
        alpha_u=0.0,
        c0=p9 * i + p10,
        c0_u=0.0,
        c1=p11 * i + p12,
        c1_u=0.0,
        k0=p1,
        k1=p2,
        x0=p3,
        gamma=g,
        beta=g,
        A=300.0,
        eta=190.0,
    )


@pytest.mark.parametrize(
    "test_name, current, quoted, tol",
    [
        ("5mm3Hz1A", 1.0, 0.079, 0.003),
        ("10mm1Hz0x5A", 0.5, 0.118, 0.003),
        ("25mm0x1Hz0A", 0.0, 0.247, 0.003),
        ("2mm5Hz0A", 0.0, 0.169, 0.01),
    ],
)
def test_utfsm_published_spencer_parameters_reproduce_their_errors(test_name, current, quoted, tol):
    """An independent check of the Spencer implementation: the authors' parameters, re-simulated from rest on
    the full-rate record (their coefficients evaluated at the test's current), give their quoted NRMSE
    (2 mm 5 Hz, sampled at 200 Hz, reaches 0.178: 0.009 above, the input reconstruction between samples)."""
    from duffsym.data import load_mr_damper_utfsm

    path = external_file("mr_damper_utfsm_quiroz2022", "sinusoidal_preprocessed", f"{test_name}.txt")
    rec = load_mr_damper_utfsm(path, velocity="derive")
    model = get_model("spencer")
    tr = simulate(model, utfsm_params(current), rec.t, rec.inputs_for(model), x0=np.array([0.0, 0.0, current]))
    assert nrmse(rec.y, tr.y) == pytest.approx(quoted, abs=tol)
