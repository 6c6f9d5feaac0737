"""duffsym.uncertainty: likelihood, priors, the fixed-schedule kernel, sampling, chains, identifiability, CLI."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest

from duffsym.data import synthetic_record, write_csv
from duffsym.errors import ConvergenceWarning, DataError, ModelError
from duffsym.excitation import Sine
from duffsym.identify import Problem, fit
from duffsym.model.library import mr_damper
from duffsym.model.presets import table2_params
from duffsym.simulate import simulate
from duffsym.uncertainty import ChainTooShort, identifiability_report, load_chains, make_prior, sample
from duffsym.uncertainty._setup import build_posterior

MODEL = mr_damper(5)
TRUTH = table2_params(0.4)
FREE = ("c1", "c2", "c3", "k1", "k2")


@pytest.fixture(scope="module")
def sine_fit():
    rec = synthetic_record(MODEL, TRUTH, Sine(1.0, 2.0), dt=0.005, duration=2.0, noise=0.02, rng=11)
    res = fit(Problem(MODEL, rec, fixed={"A_f": TRUTH["A_f"]}))
    assert res.success
    return rec, res


@pytest.fixture(scope="module")
def chains(sine_fit):
    rec, res = sine_fit
    with pytest.warns(ConvergenceWarning, match="shorter than 50 tau"):
        return sample(res, rec, n_walkers=24, n_steps=400, rng=3)


def test_priors_from_bounds():
    assert make_prior("c1", 1e-3, 1e4, 10.0).kind == "log-uniform"
    c3 = make_prior("c3", 0.0, 1e7, 320.0)
    assert c3.kind == "log-uniform" and 0 < c3.lower < 1e-3  # a zero lower bound read as tiny
    assert make_prior("c2", -1e4, 1e4, 10.0).kind == "uniform"
    assert make_prior("x", 1.0, 5.0, 2.0).kind == "uniform"  # positive but not spanning decades
    with pytest.raises(ModelError, match="outside its prior bounds"):
        make_prior("c1", 1.0, 5.0, 10.0)


def test_marginal_gaussian_likelihood_matches_direct_computation(sine_fit):
    rec, res = sine_fit
    post, model, _, setup = build_posterior(res, rec)
    # points the posterior visits: optimum + Laplace-covariance draws (conditional directions are far
    # narrower than the marginal standard errors)
    L = np.linalg.cholesky(res.covariance)
    opt = np.array([res.params[n] for n in res.free])
    draws = opt + np.array([[1.5, -1.0, 0.5, 1.0, -0.5], [-1.0, 1.0, 1.5, -1.5, 0.5]]) @ L.T
    thetas = [dict(res.params)] + [dict(res.params, **dict(zip(res.free, d))) for d in draws]
    z = post.coords(np.array([[th[n] for n in post.free] for th in thetas]))
    lp, code = post.evaluate(z)
    direct = []
    for th in thetas:
        ref = simulate(MODEL, th, rec.t, rec.inputs_for(MODEL), x0=setup[0]["x0"], h_lambda=0.05)
        direct.append(-0.5 * rec.n_times * math.log(np.sum((ref.y - rec.y) ** 2)))
    assert np.all(code == 0)
    # -N/2 log SSR (sigma integrated out under 1/sigma), up to a constant: the posterior's shape; the
    # schedule's discretisation error moves the differences by far less than one log unit
    np.testing.assert_allclose(lp - lp[0], np.array(direct) - direct[0], atol=0.05)
    assert abs(lp[0] - direct[0]) < 0.5
    assert direct[0] - direct[1] > 1  # the test points are distinguishable


def test_ar1_likelihood_matches_dense_gaussian(sine_fit):
    rec, res = sine_fit
    post, _, _, setup = build_posterior(res, rec, noise="ar1")
    phi = 0.4
    z = post.coords(np.array([[res.params[n] for n in post.free] + [phi]]))
    lp, _ = post.evaluate(z)
    y_hat = post.simulators[0].run(post.params(z))[0][0]
    r = y_hat - rec.y
    n = r.size
    # marginal over sigma (prior 1/sigma) of N(0, sigma^2 R), R_ij = phi^|i-j| / (1 - phi^2)
    R = phi ** np.abs(np.subtract.outer(np.arange(n), np.arange(n))) / (1 - phi**2)
    sign, logdet = np.linalg.slogdet(R)
    direct = -0.5 * logdet - 0.5 * n * math.log(r @ np.linalg.solve(R, r))
    assert lp[0] == pytest.approx(direct, abs=1e-6)


def test_schedule_kernel_accuracy_and_failures(sine_fit):
    rec, res = sine_fit
    post, _, _, setup = build_posterior(res, rec)
    P = post.params(post.coords(np.array([[TRUTH[n] for n in post.free]])))
    Y, status, _, worst = post.simulators[0].run(P)
    ref = simulate(MODEL, P[0], rec.t, rec.inputs_for(MODEL), x0=setup[0]["x0"], h_lambda=0.02)
    assert status[0] == 0 and worst[0] <= 1.5
    err = np.max(np.abs(Y[0] - ref.y)) / np.max(np.abs(ref.y))
    assert err < 1e-3, err
    # far stiffer than the schedule resolves: stopped (status 2), never a silently wrong trajectory
    stiff = P.copy()
    stiff[0, MODEL.param_names.index("c3")] = 3e5
    _, status, fail, worst = post.simulators[0].run(stiff)
    assert status[0] == 2 and fail[0] >= 0 and worst[0] > 2.0
    # ... and it is a -inf log-posterior, counted
    z = post.coords(np.array([[dict(res.params, c3=3e5)[n] for n in post.free]]))
    lp, code = post.evaluate(z)
    assert lp[0] == -np.inf and code[0] == 2
    lp, code = post.evaluate(post.coords(np.array([[dict(res.params, c2=2e4)[n] for n in post.free]])))
    assert lp[0] == -np.inf and code[0] == 3  # outside the prior box


def test_sample_recovers_laplace_and_truth(sine_fit, chains):
    rec, res = sine_fit
    d = chains.to_dict()
    for key in ("median", "q05", "q95", "tau"):
        assert set(d[key]) == set(FREE) | {"x0_x1", "x0_x2"}  # the initial state is sampled too
    assert chains.chain.shape == (400, 24, 7)
    assert sum(chains.counts.values()) == 24 * 400 + 24  # every proposal + the start ensemble
    assert 0.08 < d["acceptance"] < 0.5  # DE moves: ~0.1-0.3
    assert set(d["laplace"]) == set(FREE)
    for n in FREE:
        q = d["median"][n]
        se = res.stderr[n]
        # the posterior agrees with the independent Laplace approximation of the IPOPT fit ...
        assert abs(q - res.params[n]) < 1.0 * se
        half = 0.5 * (d["q84"][n] - d["q16"][n])
        assert 0.5 < half / se < 2.0
        # ... and its 95 % interval (q025..q975 ~ median +- 2 half) holds the truth
        assert abs(q - TRUTH[n]) < 3 * half
    # noise level: 2 % of the output RMS
    rms = math.sqrt(np.mean(np.asarray(rec.metadata["clean_y"]) ** 2))
    assert d["sigma"]["median"][0] == pytest.approx(0.02 * rms, rel=0.15)
    assert d["recheck"]["max_bias"] < 0.1 and d["recheck"]["failed"] == 0
    assert d["converged"] is False and any("50 tau" in w for w in d["warnings"])


def test_chains_roundtrip(chains, tmp_path):
    path = chains.save(tmp_path / "ch")
    assert path.suffix == ".npz"
    back = load_chains(path)
    np.testing.assert_array_equal(back.chain, chains.chain)
    assert back.names == chains.names and back.burn == chains.burn
    assert back.to_dict()["median"] == chains.to_dict()["median"]
    with pytest.raises(DataError, match="no such file"):
        load_chains(tmp_path / "missing.npz")


def test_too_short_raises_on_request(sine_fit):
    rec, res = sine_fit
    with pytest.raises(ChainTooShort) as info:
        sample(res, rec, n_walkers=16, n_steps=40, rng=0, on_short="raise", recheck_draws=0, sigma_draws=0)
    assert set(FREE) <= set(info.value.tau) and info.value.chains is not None


def test_bad_arguments(sine_fit):
    rec, res = sine_fit
    with pytest.raises(ModelError, match="n_walkers"):
        sample(res, rec, n_walkers=6, n_steps=10)
    with pytest.raises(ModelError, match="noise"):
        sample(res, rec, n_walkers=12, n_steps=10, noise="pink")
    with pytest.raises(DataError, match="same records"):
        sample(res, [rec, rec], n_walkers=12, n_steps=10)


def test_k3_ridge_detected_and_resolved_by_amplitudes():
    """Under one sine amplitude k3 trades against k1, k2 (a Fisher direction with sd ~ 1 of |k3|);
    records at three amplitudes pin it (sd several times smaller)."""
    free = FREE + ("k3",)
    one = synthetic_record(MODEL, TRUTH, Sine(1.0, 2.0), dt=0.005, duration=2.0, noise=0.02, rng=5)
    res1 = fit(Problem(MODEL, one, fixed={"A_f": TRUTH["A_f"]}, free=list(free)))
    rep1 = identifiability_report(res1, one)
    weak1 = [f for f in rep1.findings if "k3" in f["params"] and f["kind"] == "unidentifiable"]
    assert weak1, rep1.text
    assert {"k1", "k3"} <= set(weak1[0]["params"]) and "several amplitudes" in weak1[0]["resolve"]
    assert rep1.excitation["single_amplitude"]
    recs = [
        synthetic_record(MODEL, TRUTH, Sine(a, 2.0), dt=0.005, duration=2.0, noise=0.02, rng=6 + i)
        for i, a in enumerate((0.3, 0.6, 1.0))
    ]
    res3 = fit(Problem(MODEL, recs, fixed={"A_f": TRUTH["A_f"]}, free=list(free)))
    rep3 = identifiability_report(res3, recs)
    assert not rep3.excitation["single_amplitude"]
    assert not [f for f in rep3.findings if f["kind"] == "unidentifiable"], rep3.text
    assert rep3.params["k3"]["vif"] < rep1.params["k3"]["vif"] / 10

    # the k3 coordinate's sd along its weakest direction, absolute units
    def k3_sd(rep, res):
        Finv = np.linalg.inv(rep.fisher)
        j = list(rep.free).index("k3")
        scale = max(abs(res.params["k3"]), 100.0)
        return math.sqrt(Finv[j, j]) * scale

    sd1, sd3 = k3_sd(rep1, res1), k3_sd(rep3, res3)
    assert sd3 < sd1 / 5, (sd1, sd3)
    assert abs(res3.params["k3"] - 0.0) < 3 * sd3  # the truth is k3 = 0


def test_symmetry_unbroken_when_af_free():
    rec = synthetic_record(MODEL, TRUTH, Sine(1.0, 2.0), dt=0.005, duration=1.0, noise=0.02, rng=2)
    res = fit(Problem(MODEL, rec, fixed={"A_f": TRUTH["A_f"]}))
    # pretend A_f was free as well: the report must name the exact symmetry
    from dataclasses import replace

    res_af = replace(
        res,
        free=tuple(res.free) + ("A_f",),
        fixed={"k3": 0.0},
        covariance=np.full((6, 6), np.nan),
        stderr=dict(res.stderr, A_f=math.nan),
    )
    rep = identifiability_report(res_af, rec)
    sym = [f for f in rep.findings if f["kind"] == "symmetry"]
    assert sym and "A_f" in sym[0]["params"] and "no data can" in sym[0]["resolve"]
    assert rep.directions[0]["symmetry_overlap"] > 0.99  # the weakest Fisher direction is the symmetry


def test_cli_sample(sine_fit, tmp_path, capsys):
    from duffsym.cli import main

    rec, res = sine_fit
    csv = tmp_path / "rec.csv"
    write_csv(rec, csv)
    fitp = tmp_path / "fit.json"
    res.save(fitp)
    corner = tmp_path / "corner.png"
    rc = main(
        [
            "sample",
            str(csv),
            "--fit",
            str(fitp),
            "--walkers",
            "16",
            "--steps",
            "60",
            "--json",
            "--quiet",
            "--corner",
            str(corner),
            "--chains",
            str(tmp_path / "c.npz"),
        ]
    )
    out = json.loads(capsys.readouterr().out)
    assert rc == 0
    for key in ("median", "q05", "q95", "tau", "ess", "acceptance", "converged", "laplace", "warnings"):
        assert key in out
    assert set(FREE) <= set(out["median"]) and corner.stat().st_size > 10_000
    assert load_chains(tmp_path / "c.npz").n_steps == 60
    assert main(["sample", str(csv), "--fit", str(tmp_path / "nope.json"), "--quiet"]) == 2
    assert "no such file" in capsys.readouterr().err
    assert main(["sample", str(csv), "--fit", str(fitp), "--walkers", "4", "--steps", "10", "--quiet"]) == 2
    assert "n_walkers" in capsys.readouterr().err
    # a fit made with a mask: FIT.json stores it and `sample` leaves the same samples out by default
    masked = tmp_path / "masked.json"
    assert (
        main(["fit", str(csv), "--af", str(TRUTH["A_f"]), "--mask", "auto", "--out", str(masked), "--json", "--quiet"])
        == 0
    )
    n_masked = json.loads(capsys.readouterr().out)["n_masked"][0]
    assert n_masked > 0
    assert (
        main(["sample", str(csv), "--fit", str(masked), "--walkers", "16", "--steps", "20", "--json", "--quiet"]) == 0
    )
    assert json.loads(capsys.readouterr().out)["records"][0]["n_masked"] == n_masked
    short = tmp_path / "short.csv"
    write_csv(rec.replace(t=rec.t[:300], d=rec.d[:300], y=rec.y[:300], d_dot=rec.d_dot[:300]), short)
    assert main(["sample", str(short), "--fit", str(masked), "--quiet"]) == 2
    assert "stored mask has" in capsys.readouterr().err


def test_serial_and_vectorized_chains_agree(sine_fit):
    """The per-walker path (used with a pool) and the batch path give the same chain for the same seed."""
    rec, res = sine_fit
    kw = dict(n_walkers=16, n_steps=25, rng=4, recheck_draws=0, sigma_draws=0)
    with pytest.warns(ConvergenceWarning):
        a = sample(res, rec, **kw)
    with pytest.warns(ConvergenceWarning):
        b = sample(res, rec, vectorize=False, **kw)
    np.testing.assert_allclose(a.chain, b.chain, rtol=1e-12)
    assert a.counts == b.counts and sum(a.counts.values()) == 16 * 26


@pytest.mark.slow
def test_calibration_of_90_percent_intervals():
    """Over 20 synthetic seeds the 90 % intervals of the five identifiable parameters cover the truth
    at a pooled rate compatible with 90 % (100 intervals: 0.82..0.97 holds with probability ~0.99).
    The full table (40 seeds, per parameter) is benchmarks/bench_sample.py --calibration 40."""
    hits = []
    for i in range(20):
        rec = synthetic_record(MODEL, TRUTH, Sine(1.0, 2.0), dt=0.005, duration=2.0, noise=0.02, rng=5000 + i)
        res = fit(Problem(MODEL, rec, fixed={"A_f": TRUTH["A_f"]}))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)  # 2000 steps ~ 15-30 tau: enough for 5/95 %
            ch = sample(res, rec, n_walkers=32, n_steps=2000, rng=i, recheck_draws=0, sigma_draws=0)
        iv = ch.interval(0.9)
        hits += [iv[n][0] <= TRUTH[n] <= iv[n][1] for n in FREE]
    assert 0.82 <= np.mean(hits) <= 0.97, np.mean(hits)


def test_sampling_a_fit_with_an_effect_state():
    """A fit with an output lag (a third state) can be sampled: the substep schedule uses the kernel's
    own stiffness measure (Gershgorin for n > 2). With exact eigenvalues the kernel judged the schedule
    too coarse at the optimum itself and no walker could start. The lag is recovered within its
    posterior interval."""
    from duffsym.effects import CATALOGUE, apply_effects
    from duffsym.uncertainty._setup import spectral_bound

    lagged = apply_effects(MODEL, [CATALOGUE["output-lag"]])
    truth = {**TRUTH, "lag_tau": 0.01}
    rec = synthetic_record(lagged, truth, Sine(1.0, 2.0), dt=0.005, duration=2.0, noise=0.01, rng=5)
    res = fit(Problem(lagged, rec, fixed={"A_f": TRUTH["A_f"]}))
    assert res.success and abs(res.params["lag_tau"] / 0.01 - 1) < 0.1
    post, model, _, _ = build_posterior(res, [rec])
    J = np.array([[0.0, 1.0, 0.0], [-500.0, -20.0, 0.0], [0.0, 1.6 / 0.01, -1 / 0.01]])
    assert spectral_bound(lagged, J[None])[0] >= np.max(np.abs(np.linalg.eigvals(J)))  # a bound, never below
    with pytest.warns(ConvergenceWarning):
        ch = sample(res, rec, n_walkers=20, n_steps=60, rng=1)
    d = ch.to_dict()
    assert "x0_z_lag" in d["median"]
    # proposals far into the tails (a much shorter lag) are stiffer than the schedule and are
    # rejected as such: measured 144 of 1220 evaluations on this short chain
    assert ch.counts["ok"] > 0.7 * sum(ch.counts.values())
    assert abs(d["median"]["lag_tau"] / 0.01 - 1) < 0.05
    assert d["q05"]["lag_tau"] < res.params["lag_tau"] < d["q95"]["lag_tau"]
