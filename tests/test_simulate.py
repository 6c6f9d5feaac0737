"""The simulator against independent references: scipy's Radau, closed forms of the linear
oscillator, conservation laws and symmetries; and its failure reports and input checks."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from duffsym.errors import DataError, ModelError, SimulationError
from duffsym.excitation import BandLimitedRandom, Sine
from duffsym.model.library import duffing, duffing_like, mr_damper
from duffsym.model.presets import TABLE2, TABLE2_DT, TABLE2_FREQUENCY_HZ, TABLE2_N, table2_params
from duffsym.simulate import simulate, simulate_batch, steady_cycle

# a tight reference: Radau at rtol 1e-8 agrees with rtol 1e-10 to 5e-11 on these trajectories
REF_TOL = dict(rtol=1e-8, atol=1e-10)


def max_rel(y, ref):
    return float(np.max(np.abs(y - ref)) / np.max(np.abs(ref)))


def tolerance_scaled(y, y_true, rtol, atol):
    """SciPy test_ivp's error measure: |y - y_true| / (atol + rtol |y_true|), should stay < 5."""
    return np.abs(y - y_true) / (atol + rtol * np.abs(y_true))


@pytest.fixture(scope="module")
def table2_setup():
    model = mr_damper(TABLE2_N)
    t = np.arange(400) * TABLE2_DT
    return model, t, Sine(1.0, TABLE2_FREQUENCY_HZ)


# ------------------------------------------------------------------- (a) RK4 vs Radau, Table 2
def _check_table2_row(setup, voltage):
    model, t, exc = setup
    p = table2_params(voltage)
    rk4 = simulate(model, p, t, exc)
    ref = simulate(model, p, t, exc, method="radau", **REF_TOL)
    err = max_rel(rk4.y, ref.y)
    assert err <= 1e-3, f"{voltage} V: max relative error {err:.2e}"
    # cost: the stiffness-aware count stays near what h*rho <= 0.6 needs (about 4.5 per sample)
    assert rk4.substeps.min() >= 1 and rk4.substeps.sum() <= 2000, rk4.substeps.sum()
    # and the stiffness is real: a single step per sample is far off
    one = simulate(model, p, t, exc, substeps=1, on_failure="return")
    assert not one.success or max_rel(one.y, ref.y) > 1e-2
    return err


@pytest.mark.parametrize("voltage", [0.0, 0.4, 0.8])
def test_rk4_matches_radau_on_table2(table2_setup, voltage):
    _check_table2_row(table2_setup, voltage)


@pytest.mark.slow
@pytest.mark.parametrize("voltage", sorted(set(TABLE2) - {0.0, 0.4, 0.8}))
def test_rk4_matches_radau_on_every_table2_row(table2_setup, voltage):
    _check_table2_row(table2_setup, voltage)


def test_more_substeps_converge_at_fourth_order(table2_setup):
    """Fixed substeps 4, 8, 16: the error vs Radau falls ~16x per doubling (RK4)."""
    model, t, exc = table2_setup
    t = t[:100]
    p = table2_params(0.4)
    ref = simulate(model, p, t, exc, method="radau", **REF_TOL).y
    errs = [max_rel(simulate(model, p, t, exc, substeps=m).y, ref) for m in (4, 8, 16)]
    assert 10 < errs[0] / errs[1] < 24 and 10 < errs[1] / errs[2] < 24, errs


# ------------------------------------------------------------------- (b) analytic limits
def _linear_model():
    """Eq. 3 with beta = delta = 0: x'' + gamma x' + alpha x = k1 d + c1 d'."""
    return duffing_like(3)


