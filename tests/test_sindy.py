"""SINDy cross-check: the library comes from the model, the recovery is checked against known truth.

Synthetic records have documented parameters (Table 2, 0.4 V row); the checks compare the
selected term set with the true one and the coefficients with the values the SymPy right-hand
side gives for the true parameters, so every assertion can fail.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from duffsym.data import synthetic_record
from duffsym.effects import CATALOGUE, apply_effects
from duffsym.errors import DataError, ModelError
from duffsym.excitation import BandLimitedRandom, Sine
from duffsym.model import get_model
from duffsym.model.presets import TABLE2
from duffsym.sindy import CrossCheckOptions, candidate_library, crosscheck, sindy_evidence, split_terms

TRUTH = dict(TABLE2[0.4])
TRUE_TERMS = {"x", "x_dot", "x_dot^5", "d", "d_dot"}


@pytest.fixture(scope="module")
def model():
    return get_model("mr-damper", 5)


def _rich(model, noise, seed=0, duration=12.0):
    exc = BandLimitedRandom(rms=0.7, f_max=4.0, duration=duration, seed=seed)
    return synthetic_record(model, TRUTH, exc, dt=0.002, duration=duration, noise=noise, settle=2.0, rng=seed)


def test_library_coefficients_come_from_the_sympy_rhs(model):
    lib = candidate_library(model)
    coef = dict(zip(lib.names, lib.coefficients(TRUTH)))
    # Eq. 12: x'' = -(c1+c2) x' - (k1+k2) x - k3 x^5 - c3 x'^5 + k1 d + c1 d'
    assert coef["x_dot"] == -(TRUTH["c1"] + TRUTH["c2"])
    assert coef["x"] == -(TRUTH["k1"] + TRUTH["k2"])
    assert coef["x_dot^5"] == -TRUTH["c3"] and coef["d"] == TRUTH["k1"] and coef["d_dot"] == TRUTH["c1"]
    assert coef["x^5"] == 0.0  # k3 = 0 in Table 2
    # the library matrix times these coefficients is the model's acceleration at random points
    rng = np.random.default_rng(3)
    X, U = rng.normal(size=(50, 2)), rng.normal(size=(50, 2))
    from duffsym.codegen.numpy_rhs import numpy_model

    acc = numpy_model(model).rhs(X, U, model.param_vector(TRUTH))[:, 1]  # generated independently of the library
    np.testing.assert_allclose(lib.evaluate(X, U) @ lib.coefficients(TRUTH), acc, rtol=1e-12, atol=1e-9)


def test_library_takes_the_catalogue_terms_that_reach_the_velocity_equation(model):
    lib = candidate_library(model)
    fric = [t for t in lib.terms if t.effect == "coulomb-friction"]
    assert len(fric) == 1 and str(fric[0].coefficient) == "-fric_mu" and "tanh" in fric[0].name
    assert "force-offset" in lib.not_visible and "output-lag" in lib.not_visible
    assert (
        split_terms(model.rhs[1], model.states + model.input_symbols)[model.input_symbols[0]]
        == model.param("k1").symbol
    )


def test_noise_free_rich_excitation_recovers_terms_and_coefficients(model):
    rec = _rich(model, 0.0)
    res = crosscheck(rec, model, params=TRUTH, n_models=10)
    assert res.verdict == "consistent", res.summary()
    assert set(res.selected) == TRUE_TERMS
    for name in TRUE_TERMS:
        t = res.term(name)
        assert abs(t["coefficient"] - t["model_coefficient"]) <= 0.005 * abs(t["model_coefficient"]), name
    assert res.missing_terms() == []


def test_one_percent_noise_keeps_the_term_set(model):
    res = crosscheck(_rich(model, 0.01, seed=1), model, params=TRUTH, n_models=10)
    assert set(res.selected) == TRUE_TERMS, res.summary()
    assert res.verdict == "consistent"
    assert abs(res.term("x_dot^5")["coefficient"] / -TRUTH["c3"] - 1) < 0.05


def test_hidden_friction_is_flagged_as_a_missing_sign_term(model):
    truth_model = apply_effects(model, [CATALOGUE["coulomb-friction"]])
    # 20 s: at 12 s this friction level is sometimes confused with x'|x'| (inclusion unstable -> inconclusive)
    exc = BandLimitedRandom(rms=0.7, f_max=4.0, duration=20.0, seed=3)
    rec = synthetic_record(
        truth_model, {**TRUTH, "fric_mu": 5.0}, exc, dt=0.002, duration=20.0, noise=0.01, settle=2.0, rng=3
    )
    ev = sindy_evidence(rec, model=model, params=TRUTH, n_models=10)
    assert ev["verdict"] == "missing-terms" and ev["conclusive"]
    top = ev["missing_terms"][0]
    assert top["effect"] == "coulomb-friction" and top["supported"]
    assert abs(-top["coefficient"] - 5.0) < 0.5  # the coefficient is -mu


def test_an_effect_outside_the_library_gives_inconclusive_not_a_wrong_term(model):
    # output-lag filters the measured force: no term of x'' in (x, x', d, d') represents it, and a plain
    # selection would blame tanh(x'/eps); the systematic residual and the poor fit must stop that
    lag_model = apply_effects(model, [CATALOGUE["output-lag"]])
    exc = BandLimitedRandom(rms=0.7, f_max=4.0, duration=12.0, seed=2)
    rec = synthetic_record(
        lag_model, {**TRUTH, "lag_tau": 0.01}, exc, dt=0.002, duration=12.0, noise=0.01, settle=2.0, rng=2
    )
    res = crosscheck(rec, model, params=TRUTH, n_models=10)
    assert res.verdict == "inconclusive", res.summary()
    assert not any(m["supported"] for m in res.missing_terms())


def test_output_offset_of_a_fitted_effect_is_removed_before_the_velocity_is_rebuilt(model):
    offset_model = apply_effects(model, [CATALOGUE["force-offset"]])
    truth = {**TRUTH, "off_y0": 0.3}
    exc = BandLimitedRandom(rms=0.7, f_max=4.0, duration=8.0, seed=2)
    rec = synthetic_record(offset_model, truth, exc, dt=0.002, duration=8.0, noise=0.0, settle=2.0, rng=2)
    res = crosscheck(rec, offset_model, params=truth, n_models=10)
    assert res.verdict == "consistent" and set(res.selected) == TRUE_TERMS
    assert abs(res.term("x_dot^5")["coefficient"] / -TRUTH["c3"] - 1) < 0.01
    with pytest.raises(ModelError, match="off_y0"):
        crosscheck(rec, offset_model, n_models=10)


def test_single_sine_at_the_paper_sampling_is_inconclusive(model):
    rec = synthetic_record(model, TRUTH, Sine(1.0, 2.0), dt=0.005, duration=5.0, noise=0.02, settle=2.0, rng=0)
    res = crosscheck(rec, model, params=TRUTH, n_models=10)
    assert res.verdict == "inconclusive", res.summary()
    assert res.reasons and not res.evidence()["conclusive"]
    assert all(not m["supported"] for m in res.missing_terms())


def test_smoothed_differences_at_coarse_sampling_are_inconclusive(model):
    rec = synthetic_record(model, TRUTH, Sine(1.0, 2.0), dt=0.005, duration=5.0, noise=0.0, settle=2.0, rng=0)
    res = crosscheck(rec, model, params=TRUTH, method="smoothed", n_models=10)
    assert res.verdict == "inconclusive"
    assert res.diagnostics["sampling_change"] > res.thresholds["max_sampling_change"]


def test_too_few_bootstrap_fits_cannot_conclude(model):
    res = crosscheck(_rich(model, 0.0, duration=6.0), model, params=TRUTH, n_models=4)
    assert set(res.selected) == TRUE_TERMS  # the selection is right, but its stability is not measured
    assert res.verdict == "inconclusive" and "too few" in res.reasons[0]


def test_bad_input(model):
    rec = _rich(model, 0.0, duration=4.0)
    with pytest.raises(ModelError, match="method must be one of"):
        crosscheck(rec, model, method="exact")
    with pytest.raises(ModelError, match="proportional to the velocity|output"):
        crosscheck(rec, get_model("duffing"))
    with pytest.raises(ModelError, match="selection must be one of"):
        crosscheck(rec, model, selection="lasso")
    with pytest.raises(DataError, match="at least one record"):
        crosscheck([], model)
    with pytest.raises(DataError, match="shorter than one weak-form window"):
        crosscheck(rec, model, window=10.0)


def test_options_object_and_keyword_settings_give_the_same_check(model):
    """crosscheck(rec, model, CrossCheckOptions(...)) and the keyword call are one check; a keyword replaces the
    option's field; a name that is no setting is a TypeError naming it."""
    rec = _rich(model, 0.0, duration=6.0)

    def text(check):  # NaN-aware comparison of the whole result
        return json.dumps(check.to_dict(), sort_keys=True)

    by_keywords = crosscheck(rec, model, params=TRUTH, n_models=4, selection="ssr", rng=3)
    opts = CrossCheckOptions(n_models=4, selection="ssr", rng=3)
    assert text(crosscheck(rec, model, opts, params=TRUTH)) == text(by_keywords)
    assert text(
        crosscheck(rec, model, CrossCheckOptions(n_models=7, selection="ssr"), params=TRUTH, n_models=4, rng=3)
    ) == text(by_keywords)
    assert set(by_keywords.selected) == TRUE_TERMS and by_keywords.diagnostics["n_models"] == 4
    with pytest.raises(TypeError, match="n_model"):
        crosscheck(rec, model, params=TRUTH, n_model=4)
    with pytest.raises(TypeError, match="fit and params"):
        CrossCheckOptions().with_settings(seed=1)


