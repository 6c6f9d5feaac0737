"""The compiled implicit integrator (ROS2) and the explicit path's reported fallback to it, against
independent references: closed forms, scipy's Radau, and the real Dyke record (skipped without it).
A truly unstable parameter set must still be reported as a divergence."""

from __future__ import annotations

import math

import numpy as np
import pytest

from _external import DYKE_CSV, external_file
from duffsym.data import read_csv
from duffsym.excitation import Sine
from duffsym.model.library import duffing, mr_damper
from duffsym.model.presets import (
    TABLE2_DT,
    TABLE2_FREQUENCY_HZ,
    TABLE2_N,
    table2_params,
)
from duffsym.simulate import simulate, simulate_batch

REF_TOL = dict(rtol=1e-8, atol=1e-10)


def max_rel(y, ref):
    return float(np.max(np.abs(y - ref)) / np.max(np.abs(ref)))


@pytest.fixture(scope="module")
def table2():
    return mr_damper(TABLE2_N), np.arange(400) * TABLE2_DT, Sine(1.0, TABLE2_FREQUENCY_HZ)


def _damped(t, gamma, omega0, x0):
    """Closed form of x'' + gamma x' + omega0^2 x = 0 from (x0, 0), under- or anti-damped."""
    wd = math.sqrt(omega0**2 - gamma**2 / 4)
    return x0 * np.exp(-gamma * t / 2) * (np.cos(wd * t) + gamma / (2 * wd) * np.sin(wd * t))


def test_rosenbrock_matches_closed_form_of_linear_oscillator():
    model = duffing()
    t = np.arange(0.0, 5.0, 0.01)
    p = dict(gamma=0.6, alpha=40.0, beta=0.0)
    traj = simulate(model, p, t, np.zeros(t.size), x0=[1.0, 0.0], method="rosenbrock")
    assert traj.success and traj.method == "rosenbrock" and traj.fallback == ""
    assert max_rel(traj.y, _damped(t, 0.6, math.sqrt(40.0), 1.0)) < 2e-3  # measured 6.7e-4


def test_rosenbrock_fixed_steps_converge_at_second_order():
    """Halving a fixed step divides the error by ~4 (ROS2 is second order)."""
    model = duffing()
    t = np.arange(0.0, 5.0, 0.05)
    p = dict(gamma=0.6, alpha=40.0, beta=0.0)
    exact = _damped(t, 0.6, math.sqrt(40.0), 1.0)
    errs = [
        max_rel(simulate(model, p, t, np.zeros(t.size), x0=[1.0, 0.0], method="rosenbrock", substeps=m).y, exact)
        for m in (4, 8, 16)
    ]
    assert 3.0 < errs[0] / errs[1] < 5.5 and 3.0 < errs[1] / errs[2] < 5.5, errs


@pytest.mark.parametrize("voltage", [0.0, 0.4, 0.8])
def test_rosenbrock_matches_radau_on_table2(table2, voltage):
    model, t, exc = table2
    p = table2_params(voltage)
    ref = simulate(model, p, t, exc, method="radau", **REF_TOL)
    ros = simulate(model, p, t, exc, method="rosenbrock")
    assert max_rel(ros.y, ref.y) < 2e-4


def test_fallback_is_taken_and_reported_when_rk4_stops(table2):
    """An explicit run that stops (here: a substep budget too small for the stiffness) is redone
    implicitly, and the trajectory says so; the answer is Radau's."""
    model, t, exc = table2
    p = table2_params(0.4)
    rk4 = simulate(model, p, t, exc, method="rk4", max_substeps=3, on_failure="return")
    assert rk4.status == "too stiff"
    auto = simulate(model, p, t, exc, max_substeps=3)  # default method "auto"
    assert auto.success and auto.method == "rosenbrock"
    assert "explicit RK4 stopped (too stiff" in auto.fallback and auto.integrator["method"] == "rosenbrock"
    ref = simulate(model, p, t, exc, method="radau", **REF_TOL)
    assert max_rel(auto.y, ref.y) < 2e-4
    plain = simulate(model, p, t, exc)  # where RK4 is accurate it stays the path taken
    assert plain.method == "rk4" and plain.fallback == "" and plain.integrator["method"] == "rk4"


def test_unstable_parameters_are_still_a_divergence(table2):
    """c3 < 0 (energy injected like x'^6): the true solution escapes; both integrators say so."""
    model, t, exc = table2
    p = table2_params(0.4)
    p["c3"] = -300.0
    traj = simulate(model, p, t, exc, on_failure="return")
    assert not traj.success and traj.status == "blow-up" and traj.method == "rosenbrock"
    assert "failed too" in traj.fallback and "diverges" in traj.message
    batch = simulate_batch(model, np.array([model.param_vector(p), model.param_vector(table2_params(0.4))]), t, exc)
    assert list(batch.status) == [1, 0]