def _free_response(gamma, alpha, x0, v0, t):
    """Closed-form x(t), x'(t) of x'' + gamma x' + alpha x = 0 in its three regimes."""
    a = 0.5 * gamma
    disc = a * a - alpha
    if abs(disc) < 1e-14 * alpha:  # critically damped
        e = np.exp(-a * t)
        b = v0 + a * x0
        x = e * (x0 + b * t)
        v = e * (b - a * (x0 + b * t))
    elif disc < 0:  # under-damped
        wd = math.sqrt(-disc)
        e = np.exp(-a * t)
        b = (v0 + a * x0) / wd
        c, s = np.cos(wd * t), np.sin(wd * t)
        x = e * (x0 * c + b * s)
        v = e * (-a * (x0 * c + b * s) + wd * (-x0 * s + b * c))
    else:  # over-damped
        s = math.sqrt(disc)
        r1, r2 = -a + s, -a - s
        A = (v0 - r2 * x0) / (r1 - r2)
        B = x0 - A
        x = A * np.exp(r1 * t) + B * np.exp(r2 * t)
        v = A * r1 * np.exp(r1 * t) + B * r2 * np.exp(r2 * t)
    return x, v


@pytest.mark.parametrize("regime, gamma, alpha", [("under", 1.0, 10.0), ("critical", 4.0, 4.0), ("over", 10.0, 10.0)])
@pytest.mark.parametrize("method, rtol, atol", [("rk4", 1e-5, 1e-7), ("radau", 1e-8, 1e-10)])
def test_linear_free_response_matches_closed_form(regime, gamma, alpha, method, rtol, atol):
    model = _linear_model()
    p = dict(gamma=gamma, alpha=alpha, beta=0.0, delta=0.0, k1=10.0, c1=10.0, A_f=2.0)
    t = np.linspace(0.0, 5.0, 501)
    x0, v0 = 0.8, -1.3
    kw = dict(rtol=1e-11, atol=1e-13) if method == "radau" else {}
    traj = simulate(model, p, t, np.zeros((t.size, 2)), x0=[x0, v0], method=method, **kw)
    x, v = _free_response(gamma, alpha, x0, v0, t)
    for got, want in ((traj.x[:, 0], x), (traj.x[:, 1], v), (traj.y, 2.0 * v)):
        e = tolerance_scaled(got, want, rtol, atol)
        assert e.max() < 5, f"{regime}/{method}: scaled error {e.max():.2f}"


def test_linear_free_response_of_mr_damper_n1():
    """n = 1 makes Eq. 12 linear: x'' + (c1+c2+c3) x' + (k1+k2+k3) x = k1 d + c1 d'."""
    model = mr_damper(1)
    p = dict(c1=1.0, c2=0.5, c3=0.5, k1=20.0, k2=10.0, k3=10.0, A_f=1.0)
    t = np.linspace(0.0, 4.0, 801)
    traj = simulate(model, p, t, np.zeros((t.size, 2)), x0=[0.5, 0.0])
    x, v = _free_response(2.0, 40.0, 0.5, 0.0, t)
    assert tolerance_scaled(traj.x[:, 0], x, 1e-6, 1e-8).max() < 5
    assert tolerance_scaled(traj.y, v, 1e-6, 1e-8).max() < 5


@pytest.mark.parametrize("freq", [0.5, 2.0, 6.0])
def test_linear_forced_steady_state_matches_transfer_function(freq):
    """x' in steady state is |G| sin(wt + arg G) for d = sin(wt), with G = jw H(jw) and
    H(s) = (c1 s + k1) / (s^2 + gamma s + alpha), times the gain sinc^2(f dt) of the linear
    reconstruction of the sampled input (a triangle kernel: no phase)."""
    model = _linear_model()
    gamma, alpha, k1, c1 = 6.0, 40.0, 10.0, 3.0
    p = dict(gamma=gamma, alpha=alpha, beta=0.0, delta=0.0, k1=k1, c1=c1, A_f=1.0)
    dt = 0.001
    t = np.arange(0.0, 10.0, dt)  # transients decay as exp(-3 t): 1e-13 by t = 10
    traj = simulate(model, p, t, Sine(1.0, freq))
    w = 2 * math.pi * freq
    s = 1j * w
    G = s * (c1 * s + k1) / (s * s + gamma * s + alpha)
    gain = abs(G) * np.sinc(freq * dt) ** 2
    cyc = steady_cycle(traj, 1.0 / freq)
    tt = t[cyc]
    want = gain * np.sin(w * tt + np.angle(G))
    assert tolerance_scaled(traj.y[cyc], want, 1e-6, 1e-8 * abs(G)).max() < 5
    # amplitude and phase by projection on sin/cos over the last cycle
    basis = np.column_stack([np.sin(w * tt), np.cos(w * tt)])
    a, b = np.linalg.lstsq(basis, traj.y[cyc], rcond=None)[0]
    assert math.hypot(a, b) == pytest.approx(gain, rel=1e-7)
    assert math.atan2(b, a) == pytest.approx(np.angle(G), abs=1e-7)
    # the reconstruction gain is measurable: without it the amplitude is off by (pi f dt)^2 / 3
    assert abs(math.hypot(a, b) / abs(G) - 1) == pytest.approx((math.pi * freq * dt) ** 2 / 3, rel=1e-2)