def test_shared_sparse_path_recovers_a_known_support():
    """The one sparse-regression path (sindy.sparse) on b = 2 g1 - 3 g4 + noise over 8 correlated columns:
    every path (best subsets, pysindy SSR, sklearn OMP) has {1, 4} at size 2, the residual rule and the
    held-out rule stop there, and the coefficients are the true ones within the noise."""
    from duffsym.sindy import sparse

    rng = np.random.default_rng(0)
    G = rng.normal(size=(400, 8))
    G[:, 5] = G[:, 1] + 0.3 * rng.normal(size=400)  # a collinear decoy of the true column 1
    b = 2.0 * G[:, 1] - 3.0 * G[:, 4] + 0.01 * rng.normal(size=400)
    for method in sparse.PATHS:
        path = sparse.sparse_path(G, b, method, max_terms=3)
        two = [sup for sup, _ in path if sup.size == 2]
        assert [sorted(s.tolist()) for s in two] == [[1, 4]], method
    c = sparse.sparsest_acceptable(G, b, n_eff=400, tolerance=1e-4)
    assert np.flatnonzero(c).tolist() == [1, 4]
    np.testing.assert_allclose(c[[1, 4]], [2.0, -3.0], atol=2e-3)
    np.testing.assert_allclose(sparse.stlsq(G, b, threshold=0.5)[[1, 4]], [2.0, -3.0], atol=2e-3)
    support, scores, _ = sparse.validated_support(G, b, 300, max_terms=3, parsimony=1.05)
    assert sorted(support) == [1, 4] and scores[2] < 1e-3 * scores[0]
    stab = sparse.stability_selection(
        G, b, np.array_split(np.arange(400), 8), [f"g{j}" for j in range(8)], resamples=10, max_terms=3, parsimony=1.05
    )
    assert stab["family"] == {"g1": 1.0, "g4": 1.0}


