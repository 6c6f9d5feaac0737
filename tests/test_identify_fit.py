"""Collocation + IPOPT identification on synthetic Table 2 data with known truth."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from duffsym import Sine, mr_damper
from duffsym.data import synthetic_record
from duffsym.errors import DataError
from duffsym.identify import (
    IdentificationResult,
    Problem,
    auto_mask,
    collocation_coefficients,
    fit,
    initial_guess,
    load_result,
)
from duffsym.model.presets import table2_params

MODEL = mr_damper()
TRUTH = table2_params(0.4)
FREE = ("c1", "c2", "c3", "k1", "k2")


def symmetric(p, s, n=5):
    """Parameters after the scaling x -> s x (design.md), which leaves the output unchanged."""
    return dict(
        c1=p["c1"] / s,
        c2=p["c1"] + p["c2"] - p["c1"] / s,
        k1=p["k1"] / s,
        k2=p["k1"] + p["k2"] - p["k1"] / s,
        c3=p["c3"] * s ** (n - 1),
        k3=p["k3"] * s ** (n - 1),
        A_f=p["A_f"] * s,
    )


def rel_errors(params, truth, names=FREE):
    return {k: abs(params[k] / truth[k] - 1) for k in names}


@pytest.fixture(scope="module")
def clean_record():
    # 0.4 V row, 2 Hz, dt 0.005, 3 periods, noise-free
    return synthetic_record(MODEL, TRUTH, Sine(1.0, 2.0), dt=0.005, duration=1.5, noise=0.0, rng=0)


def test_collocation_coefficients_differentiate_cubics_exactly():
    tau, C, D = collocation_coefficients(3)
    assert tau[0] == 0 and np.all(np.diff(tau) > 0) and tau[-1] < 1
    for coeffs in ([1.0], [2.0, -1.0], [0.5, 0.0, 3.0], [-1.0, 2.0, 0.0, 4.0]):
        p = np.poly1d(coeffs)
        vals = p(tau)
        assert np.allclose(vals @ C, np.polyder(p)(tau), atol=1e-12)
        assert vals @ D == pytest.approx(p(1.0), abs=1e-12)


def test_noise_free_recovery_from_random_starts(clean_record):
    """From starts within a factor 10 of the truth, every fit converges to the truth.

    Degree 5 recovers to < 1e-5; the default degree 3 carries a discretisation bias of
    about 1.2e-4 on c2 at dt = 0.005 s (measured 1.21e-4; the other parameters < 8e-5).
    """
    problem = Problem(MODEL, clean_record, fixed={"A_f": TRUTH["A_f"]})
    assert problem.free == FREE and problem.defaults_applied.keys() == {"k3"}
    rng = np.random.default_rng(11)
    for _ in range(3):
        factors = np.exp(rng.uniform(-math.log(10), math.log(10), len(FREE)))
        x0 = {k: TRUTH[k] * f for k, f in zip(FREE, factors)}
        res = fit(problem, x0, degree=5)
        assert res.success, res.message
        assert max(rel_errors(res.params, TRUTH).values()) < 1e-4
        assert res.nrmse < 1e-4 and res.r2 > 1 - 1e-8
    res3 = fit(problem, {k: 3 * TRUTH[k] for k in FREE})
    errs = rel_errors(res3.params, TRUTH)
    assert res3.success and max(errs.values()) < 2e-4 and errs["c3"] < 1e-4


def test_multistart_builds_once_and_all_starts_agree():
    rec = synthetic_record(MODEL, TRUTH, Sine(1.0, 2.0), dt=0.005, duration=1.5, noise=0.02, rng=4)
    res = fit(Problem(MODEL, rec, fixed={"A_f": TRUTH["A_f"]}), n_starts=6, rng=5)
    assert res.success and res.settings["n_starts"] == 6 and res.settings["starts_converged"] == 6
    costs = np.array(res.settings["start_costs"])
    assert np.ptp(costs) < 1e-8 * costs.min()  # states start from the data: every start finds the same optimum
    assert res.cost == pytest.approx(costs.min(), rel=1e-12)
    with pytest.raises(Exception, match="n_starts must be a positive integer"):
        fit(Problem(MODEL, rec), n_starts=0)


def test_default_af_recovers_symmetry_invariant_combinations(clean_record):
    problem = Problem(MODEL, clean_record)
    assert set(problem.defaults_applied) == {"A_f", "k3"}
    assert problem.fixed["A_f"] == pytest.approx(np.max(np.abs(clean_record.y)))
    res = fit(problem, degree=5)  # x0 from initial_guess (paper's Fig. 4b procedure)
    assert res.success
    s = res.params["A_f"] / TRUTH["A_f"]
    assert abs(s - 1) > 0.1  # A_f = max|y| is not the truth: the other gains move along the symmetry
    assert max(rel_errors(res.params, symmetric(TRUTH, s)).values()) < 1e-4
    assert "scaling symmetry" in res.defaults_applied["A_f"] and "ridge" in res.defaults_applied["k3"]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_noisy_truth_within_three_standard_errors(seed):
    rec = synthetic_record(MODEL, TRUTH, Sine(1.0, 2.0), dt=0.005, duration=1.5, noise=0.02, rng=seed)
    res = fit(Problem(MODEL, rec, fixed={"A_f": TRUTH["A_f"]}))
    assert res.success
    for k in FREE:
        assert abs(res.params[k] - TRUTH[k]) < 3 * res.stderr[k], (k, res.params[k], res.stderr[k])
    # the standard errors are informative: a few percent of the values, not huge
    assert all(res.stderr[k] / TRUTH[k] < 0.3 for k in FREE)
    # free-run NRMSE at the noise level (noise is 2 % of the RMS, NRMSE is relative to the std)
    assert 0.015 < res.nrmse < 0.03
    cov = res.covariance
    assert np.allclose(cov, cov.T) and np.all(np.linalg.eigvalsh(cov) > 0)


def test_twenty_random_starts_recover_the_invariant_combinations(clean_record):
    """Issue 3: noise-free data, A_f = max|y| (the default, so the symmetry is in play), 20 random
    starts log-uniform within a factor 10 of the truth mapped onto A_f = max|y|: every fit recovers
    the symmetry-invariant combinations to 1e-4 (degree 5; measured max 3.5e-6 over the 20). Start 15
    needs the restart off the k1 bound (see the next test).
    """
    problem = Problem(MODEL, clean_record)
    s = problem.fixed["A_f"] / TRUTH["A_f"]
    mapped = symmetric(TRUTH, s)
    rng = np.random.default_rng(2026)
    worst = 0.0
    for _ in range(20):
        factors = np.exp(rng.uniform(-math.log(10), math.log(10), len(FREE)))
        res = fit(problem, {k: mapped[k] * f for k, f in zip(FREE, factors)}, degree=5)
        assert res.success, res.message
        worst = max(worst, *rel_errors(res.params, mapped).values())
    assert worst < 1e-4, worst


def test_a_run_pushed_onto_a_bound_is_restarted(clean_record):
    """Start 15 of the test above: without the restart IPOPT stops at k1 = 0, k2 ~ 0 (NRMSE 0.015 on
    noise-free data, reported as converged); the restart from its end parameters with k1 back at its
    start reaches the truth, and the result says so. The trap was found with IPOPT's own initial barrier
    parameter (0.1); from the fit's default (``nlp.MU_INIT``, 1e-3) this start converges to k1 = 41.8, so the
    test sets IPOPT's to reach the trap."""
    problem = Problem(MODEL, clean_record)
    mapped = symmetric(TRUTH, problem.fixed["A_f"] / TRUTH["A_f"])
    start = {
        "c1": 21.434361463294696,
        "c2": 1.6147314253460154,
        "c3": 1102.3402507463006,
        "k1": 4.655682916414523,
        "k2": 186.03103090768062,
    }
    ipopt = {"mu_init": 0.1}
    trapped = fit(problem, start, degree=5, bound_restart=False, ipopt_options=ipopt)
    # the path is a knife edge (the start rounded to 2 digits misses it): when this start stops reaching the trap,
    # the restart below is no longer tested, so the test fails and asks for a new start (a skip would hide that)
    assert trapped.params["k1"] < 1e-6 and trapped.nrmse > 0.01, "this start no longer reaches the k1 = 0 trap"
    assert trapped.success  # the trap is a converged KKT point: only the restart can tell
    res = fit(problem, start, degree=5, ipopt_options=ipopt)
    assert max(rel_errors(res.params, mapped).values()) < 1e-4 and res.nrmse < 1e-4
    note = res.settings["bound_restart"]
    assert note["parameters"] == ["k1"] and note["kept"] == "restart" and note["cost_after"] < note["cost_before"]
    assert "k1 had stopped on a bound" in res.message
    # a fit that starts on the optimum has nothing to restart
    assert fit(problem, mapped, degree=5).settings["bound_restart"] is None