# ------------------------------------------------------------------- (c) properties
@settings(max_examples=8, deadline=None, derandomize=True)
@given(
    scale=st.floats(0.5, 1.5),
    amplitude=st.floats(0.1, 1.5),
    freq=st.floats(0.5, 4.0),
    x0=st.tuples(st.floats(-0.5, 0.5), st.floats(-2.0, 2.0)),
    n=st.sampled_from([1, 3, 5]),
)
def test_odd_symmetry(scale, amplitude, freq, x0, n):
    """For odd n, negating d, d' and x0 negates the states and the output exactly."""
    model = mr_damper(n)
    p = {k: v * (scale if k in ("c3", "k2") else 1.0) for k, v in table2_params(0.4).items()}
    p["k3"] = 50.0
    t = np.arange(200) * 0.005
    U = Sine(amplitude, freq, phase=0.3).channels(t, model)
    a = simulate(model, p, t, U, x0=x0)
    b = simulate(model, p, t, -U, x0=[-x0[0], -x0[1]])
    np.testing.assert_allclose(b.y, -a.y, rtol=1e-12, atol=1e-12 * np.abs(a.y).max())
    np.testing.assert_array_equal(a.substeps, b.substeps)


def _duffing_energy(x, alpha, beta):
    return 0.5 * x[:, 1] ** 2 + 0.5 * alpha * x[:, 0] ** 2 + 0.25 * beta * x[:, 0] ** 4


@settings(max_examples=8, deadline=None, derandomize=True)
@given(alpha=st.floats(0.5, 5.0), beta=st.floats(0.0, 5.0), x0=st.floats(-2.0, 2.0), v0=st.floats(-2.0, 2.0))
def test_duffing_energy_conserved_without_damping_and_force(alpha, beta, x0, v0):
    model = duffing()
    t = np.arange(0.0, 10.0, 0.01)
    H0 = 0.5 * v0**2 + 0.5 * alpha * x0**2 + 0.25 * beta * x0**4
    if H0 < 1e-3:
        return
    for substeps, bound in (("auto", 1e-6), (4, 1e-8)):
        traj = simulate(
            model, dict(gamma=0.0, alpha=alpha, beta=beta), t, np.zeros(t.size), x0=[x0, v0], substeps=substeps
        )
        drift = np.abs(_duffing_energy(traj.x, alpha, beta) - H0).max() / H0
        assert drift < bound, (substeps, drift)


def test_energy_drift_is_fourth_order():
    """RK4's energy error falls ~16x when the step halves: the test above measures the integrator."""
    model = duffing()
    t = np.arange(0.0, 10.0, 0.05)
    alpha, beta, x0 = 2.0, 3.0, [1.5, 0.0]
    H0 = 0.5 * alpha * 1.5**2 + 0.25 * beta * 1.5**4
    drift = []
    for m in (2, 4):
        traj = simulate(model, dict(gamma=0.0, alpha=alpha, beta=beta), t, np.zeros(t.size), x0=x0, substeps=m)
        drift.append(np.abs(_duffing_energy(traj.x, alpha, beta) - H0).max() / H0)
    assert 8 < drift[0] / drift[1] < 40, drift


