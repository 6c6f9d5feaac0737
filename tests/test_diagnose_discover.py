"""Discovery of a term outside the catalogue, on records this package did not generate.

The record comes from a plain numpy RK4 simulator written here (it imports nothing of duffsym): the
normalised MR damper of Eq. 12 (Table 2's 0.4 V row) with a piston seal friction
``F_c·tanh(d'/ε)`` added to the measured force — friction on the piston velocity, which the
catalogue's ``coulomb-friction`` (on the internal velocity x') does not have — and 1 % noise.
The friction-like catalogue entries are withheld, as for an effect the catalogue lacks. The last
default test repeats it on the project's independent generator (``tests/independent_sim.py``).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import sympy as sp

P04 = dict(c1=10.0, c2=10.0, c3=320.0, k1=34.0, k2=480.0, A_f=1.6)


def seal_friction_record(
    f_c: float = 0.3,
    eps: float = 0.3,
    n: int = 1600,
    dt: float = 0.005,
    noise: float = 0.01,
    seed: int = 0,
    substeps: int = 20,
):
    """(t, d, d', y, sigma): RK4 at ``substeps`` per sample of x'' = k1(d-x) + c1(d'-x') - c2 x' - k2 x - c3 x'^5,
    y = A_f x' + f_c tanh(d'/eps) + noise; d = sin(2π·2t)."""
    w = 2 * np.pi * 2.0
    p = P04

    def rhs(t, s):
        d, v = np.sin(w * t), w * np.cos(w * t)
        x, xd = s
        return np.array([xd, p["k1"] * (d - x) + p["c1"] * (v - xd) - p["c2"] * xd - p["k2"] * x - p["c3"] * xd**5])

    t = np.arange(n) * dt
    s = np.zeros(2)
    xs = np.empty((n, 2))
    h = dt / substeps
    for i in range(n):
        xs[i] = s
        for j in range(substeps):
            tt = t[i] + j * h
            k1 = rhs(tt, s)
            k2 = rhs(tt + h / 2, s + h / 2 * k1)
            k3 = rhs(tt + h / 2, s + h / 2 * k2)
            k4 = rhs(tt + h, s + h * k3)
            s = s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    d, v = np.sin(w * t), w * np.cos(w * t)
    y = p["A_f"] * xs[:, 1] + f_c * np.tanh(v / eps)
    sigma = noise * float(np.sqrt(np.mean(y**2)))
    return t, d, v, y + np.random.default_rng(seed).normal(0, sigma, n), sigma


def _record(**kw):
    from duffsym.data import Record

    t, d, v, y, sigma = seal_friction_record(**kw)
    return Record(t=t, d=d, y=y, d_dot=v, name="seal-friction (independent RK4)"), sigma


def test_simulator_is_accurate():
    """The independent simulator converges: 20 and 40 substeps agree to far below the noise."""
    a = seal_friction_record(noise=0.0, n=400)[3]
    b = seal_friction_record(noise=0.0, n=400, substeps=40)[3]
    assert np.max(np.abs(a - b)) < 1e-6 * np.max(np.abs(a))


def test_discovered_effect_is_rebuilt_from_its_name():
    from duffsym.effects.discovered import DiscoveredEffect, from_name
    from duffsym.model.library import mr_damper
    from duffsym.model.symbols import state_symbol

    d, v, xd = state_symbol("d"), state_symbol("d_dot"), state_symbol("x_dot")
    eff = DiscoveredEffect((sp.tanh(v / sp.Float(0.27)), d * xd, v**3), (0.30185, -64.32, -6.965e-5))
    back = from_name(eff.name)
    assert back.name == eff.name and back.terms == eff.terms
    assert [p.name for p in back.parameters()] == [p.name for p in eff.parameters()]
    m = back.apply(mr_damper())
    assert m.effects == (eff.name,) and {"disc1_c1", "disc1_c2", "disc1_c3"} <= set(m.param_names)
    assert m.output.has(m.velocity) and m.output.has(sp.tanh)


def test_library_words_and_resemblance():
    from duffsym.effects.discovered import DiscoveredEffect, resembles, term_latex, term_words
    from duffsym.model.symbols import state_symbol

    v = state_symbol("d_dot")
    term = sp.tanh(v / sp.Float(0.02))
    eff = DiscoveredEffect((term,), (0.156,))
    assert eff.name == "discovered: +0.156·tanh(d'/0.02) on the output"
    assert "piston velocity" in resembles(term)
    assert r"\dot{d}" in term_latex(eff.expression(eff.coefs))
    assert term_words(-2.0 * state_symbol("d")) == "-2.0·d"


@pytest.mark.slow
@pytest.mark.ci
def test_seal_friction_is_discovered_when_the_catalogue_lacks_it(tmp_path, capsys):
    """Friction on d' withheld from the catalogue: ``duffsym ladder --discover`` adds a discovered
    tanh(d'/ε) term, names it in words, recovers F_c, and ends within 2x the noise on the held-out tail
    (the base model alone is far above); the JSON step carries "term" and "latex"."""
    from duffsym.cli import main
    from duffsym.data import write_csv
    from duffsym.diagnose.search import split_record

    rec, sigma = _record()
    path = tmp_path / "seal.csv"
    write_csv(rec, path)
    code = main(
        [
            "ladder",
            str(path),
            "--candidates",
            "force-offset,inertia",
            "--discover",
            "--json",
            "--quiet",
            "--no-sindy",
            "--report",
            str(tmp_path / "rep"),
            "--out",
            str(tmp_path / "fit.json"),
        ]
    )
    doc = json.loads(capsys.readouterr().out)
    assert code == 0
    first, last = doc["steps"][0], doc["steps"][-1]
    k = split_record(rec, 0.3)  # the held-out tail of the diagnosis (CLI default --holdout 0.3)
    floor = sigma / float(np.std(rec.y[k:]))
    assert first["nrmse_heldout"] > 4 * floor, doc["stopped"]
    names = [e for e in last["effects"] if e.startswith("discovered:")]
    assert names and "tanh(d'/" in names[0], last["effects"]
    assert last["nrmse_heldout"] <= 2 * floor, (last["nrmse_heldout"], floor)
    assert "d_dot" in last["term"] and "tanh" in last["latex"] and r"\dot{d}" in last["latex"]
    disc = last["discovered"]
    assert any("piston velocity" in r for r in disc["resembles"]), disc
    assert disc["delta_bic"] < -10 and disc["explained"] >= 0.5 and disc["needed"]
    # the fitted switch is the seal friction: its coefficient (force units) within 10 % of F_c = 0.3
    assert any(abs(v - 0.3) < 0.03 for v in disc["params"].values()), disc["params"]
    assert (tmp_path / "rep").is_dir()
    # the saved fit is read back with its discovered term (rebuilt from its name) and validates
    assert main(["validate", str(tmp_path / "fit.json"), str(path), "--json"]) == 0
    val = json.loads(capsys.readouterr().out)
    assert val["nrmse"] <= 2 * sigma / float(np.std(rec.y)), val["nrmse"]


def test_no_term_is_discovered_on_a_record_the_model_explains():
    """No seal friction (F_c = 0): the base model fits to the noise and discovery adds nothing."""
    from duffsym.diagnose import ladder

    rec, sigma = _record(f_c=0.0, n=1000, seed=3)
    lad = ladder(rec, candidates=["force-offset"], discover=True)
    assert lad.effects == (), lad.summary()
    assert not any(s.discovered for s in lad.steps)


@pytest.mark.slow
def test_utfsm_0a_discovery_is_judged_on_held_out_cycles():
    """Real MR damper (UTFSM, 25 mm 0.5 Hz 0 A, one of the four worst single-test fits): a term is
    proposed from the fitting part and judged on the held-out tail; a term the evidence calls needed
    lowers the held-out error, and the numbers are finite. (The before/after table of the four worst
    tests is ``benchmarks/bench_discover_utfsm.py``.)"""
    import sys
    from pathlib import Path

    from duffsym.data import external_data_dir
    from duffsym.errors import DataError

    try:
        base = external_data_dir() / "mr_damper_utfsm_quiroz2022"
    except DataError as exc:
        pytest.skip(f"external data not available: {exc}")
    if not base.is_dir():
        pytest.skip("UTFSM MR damper data not present")
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from bench_discover_utfsm import run

    row = run("25mm0x5Hz", 100)
    assert row["found"], row
    assert np.isfinite(row["nrmse_before"]) and np.isfinite(row["nrmse_after"])
    if row["needed"]:
        assert row["nrmse_after"] < row["nrmse_before"] and row["delta_bic"] < -10
    assert row["effect"].startswith("discovered: ") and row["latex"]


def test_seal_friction_from_the_independent_generator_is_discovered():
    """The same on the project's independent generator (tests/independent_sim.py, sine, 0.2 V row, 801
    samples), seal-friction and coulomb-friction withheld: a discovered tanh(d'/ε) term, F_c within 10 %,
    the held-out error within 2x the noise (measured: 0.0218 -> 0.0101, F_c 0.0715 for 0.0745)."""
    import independent_sim as gen
    from duffsym.data import Record
    from duffsym.diagnose import ladder
    from duffsym.diagnose.search import split_record

    g = gen.scenario("seal-friction", 0)
    rec = Record(t=g.t, d=g.d, y=g.y, name="seal-friction-0", source="independent_sim")
    lad = ladder(rec, candidates=["force-offset", "inertia"], discover=True, sindy=False)
    floor = g.truth["noise_std_raw"] / float(np.std(rec.y[split_record(rec, 0.3) :]))
    last = lad.steps[-1]
    assert last.discovered and "tanh(d'/" in last.effects[-1], lad.summary()
    assert last.nrmse_heldout <= 2 * floor < lad.steps[0].nrmse_heldout, (lad.summary(), floor)
    f_c = g.truth["physics"]["seal_friction"]
    assert any(abs(v - f_c) < 0.1 * f_c for v in last.discovered["params"].values()), last.discovered["params"]


def test_library_terms_that_repeat_an_added_effect_are_left_out():
    from duffsym.effects.discovered import duplicates
    from duffsym.model.symbols import state_symbol

    D, DD, DDD = state_symbol("d"), state_symbol("d_dot"), state_symbol("d_ddot")
    sign = sp.tanh(DD / sp.Float(0.05))
    assert duplicates(sign, ("seal-friction",)) == "seal-friction"  # F_c tanh(d'/eps): the effect's own term
    assert duplicates(sign, ("force-offset",)) == "" and duplicates(sign, ()) == ""
    assert duplicates(D**2 * sign, ("seal-friction",)) == ""  # a stroke-dependent level is new physics
    assert duplicates(DDD, ("inertia",)) == "inertia" and duplicates(D, ("gas-accumulator",)) == "gas-accumulator"
    assert duplicates(sp.Integer(1), ("gas-accumulator",)) == "gas-accumulator"  # its preload is the offset