def test_standard_errors_are_calibrated_over_fifty_seeds():
    """Issue 3: with 2 % noise the truth lies within 3 standard errors in >= 90 % of 50 seeds.

    Beyond the count, the z-scores (estimate - truth) / s.e. must have a spread near 1: standard
    errors that were 3x too large would pass the count and fail this. Measured (seeds 100-149,
    7 s): 50/50 seeds with all five parameters inside, z std 0.97-1.05, |z mean| <= 0.21.
    """
    z = []
    for seed in range(100, 150):
        rec = synthetic_record(MODEL, TRUTH, Sine(1.0, 2.0), dt=0.005, duration=1.5, noise=0.02, rng=seed)
        res = fit(Problem(MODEL, rec, fixed={"A_f": TRUTH["A_f"]}))
        assert res.success, (seed, res.message)
        z.append([(res.params[k] - TRUTH[k]) / res.stderr[k] for k in FREE])
    z = np.asarray(z)
    inside = np.all(np.abs(z) < 3, axis=1)
    assert inside.sum() >= 45, inside.sum()
    assert np.all((z.std(axis=0) > 0.7) & (z.std(axis=0) < 1.4)), z.std(axis=0)
    assert np.all(np.abs(z.mean(axis=0)) < 0.5), z.mean(axis=0)