# ------------------------------------------------------------------- (d) batch
def test_batch_equals_single_simulations(table2_setup):
    model, t, exc = table2_setup
    rows = [model.param_vector(table2_params(v)) for v in (0.0, 0.4, 0.8)]
    bad = model.param_vector(table2_params(0.4))
    bad[2] = -300.0  # negative c3: blows up
    P = np.array(rows + [bad])
    for substeps in ("auto", 3):
        res = simulate_batch(model, P, t, exc, substeps=substeps)
        assert list(res.status) == [0, 0, 0, 1]
        for i, p in enumerate(rows):
            single = simulate(model, p, t, exc, substeps=substeps)
            np.testing.assert_allclose(res.y[i], single.y, rtol=1e-13, atol=1e-13)
            assert res.total_substeps[i] == single.substeps.sum()
        failed = simulate(model, bad, t, exc, substeps=substeps, method="rk4", on_failure="return")
        assert res.failed_at[3] == failed.failed_at  # the batch's default is the explicit run's verdict
        assert np.all(np.isnan(res.y[3, failed.failed_at :]))


def test_batch_with_initial_states_and_array_input():
    model = duffing()
    t = np.arange(0.0, 2.0, 0.01)
    F = BandLimitedRandom(rms=0.5, f_max=3.0, duration=2.0, seed=3, signal="F")
    P = np.array([[0.3, 1.0, 1.0], [0.1, 2.0, -0.2]])
    X0 = np.array([[0.1, 0.0], [-0.2, 0.4]])
    res = simulate_batch(model, P, t, F, x0=X0)
    for i in range(2):
        np.testing.assert_allclose(res.y[i], simulate(model, P[i], t, F, x0=X0[i]).y, rtol=1e-13, atol=1e-15)


# ------------------------------------------------------------------- (e) input reconstruction
def test_hold_and_linear_reconstruction_each_match_radau(table2_setup):
    model, t, exc = table2_setup
    t = t[:120]
    p = table2_params(0.4)
    out = {}
    for rec in ("linear", "hold"):
        rk4 = simulate(model, p, t, exc, reconstruction=rec)
        ref = simulate(model, p, t, exc, reconstruction=rec, method="radau", **REF_TOL)
        assert max_rel(rk4.y, ref.y) <= 1e-3, rec
        out[rec] = ref.y
    assert max_rel(out["hold"], out["linear"]) > 1e-2


def test_hold_reconstruction_of_linear_model_is_exact_zoh():
    """Zero-order hold on a linear model equals the exact discretisation with expm."""
    from scipy.linalg import expm

    model = _linear_model()
    gamma, alpha, k1, c1 = 2.0, 20.0, 5.0, 1.0
    p = dict(gamma=gamma, alpha=alpha, beta=0.0, delta=0.0, k1=k1, c1=c1, A_f=1.0)
    t = np.arange(200) * 0.02
    U = Sine(1.0, 1.5).channels(t, model)
    traj = simulate(model, p, t, U, reconstruction="hold", substeps=8)
    A = np.array([[0.0, 1.0], [-alpha, -gamma]])
    B = np.array([[0.0, 0.0], [k1, c1]])
    M = expm(np.block([[A, B], [np.zeros((2, 4))]]) * 0.02)
    Ad, Bd = M[:2, :2], M[:2, 2:]
    x = np.zeros(2)
    xs = [x]
    for k in range(t.size - 1):
        x = Ad @ x + Bd @ U[k]
        xs.append(x)
    xs = np.array(xs)
    assert tolerance_scaled(traj.x, xs, 1e-7, 1e-9).max() < 5