def test_rosenbrock_follows_exponential_growth_to_blow_up():
    """An L-stable method with large steps could damp a growing mode away; error control must not:
    x'' - 2 x' + 40 x = 0 grows like e^t. It is followed to t = 10 and reported as a blow-up."""
    model = duffing()
    t = np.arange(0.0, 30.0, 0.05)
    p = dict(gamma=-2.0, alpha=40.0, beta=0.0)
    traj = simulate(model, p, t, np.zeros(t.size), x0=[1.0, 0.0], method="rosenbrock", on_failure="return")
    assert traj.status == "blow-up" and 15.0 < t[traj.failed_at] < 22.0
    k = np.searchsorted(t, 10.0)
    exact = _damped(t[:k], -2.0, math.sqrt(40.0), 1.0)
    assert max_rel(traj.y[:k], exact) < 2e-2  # measured 5.4e-3 after growing e^10-fold


# ---------------------------------------------------------------- the real Dyke record
# A fit of the base model to 5 s of the Dyke record (samples 30 000-45 000, velocity derived from the
# displacement) and its initial state: the explicit RK4 reports its free run "too stiff ... probably
# diverging" at sample 0 (its substep controller trusts the end state of an under-resolved trial
# step, which asks for more than max_substeps); Radau completes it with |x| <= 0.64, and so does the
# default method="auto" through its reported fallback to ROS2.
DYKE_PARAMS = {
    "c1": 105.54754844447353,
    "c2": 516.0838990034977,
    "c3": 57301.30922766054,
    "k1": 76.61471716713335,
    "k2": 46.642636473388485,
    "k3": 0.0,
    "A_f": 1863.1959,
}
DYKE_X0 = [0.42873573695978767, -0.24877170783700148]
FS = 3004.8


def _dyke_slice(tmp_path, a, b):
    src = external_file(*DYKE_CSV)
    import csv

    rows = [r for r in csv.reader(open(src)) if r][1:][a:b]
    p = tmp_path / "dyke.csv"
    p.write_text("time,displacement,force\n" + "".join(f"{(a + k) / FS!r},{r[2]},{r[6]}\n" for k, r in enumerate(rows)))
    return read_csv(p)


def _dyke_runs(tmp_path, n):
    """The first ``n`` samples of the 15 000 (the velocity derived from the whole slice, as the fit had it)."""

    model = mr_damper(5)
    rec = _dyke_slice(tmp_path, 30_000, 45_000)
    U = rec.input_matrix(model)[:n]
    t, y = np.asarray(rec.t)[:n], np.asarray(rec.y)[:n]
    ref = simulate(model, DYKE_PARAMS, t, U, x0=DYKE_X0, method="radau", rtol=1e-9, atol=1e-11)
    assert ref.success and np.abs(ref.x).max() < 1.0
    runs = {
        m: simulate(model, DYKE_PARAMS, t, U, x0=DYKE_X0, method=m, on_failure="return")
        for m in ("auto", "rk4", "rosenbrock")
    }
    return y, ref, runs


def test_dyke_start_is_no_false_blow_up(tmp_path):
    y, ref, runs = _dyke_runs(tmp_path, 300)
    scale = np.std(y)
    assert runs["rk4"].status == "too stiff" and runs["rk4"].failed_at == 0  # the explicit path's false failure
    auto = runs["auto"]
    assert auto.success and auto.method == "rosenbrock" and "explicit RK4 stopped (too stiff" in auto.fallback
    assert np.max(np.abs(auto.y - ref.y)) / scale < 1e-3  # measured 2.4e-4
    assert np.max(np.abs(runs["rosenbrock"].y - auto.y)) == 0.0


@pytest.mark.slow
def test_dyke_five_seconds_agree_with_radau(tmp_path):
    """Measured: max |y - y_Radau| / std(y) = 3.5e-4 for the default run (ROS2 after the RK4 stop)."""
    y, ref, runs = _dyke_runs(tmp_path, 15_000)
    scale = np.std(y)
    assert runs["auto"].success and runs["auto"].method == "rosenbrock"
    assert np.max(np.abs(runs["auto"].y - ref.y)) / scale < 1e-3


def test_sampler_kernel_follows_the_stiff_dyke_record(tmp_path):
    """The uncertainty sampler's compiled kernel is explicit, but on the substep schedule it derives from
    the stiffness along the fit's trajectory (h rho(J) <= 1) it follows the record where the default
    explicit free run stops at sample 0: measured max |y - y_Radau| / std(y) = 2.6e-4 over 3000 samples."""
    from duffsym.uncertainty import _kernel, _setup

    model, n = mr_damper(5), 1000
    rec = _dyke_slice(tmp_path, 30_000, 45_000)
    U, t = rec.input_matrix(model)[:n], np.asarray(rec.t)[:n]
    p, x0 = model.param_vector(DYKE_PARAMS), np.asarray(DYKE_X0)
    ref = simulate(model, p, t, U, x0=x0, method="radau", rtol=1e-9, atol=1e-11)
    sched, _ = _setup.stiffness_schedule(model, p, t, U, x0, h_rho=1.0)
    sim = _kernel.ScheduleSimulator(model, t, U, x0, sched, hold=False, hrho_max=2.0)
    Y, status, _, hrho = sim.run(p[None, :], x0[None, :])
    assert status[0] == 0 and hrho[0] <= 1.0 + 1e-9
    assert np.max(np.abs(Y[0] - ref.y)) / np.std(ref.y) < 1e-3