def test_multi_record_shares_parameters_and_frees_k3():
    """Two amplitudes make k3 identifiable; both records share one parameter set."""
    recs = [synthetic_record(MODEL, TRUTH, Sine(a, 2.0), dt=0.005, duration=1.0, noise=0.0, rng=0) for a in (0.4, 1.0)]
    problem = Problem(MODEL, recs, free=[*FREE, "k3"], fixed={"A_f": TRUTH["A_f"]})
    res = fit(problem, {**{k: 2 * TRUTH[k] for k in FREE}, "k3": 50.0}, degree=5)
    assert res.success and len(res.x0) == 2 and len(res.nrmse_records) == 2
    assert max(rel_errors(res.params, TRUTH).values()) < 1e-4
    # k3 = 0 recovered to where its force k3 x^5 is < 1e-4 of the linear term k2 x over the fitted range
    from duffsym import simulate

    x1max = max(
        np.max(np.abs(simulate(MODEL, res.params, r.t, r.inputs_for(MODEL), x0=x0).x[:, 0]))
        for r, x0 in zip(recs, res.x0)
    )
    assert abs(res.params["k3"]) * x1max**4 < 1e-4 * TRUTH["k2"]


def test_masked_fit_beats_unmasked_under_input_backlash(tmp_path):
    """Measured: RMS relative parameter error 0.84 unmasked vs 0.24 masked (backlash half-width 0.02)."""
    rec = synthetic_record(MODEL, TRUTH, Sine(1.0, 2.0), dt=0.005, duration=2.0, noise=0.0, backlash=0.02, rng=0)
    mask, info = auto_mask(rec)
    assert info["n_stretches"] == 8 and 0.05 < info["fraction_masked"] < 0.2
    fixed = {"A_f": TRUTH["A_f"]}
    plain = fit(Problem(MODEL, rec, fixed=fixed))
    masked = fit(Problem(MODEL, rec, fixed=fixed, mask=mask, mask_info=info))
    assert plain.success and masked.success
    err = [np.sqrt(np.mean(np.square(list(rel_errors(r.params, TRUTH).values())))) for r in (plain, masked)]
    assert err[1] < err[0] / 2.5, err
    assert masked.mask[0].sum() == info["n_masked"] and masked.mask_info["rule"].startswith("auto")
    # the saved fit keeps the mask it used (as runs of samples), so `sample` and readers get it back
    back = load_result(masked.save(tmp_path / "masked.json"))
    assert np.array_equal(back.mask[0], mask) and back.to_dict()["mask"][0]["n_times"] == rec.n_times
    assert len(back.to_dict()["mask"][0]["ranges"]) == info["n_stretches"]
    bad = json.loads((tmp_path / "masked.json").read_text())
    bad["mask"][0]["ranges"].append([rec.n_times - 2, rec.n_times + 5])
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    with pytest.raises(DataError, match=r"mask range \[\d+, \d+\) lies outside"):
        load_result(tmp_path / "bad.json")


