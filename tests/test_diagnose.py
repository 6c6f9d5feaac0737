"""The diagnosis on data with a known hidden effect: the right effect first, its parameter recovered,
the held-out error at least halved; no false positive on clean data; no confident wrong verdict for
an effect outside the catalogue; the ladder adds two hidden effects and stops at the noise.

The default run restricts the candidates to a few effects to stay fast; the slow tests try the whole
catalogue on every effect (``pytest -m slow``), and ``benchmarks/bench_diagnose.py`` gives the
confusion matrix over ten seeds per effect.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from duffsym.cli import main
from duffsym.data import synthetic_record, write_csv
from duffsym.diagnose import diagnose, ladder
from duffsym.diagnose.scenarios import HIDDEN, hidden_effect_record, noise_nrmse
from duffsym.effects import CATALOGUE, apply_effects
from duffsym.excitation import Sine
from duffsym.model.library import mr_damper
from duffsym.model.presets import table2_params

FEW = ["force-offset", "output-lag", "coulomb-friction"]


def check_found(dg, hidden: str, record) -> None:
    """``hidden`` is first and needed, its parameters recovered, the held-out error at least halved."""
    best = dg.best
    assert best.effect == hidden and dg.needed == (hidden,), dg.summary()
    for p, true in HIDDEN[hidden].items():
        assert best.params[p] == pytest.approx(true, rel=0.15), (p, best.params, best.stderr)
    assert best.nrmse_after <= dg.nrmse_heldout / 2
    k = dg.split["n_fit"]
    assert best.nrmse_after <= 2 * noise_nrmse(record, slice(k, None))  # close to the noise floor
    assert hidden in dg.verdict


def test_hidden_output_lag_is_found_first_and_recovered():
    """The record comes from the independent generator (tests/independent_sim.py: no duffsym code), so the
    diagnosis is not judged on data its own effect code made: a load-cell lag on a sine, 0.2 V row."""
    import independent_sim as gen
    from duffsym.data.record import Record

    g = gen.scenario("output-lag", 0, kind="sine", voltage=0.2)
    rec = Record(t=g.t, d=g.d, y=g.y, name="output-lag-0", source="independent_sim")
    dg = diagnose(rec, fixed={"A_f": g.truth["params"]["A_f"]}, candidates=FEW)
    best = dg.best
    assert best.effect == "output-lag" and dg.needed == ("output-lag",), dg.summary()
    assert best.params["lag_tau"] == pytest.approx(g.truth["physics"]["lag"], rel=0.15)
    assert best.nrmse_after <= dg.nrmse_heldout / 2
    k = dg.split["n_fit"]
    assert best.nrmse_after <= 2 * g.noise_std / np.std(rec.y[k:])  # close to the noise floor
    assert "output-lag" in dg.verdict
    assert [c.effect for c in dg.candidates][0] == "output-lag"
    assert not dg.residuals.at_noise_level


def test_hidden_friction_under_random_input_is_found():
    """Friction inside the fluid model on a band-limited random input (0.4 V row), in a record of the
    independent generator (tests/independent_sim.py: no duffsym code)."""
    import independent_sim as gen
    from duffsym.data.record import Record

    g = gen.scenario("coulomb-friction", 2, kind="random", voltage=0.4)
    rec = Record(t=g.t, d=g.d, y=g.y, name="coulomb-friction-2", source="independent_sim")
    dg = diagnose(rec, fixed={"A_f": g.truth["params"]["A_f"]}, candidates=FEW)
    best = dg.best
    assert best.effect == "coulomb-friction" and dg.needed == ("coulomb-friction",), dg.summary()
    assert best.params["fric_mu"] == pytest.approx(g.truth["physics"]["internal_friction"], rel=0.15)
    assert best.nrmse_after <= dg.nrmse_heldout / 2
    k = dg.split["n_fit"]
    assert best.nrmse_after <= 2 * g.noise_std / np.std(rec.y[k:])  # close to the noise floor


def _independent(effect: str, seed: int, **kw):
    """A record of the independent generator (tests/independent_sim.py: no duffsym code) and its truth."""
    import independent_sim as gen
    from duffsym.data.record import Record

    g = gen.scenario(effect, seed, **kw)
    return Record(t=g.t, d=g.d, y=g.y, name=f"{effect}-{seed}", source="independent_sim"), g


def test_clean_data_need_no_effect():
    rec, _ = _independent("clean", 1, kind="multisine", voltage=0.3)
    dg = diagnose(rec, candidates=FEW)
    assert dg.needed == ()
    assert dg.residuals.at_noise_level
    assert dg.verdict.startswith("The model fits to the noise")
    # nothing improves the held-out error by more than a few per cent
    assert all(c.nrmse_after >= 0.95 * dg.nrmse_heldout for c in dg.candidates if c.success)


def test_drift_outside_the_catalogue_gets_no_confident_wrong_verdict():
    rec, _ = _independent("drift", 0)  # the damping falls by half over the record
    dg = diagnose(rec, candidates=["input-delay", "output-lag", "inertia", "force-offset"])
    assert dg.needed == ()
    assert dg.verdict.startswith("No catalogued effect explains")
    assert "grows with time" in dg.verdict


@pytest.mark.slow
def test_ladder_adds_two_hidden_effects_and_stops_at_the_noise():
    m = mr_damper()
    truth = {**table2_params(0.5), "off_y0": 0.2, "lag_tau": 0.008}
    hidden = apply_effects(m, [CATALOGUE["force-offset"], CATALOGUE["output-lag"]])
    rec = synthetic_record(hidden, truth, Sine(1.0, 2.0), dt=0.005, duration=4.0, noise=0.01, rng=5)
    lad = ladder(rec, m, candidates=FEW, fixed={"A_f": truth["A_f"]})
    assert [s.effects for s in lad.steps] in (
        [(), ("force-offset",), ("force-offset", "output-lag")],
        [(), ("output-lag",), ("output-lag", "force-offset")],
    ), lad.summary()
    held = [s.nrmse_heldout for s in lad.steps]
    assert held[0] > held[1] > held[2]
    assert held[2] <= 1.5 * noise_nrmse(rec, slice(lad.steps[0].diagnosis.split["n_fit"], None))
    final = lad.final_fit
    assert final.success
    assert final.params["off_y0"] == pytest.approx(0.2, rel=0.05)
    assert final.params["lag_tau"] == pytest.approx(0.008, rel=0.1)


# ------------------------------------------------------------------------------------------------ CLI
OFFSET_SEED = 1  # the independent generator's force-offset record, seed 1


@pytest.fixture(scope="module")
def offset_csv(tmp_path_factory):
    """A load-cell offset hidden in a record of the independent generator (tests/independent_sim.py: no duffsym
    code), written as CSV for the command line."""
    import independent_sim as gen
    from duffsym.data.record import Record

    g = gen.scenario("force-offset", OFFSET_SEED)
    rec = Record(t=g.t, d=g.d, y=g.y, name="offset", source="independent_sim")
    path = tmp_path_factory.mktemp("diag") / "offset.csv"
    write_csv(rec, path)
    return path


def _true_offset() -> float:
    import independent_sim as gen

    return gen.scenario("force-offset", OFFSET_SEED).truth["physics"]["offset"]


def test_cli_diagnose_json_follows_the_contract(offset_csv, capsys, tmp_path):
    code = main(
        [
            "diagnose",
            str(offset_csv),
            "--candidates",
            "force-offset,output-lag",
            "--json",
            "--quiet",
            "--report",
            str(tmp_path / "rep"),
        ]
    )
    out = capsys.readouterr()
    assert code == 0
    doc = json.loads(out.out)
    assert doc["needed"] == ["force-offset"]
    assert [c["effect"] for c in doc["candidates"]] == ["force-offset", "output-lag"]
    first = doc["candidates"][0]
    assert first["params"]["off_y0"] == pytest.approx(_true_offset(), rel=0.05)
    assert first["delta_bic"] < -100 and first["nrmse_after"] < doc["nrmse"] / 5
    assert isinstance(doc["verdict"], str) and "force-offset" in doc["verdict"]
    md = (tmp_path / "rep" / "diagnosis.md").read_text()
    assert "force-offset" in md and (tmp_path / "rep" / "where_it_fails.png").stat().st_size > 10_000


def test_cli_ladder_saves_a_fit_that_validate_reads(offset_csv, capsys, tmp_path):
    fit_path = tmp_path / "fit.json"
    code = main(
        [
            "ladder",
            str(offset_csv),
            "--candidates",
            "force-offset,output-lag",
            "--json",
            "--quiet",
            "--out",
            str(fit_path),
        ]
    )
    out = capsys.readouterr()
    assert code == 0
    doc = json.loads(out.out)
    assert [s["effects"] for s in doc["steps"]] == [[], ["force-offset"]]
    assert doc["steps"][1]["nrmse"] < doc["steps"][0]["nrmse"] / 5
    assert all(np.isfinite(s["bic"]) for s in doc["steps"])
    code = main(["validate", str(fit_path), str(offset_csv), "--json"])
    val = json.loads(capsys.readouterr().out)
    assert code == 0 and val["nrmse"] < 0.02


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--candidates", "viscous-heating"], "unknown effect"),
        (["--holdout", "0.95"], "holdout must be between"),
        (["--mask", "/nonexistent/mask.txt"], "no such file"),
        (["--decimate", "0"], "--decimate must be"),
    ],
)
def test_cli_diagnose_bad_options_exit_2_with_one_line(offset_csv, capsys, argv, message):
    code = main(["diagnose", str(offset_csv), "--quiet", *argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and message in err[0] and "Traceback" not in err[0]


# ------------------------------------------------------------------------------------------------ slow
#: seeds 0-2 of every scenario, with what bench_diagnose.py measured where it differs from "found
#: first, parameter within 15 %, held-out error halved and within 2x of the noise"
ABSORBED = {("input-shift", 0)}  # sine: the base parameters absorb a 4 ms shift; base already at the noise
NOT_HALVED = {("input-delay", 0)}  # sine: base 0.0176 -> 0.0098 (noise 0.0100): at the noise, not halved
WEAK = {
    ("backlash", 1): "multisine: backlash is called first but h = 0.036 for 0.05 and the held-out NRMSE "
    "falls only 0.119 -> 0.066 (noise 0.010): the smooth play fit stops short"
}


@pytest.mark.slow
@pytest.mark.parametrize("hidden", list(HIDDEN))
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_every_hidden_effect_is_found_with_the_whole_catalogue(hidden, seed, request):
    if (hidden, seed) in WEAK:
        request.applymarker(pytest.mark.xfail(reason=WEAK[(hidden, seed)], strict=True))
    rec = hidden_effect_record(hidden, seed)
    dg = diagnose(rec, fixed={"A_f": rec.metadata["truth"]["A_f"]})
    k = dg.split["n_fit"]
    floor = noise_nrmse(rec, slice(k, None))
    if (hidden, seed) in ABSORBED:
        assert dg.needed == () and dg.nrmse_heldout <= 1.1 * floor, dg.summary()
        return
    if (hidden, seed) in NOT_HALVED:
        assert dg.needed == (hidden,) and dg.best.effect == hidden
        for p, true in HIDDEN[hidden].items():
            assert dg.best.params[p] == pytest.approx(true, rel=0.15)
        assert dg.best.nrmse_after <= 1.1 * floor
        return
    check_found(dg, hidden, rec)


def test_cli_derive_shows_what_an_added_effect_does_to_the_lyapunov_argument(capsys):
    assert main(["derive", "--add", "coulomb-friction"]) == 0
    text = capsys.readouterr().out
    # the friction term dissipates: it enters dV/dt with its sign condition
    assert "-fric_mu*x2*tanh(100.0*x2) <= 0 when fric_mu >= 0" in text
    assert "dV/dt negative semi-definite: if (sufficient) c3 >= 0 and fric_mu >= 0 and c1 + c2 >= 0" in text