# ------------------------------------------------------------------- (f) blow-up
def test_blow_up_raises_with_time_and_advice(table2_setup):
    model, t, exc = table2_setup
    p = table2_params(0.4)
    p["c3"] = -300.0
    with pytest.raises(SimulationError, match=r"blew up at t=0\.01 s \(sample 2 of 400\).*unstable") as info:
        simulate(model, p, t, exc)
    traj = info.value.trajectory
    assert traj is not None and traj.status == "blow-up" and traj.failed_at == 2


def test_blow_up_returned_with_nan_after_failure(table2_setup):
    model, t, exc = table2_setup
    p = table2_params(0.4)
    p["c3"] = -300.0
    for substeps in ("auto", 2):
        traj = simulate(model, p, t, exc, substeps=substeps, on_failure="return")
        assert not traj.success and traj.status == "blow-up"
        k = traj.failed_at
        assert np.all(np.isfinite(traj.y[:k])) and np.all(np.isnan(traj.y[k:]))
        assert np.all(np.isnan(traj.x[k:]))
        assert "blew up" in traj.summary()


def test_too_stiff_reported(table2_setup):
    model, t, exc = table2_setup
    traj = simulate(model, table2_params(0.4), t, exc, method="rk4", max_substeps=3, on_failure="return")
    assert traj.status == "too stiff" and traj.failed_at == 1
    assert "raise max_substeps" in traj.message and "t=0.005 s" in traj.message
    assert np.all(np.isnan(traj.y[2:])) and np.isfinite(traj.y[1])


def test_radau_reports_blow_up(table2_setup):
    model, t, exc = table2_setup
    p = table2_params(0.4)
    p["c3"] = -300.0
    traj = simulate(model, p, t[:20], exc, method="radau", on_failure="return", **REF_TOL)
    assert not traj.success and traj.status == "blow-up" and np.isnan(traj.y[-1])


# ------------------------------------------------------------------- (g) bad input
@pytest.fixture(scope="module")
def small():
    model = mr_damper(5)
    t = np.arange(10) * 0.005
    return model, t, Sine(1.0, 2.0)


def test_bad_params(small):
    model, t, exc = small
    p = table2_params(0.4)
    with pytest.raises(ModelError, match=r"parameter\(s\) \['c3'\] are not finite"):
        simulate(model, {**p, "c3": math.nan}, t, exc)
    with pytest.raises(ModelError, match=r"unknown parameter\(s\) \['c4'\].*known: c1"):
        simulate(model, {**p, "c4": 1.0}, t, exc)
    missing = dict(p)
    del missing["k2"]
    with pytest.raises(ModelError, match=r"missing value\(s\) for \['k2'\]"):
        simulate(model, missing, t, exc)
    with pytest.raises(ModelError, match="has 7 parameters .* got a vector of length 6"):
        simulate(model, np.ones(6), t, exc)


def test_even_power_refused():
    with pytest.raises(ModelError, match="must be odd.*use 3 or 5"):
        mr_damper(n=4)


def test_bad_time(small):
    model, _, exc = small
    with pytest.raises(DataError, match=r"strictly increasing: 1 non-increasing step\(s\), first at index 2"):
        simulate(model, table2_params(0.4), [0.0, 0.01, 0.005, 0.02], exc)
    with pytest.raises(DataError, match="non-finite value"):
        simulate(model, table2_params(0.4), [0.0, np.nan, 0.02], exc)
    with pytest.raises(DataError, match="at least 2 sample times"):
        simulate(model, table2_params(0.4), [0.0], exc)


def test_bad_inputs(small):
    model, t, exc = small
    p = table2_params(0.4)
    with pytest.raises(DataError, match=r"inputs must have shape \(n_times, n_inputs\) = \(10, 2\).*got \(10, 1\)"):
        simulate(model, p, t, np.zeros((10, 1)))
    with pytest.raises(DataError, match="needs input 'd_dot'"):
        simulate(model, p, t, {"d": np.zeros(10)})
    with pytest.raises(DataError, match=r"input 'd_dot' must have shape \(n_times,\) = \(10,\)"):
        simulate(model, p, t, {"d": np.zeros(10), "d_dot": np.zeros(9)})
    U = exc.channels(t, model)
    U[4, 1] = np.inf
    with pytest.raises(DataError, match=r"input d_dot is not finite at index 4 \(t=0.02 s\)"):
        simulate(model, p, t, U)
    with pytest.raises(DataError, match="needs input signal 'F'.*signal='F'"):
        simulate(duffing(), dict(gamma=0.1, alpha=1.0, beta=1.0), t, exc)