def test_auto_mask_small_without_deadzone(clean_record):
    mask, info = auto_mask(clean_record)
    lag_no_backlash = info["median_lag_samples"]
    rec = synthetic_record(MODEL, TRUTH, Sine(1.0, 2.0), dt=0.005, duration=1.5, noise=0.0, backlash=0.05, rng=0)
    _, info_b = auto_mask(rec)
    # the gap of 2 x 0.05 at the top of a unit sine takes ~7 samples to cross: the lag grows accordingly
    assert info_b["median_lag_samples"] > lag_no_backlash + 2
    assert info["fraction_masked"] < info_b["fraction_masked"]
    with pytest.raises(DataError, match="force_band must lie in"):
        auto_mask(rec, force_band=1.5)


def test_initial_guess_improves_on_defaults_for_another_row():
    truth = table2_params(0.0)  # c2 = 100, k1 = 50, k2 = 800: far from the 0.4 V defaults
    rec = synthetic_record(MODEL, truth, Sine(1.0, 2.0), dt=0.005, duration=1.5, noise=0.0, rng=0)
    fixed = {"A_f": truth["A_f"], "k3": 0.0}
    guess = initial_guess(rec, MODEL, fixed=fixed)
    from duffsym import simulate

    def err(p):
        y = simulate(MODEL, p, rec.t, rec.inputs_for(MODEL), on_failure="return").y
        return np.sqrt(np.mean((y - rec.y) ** 2)) / np.std(rec.y)

    assert err(guess) < 0.5 * err({**MODEL.defaults(), **fixed})
    res = fit(Problem(MODEL, rec, fixed=fixed), degree=5)  # starts from the guess
    assert res.success and max(rel_errors(res.params, truth).values()) < 1e-4


def test_nonconverged_fit_is_reported_not_raised(clean_record):
    res = fit(Problem(MODEL, clean_record, fixed={"A_f": 1.6}), {k: 3 * TRUTH[k] for k in FREE}, max_iter=1)
    assert res.success is False
    assert res.status == "Maximum_Iterations_Exceeded" and "max_iter=1" in res.message
    assert "FAILED" in res.summary()


def test_json_round_trip(tmp_path, clean_record):
    res = fit(Problem(MODEL, clean_record, fixed={"A_f": 1.6}), {k: TRUTH[k] for k in FREE})
    path = res.save(tmp_path / "fit.json")
    data = json.loads(path.read_text())
    for key in ("model", "effects", "params", "stderr", "nrmse", "status", "success"):
        assert key in data
    assert data["model"] == "mr-damper" and data["effects"] == [] and data["success"] is True
    back = load_result(path)
    assert isinstance(back, IdentificationResult)
    assert back.params == res.params and back.stderr == pytest.approx(res.stderr)
    assert np.allclose(back.covariance, res.covariance) and back.nrmse == res.nrmse
    assert back.defaults_applied == res.defaults_applied
    bad = tmp_path / "bad.json"
    bad.write_text('{"model": "mr-damper"}')
    with pytest.raises(DataError, match=r"missing key\(s\)"):
        load_result(bad)
    bad.write_text("not json")
    with pytest.raises(DataError, match="not valid JSON"):
        load_result(bad)


def test_validate_saved_fit_on_another_frequency(tmp_path, clean_record):
    """Fit at 2 Hz, validate the saved fit at 1 Hz (paper Fig. 9): the truth model predicts it."""
    from duffsym.identify import validate

    res = fit(Problem(MODEL, clean_record, fixed={"A_f": 1.6}), {k: TRUTH[k] for k in FREE})
    back = load_result(res.save(tmp_path / "fit.json"))
    # 1.5 periods at 0.5 Hz: the unmeasured initial state is estimated over the first period
    other = synthetic_record(MODEL, TRUTH, Sine(0.8, 0.5), dt=0.005, duration=3.0, noise=0.0, settle=2.0, rng=0)
    val = validate(back, other)
    assert val.success and val.nrmse < 1e-3 and val.to_dict()["nrmse"] == val.nrmse
    assert np.allclose(val.x0, other.metadata["x0"], rtol=1e-3, atol=1e-5)
    # a wrong parameter set is visibly worse
    wrong = IdentificationResult.from_dict({**back.to_dict(), "params": {**back.params, "c3": 2 * TRUTH["c3"]}})
    assert validate(wrong, other).nrmse > 50 * val.nrmse