def test_cli_sindy_json(tmp_path, model, capsys):
    from duffsym.cli import main
    from duffsym.data import write_csv

    path = write_csv(_rich(model, 0.0, duration=8.0), tmp_path / "rich.csv")
    assert main(["sindy", str(path), "--json", "--models", "10", "--quiet"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["verdict"] == "consistent" and set(out["selected"]) == TRUE_TERMS
    assert main(["sindy", str(tmp_path / "missing.csv")]) == 2
    assert "no such file" in capsys.readouterr().err


@pytest.mark.slow
def test_one_percent_noise_term_set_over_twenty_seeds(model):
    """Target: the exact term set in at least 18 of 20 seeds (measured 20/20 with 20 s records, s09)."""
    exact = 0
    for seed in range(20):
        res = crosscheck(_rich(model, 0.01, seed=seed, duration=20.0), model, params=TRUTH, n_models=10, rng=seed)
        exact += set(res.selected) == TRUE_TERMS and res.verdict == "consistent"
    assert exact >= 18


@pytest.mark.slow
def test_cli_sindy_with_a_fit_compares_coefficients(tmp_path, model, capsys):
    from duffsym.cli import main
    from duffsym.data import write_csv

    path = write_csv(_rich(model, 0.01, seed=4, duration=12.0), tmp_path / "rich.csv")
    fit_path = tmp_path / "fit.json"
    assert main(["fit", str(path), "--out", str(fit_path), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["sindy", str(path), "--fit", str(fit_path), "--json", "--quiet", "--models", "10"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["reference"] == "fit" and out["verdict"] == "consistent"
    for t in out["terms"]:
        if t["name"] in TRUE_TERMS:
            assert t["agrees"] is True, t
            assert t["model_stderr"] is not None


def test_real_damper_single_sine_is_not_given_a_confident_verdict():
    """UTFSM 1 kHz test (skipped without the external data): inconclusive, with measured reasons."""
    from duffsym.data import external_data_dir, load_mr_damper_utfsm

    try:
        path = external_data_dir() / "mr_damper_utfsm_quiroz2022" / "sinusoidal_preprocessed" / "10mm1Hz1A.txt"
    except DataError:
        pytest.skip("external data folder absent")
    if not path.is_file():
        pytest.skip(f"{path} absent")
    res = crosscheck(load_mr_damper_utfsm(path, velocity="derive"), n_models=10)
    assert res.verdict == "inconclusive" and res.reasons
    assert res.gain == pytest.approx(float(np.max(np.abs(load_mr_damper_utfsm(path).y))))