def test_bad_options(small):
    model, t, exc = small
    p = table2_params(0.4)
    with pytest.raises(ModelError, match="method must be one of"):
        simulate(model, p, t, exc, method="euler")
    with pytest.raises(ModelError, match="reconstruction must be one of"):
        simulate(model, p, t, exc, reconstruction="cubic")
    with pytest.raises(ModelError, match="substeps must be 'auto' or a positive integer; got 0"):
        simulate(model, p, t, exc, substeps=0)
    with pytest.raises(ModelError, match="on_failure must be"):
        simulate(model, p, t, exc, on_failure="ignore")
    with pytest.raises(ModelError, match=r"x0 must hold 2 finite values"):
        simulate(model, p, t, exc, x0=[0.0, 0.0, 1.0])
    with pytest.raises(ModelError, match=r"params must have shape \(n_sets, 7\)"):
        simulate_batch(model, np.ones((3, 6)), t, exc)
    with pytest.raises(ModelError, match="non-finite entries in row"):
        simulate_batch(model, np.full((2, 7), np.nan), t, exc)


def test_bad_integrator_options(small):
    model, t, exc = small
    p = table2_params(0.4)
    with pytest.raises(ModelError, match=r"h_lambda must be in \(0, 2.5\]"):
        simulate(model, p, t, exc, h_lambda=3.0)
    with pytest.raises(ModelError, match="max_substeps must be a positive integer"):
        simulate(model, p, t, exc, max_substeps=0)
    with pytest.raises(ModelError, match="blowup must be a positive number"):
        simulate(model, p, t, exc, blowup=-1.0)
    P = np.tile(model.param_vector(p), (3, 1))
    with pytest.raises(ModelError, match=r"x0 must be finite with shape \(2,\) or \(3, 2\).*got shape \(2, 2\)"):
        simulate_batch(model, P, t, exc, x0=np.zeros((2, 2)))
    with pytest.raises(ModelError, match="reconstruction must be one of"):
        simulate_batch(model, P, t, exc, reconstruction="spline")


def test_repeated_excitation_inputs_are_fresh_and_equal(small):
    """simulate() remembers the sampled excitation; each trajectory still owns its input array."""
    model, t, exc = small
    p = table2_params(0.4)
    a = simulate(model, p, t, exc)
    a.u[:] = 0.0  # a user mutating one result must not change the next
    b = simulate(model, p, t, Sine(1.0, 2.0))
    np.testing.assert_array_equal(b.u, Sine(1.0, 2.0).channels(t, model))
    c = simulate(model, p, t, Sine(1.0, 2.5))
    assert not np.allclose(c.u, b.u)


@pytest.mark.slow
@pytest.mark.ci
def test_auto_substeps_retry_an_overshooting_step_instead_of_reporting_blowup():
    """Table 1's c3 = 1000 at 25 samples per period: the first trial step overshoots (the stiffness grows like
    x'^2 inside it) — auto mode must refine it, not call it a blow-up (found by studies/s02)."""
    from duffsym.model.presets import TABLE1_BASE

    t = np.linspace(0, 24, 601)
    params = {**TABLE1_BASE, "c3": 1000.0}
    traj = simulate(mr_damper(3), params, t, Sine(1.0, 0.25))
    ref = simulate(mr_damper(3), params, t, Sine(1.0, 0.25), method="radau")
    assert traj.success and traj.substeps.max() > 8
    assert np.max(np.abs(traj.y - ref.y)) / np.max(np.abs(ref.y)) < 1e-3