def test_per_voltage_parameters_in_one_fit(tmp_path):
    """Three Table 2 rows fitted together, one parameter set per voltage: each row recovered
    (up to the per-group scaling symmetry, since A_f is fixed per group to the group's max|y|)."""
    from duffsym.identify import validate

    volts = (0.2, 0.4, 0.8)
    recs = [
        synthetic_record(MODEL, table2_params(v), Sine(1.0, 2.0), dt=0.005, duration=1.0, noise=0.0, rng=0).replace(
            voltage=v
        )
        for v in volts
    ]
    problem = Problem(MODEL, recs, groups="voltage", per_group=FREE)
    assert problem.slot_names[:3] == ("c1[0.2V]", "c1[0.4V]", "c1[0.8V]") and len(problem.slots) == 15
    res = fit(problem, degree=5)
    assert res.success and set(res.group_params) == {"0.2V", "0.4V", "0.8V"}
    for v, rec in zip(volts, recs):
        truth = table2_params(v)
        got = res.params_for(f"{v:g}V")
        assert got["A_f"] == pytest.approx(np.max(np.abs(rec.y)))
        assert max(rel_errors(got, symmetric(truth, got["A_f"] / truth["A_f"])).values()) < 1e-4
        assert res.stderr[f"c3[{v:g}V]"] > 0
    back = load_result(res.save(tmp_path / "fit.json"))
    assert back.group_params == res.group_params
    val = validate(back, recs[2])  # picks the 0.8V parameters from the record's voltage
    assert val.nrmse < 1e-3
    with pytest.raises(DataError, match="this fit has groups"):
        back.params_for("0.3V")


def test_structured_derivatives_follow_casadi_autodiff():
    """The block-assembled Jacobian and Hessian (the default) take IPOPT along the same iterates as
    CasADi's automatic differentiation of the whole NLP: two records, a mask, per-group and shared
    parameters, a group-fixed A_f."""
    recs = [
        synthetic_record(MODEL, table2_params(v), Sine(1.0, 2.0), dt=0.005, duration=1.0, noise=0.02, rng=3).replace(
            voltage=v
        )
        for v in (0.2, 0.8)
    ]
    mask = [np.arange(r.n_times) % 7 == 0 for r in recs]
    problem = Problem(MODEL, recs, groups="voltage", per_group=("c1", "k2"), mask=mask)
    runs = [
        fit(problem, degree=2, derivatives=d, compute_stderr=False, param_stride=s)
        for d, s in (("structured", 8), ("casadi", 8), ("structured", 1))
    ]
    assert all(r.success for r in runs)
    assert runs[0].n_iter == runs[1].n_iter
    for r in runs[1:]:  # the parameter copies per 8 samples or per sample: the same NLP solution
        for k, v in r.params.items():
            assert runs[0].params[k] == pytest.approx(v, rel=1e-7, abs=1e-9)
    with pytest.raises(Exception, match="derivatives must be"):
        fit(problem, derivatives="numeric")


def test_linear_parameter_constraints_hold_per_group():
    """k2 - 2 k1 <= 100 binds in the 0.2 V group (its truth is 680 - 2*54); both derivative paths agree."""
    import math

    recs = [
        synthetic_record(MODEL, table2_params(v), Sine(1.0, 2.0), dt=0.005, duration=1.0, noise=0.02, rng=3).replace(
            voltage=v
        )
        for v in (0.2, 0.8)
    ]
    cons = [({"k1": -2.0, "k2": 1.0}, -math.inf, 100.0), ({"c1": 1, "c2": 1}, 0, math.inf)]
    problem = Problem(MODEL, recs, groups="voltage", per_group=("c1", "k2"), constraints=cons)
    free_fit = fit(Problem(MODEL, recs, groups="voltage", per_group=("c1", "k2")), compute_stderr=False)
    p_free = free_fit.params_for("0.2V")
    assert p_free["k2"] - 2 * p_free["k1"] > 200  # unconstrained, the constraint would be violated
    runs = [fit(problem, derivatives=d, compute_stderr=False) for d in ("structured", "casadi")]
    assert all(r.success for r in runs) and len(runs[0].settings["constraints"]) == 4
    for lab in ("0.2V", "0.8V"):
        p = runs[0].params_for(lab)
        assert p["k2"] - 2 * p["k1"] <= 100 + 1e-6 and p["c1"] + p["c2"] >= -1e-9
    p = runs[0].params_for("0.2V")
    assert p["k2"] - 2 * p["k1"] == pytest.approx(100, abs=1e-5)  # active
    for k, v in runs[1].params.items():
        assert runs[0].params[k] == pytest.approx(v, rel=1e-7, abs=1e-9)
