"""``duffsym fit``/``validate`` on records with invalid stretches and outside the fit's range: the stretch is
reported in one line, left out of the fit and the score (kept with --keep-invalid), FIT.json stores the
training ranges and the decimation, and validate notes a command and a frequency band the fit never saw.
Records from the independent generator (tests/independent_current_sim.py, numpy only)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import independent_current_sim as gen
from duffsym.cli import main

DISP = gen.Sines((0.45, 0.25, 0.12), (0.7, 1.6, 2.7), (0.0, 1.0, 2.0))
SWITCH = gen.Switching(0.05, 0.95, gen.Sines((1.0, 0.7, 0.5), (0.4, 0.9, 1.4), (0.3, 2.0, 4.0)), sharp=2.0)
N_BAD = 80


def _write(path, g, d=None, y=None):
    d = g["d"] if d is None else d
    y = g["y"] if y is None else y
    rows = "\n".join(",".join(f"{v:.10g}" for v in r) for r in zip(g["t"], d, y, g["command"]))
    path.write_text("time,displacement,force,current\n" + rows + "\n")
    return str(path)


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """A 3 s record at 200 Hz whose last 0.4 s hold the force at its maximum (clipped) and the displacement
    flat, fitted by the CLI."""
    tmp = tmp_path_factory.mktemp("sanity")
    g = gen.generate(gen.TRUTH, DISP, SWITCH, dt=0.005, duration=3.0, seed=3)
    y, d = g["y"].copy(), g["d"].copy()
    y[-N_BAD:] = np.max(y[:-N_BAD]) * 1.02  # the load cell's limit: above every valid sample
    d[-N_BAD:] = d[-N_BAD - 1]
    data = _write(tmp / "clipped.csv", g, d, y)
    out = tmp / "fit.json"
    assert main(["fit", data, "--model", "mr-damper-current", "--out", str(out), "--quiet"]) == 0
    return tmp, data, json.loads(out.read_text()), g


def test_fit_leaves_the_clipped_end_out(fitted, capsys):
    tmp, data, fit, g = fitted
    san = fit["data_sanity"]
    kinds = sorted((s["signal"], s["kind"]) for s in san["stretches"])
    assert kinds == [("displacement", "frozen"), ("force", "clipped")]
    n = g["t"].size
    assert san["kept"] == [0, n - N_BAD - 1] and fit["n_samples"] == n - N_BAD - 1
    assert fit["decimation"]["factor"] == 1  # 600 samples: fitted as they are
    assert fit["training_ranges"]["command"] == pytest.approx([g["command"].min(), g["command"].max()], abs=1e-6)
    assert fit["nrmse"] < 0.03  # the valid part is fitted well (1 % noise)


def test_validate_scores_valid_samples_and_keep_invalid_changes_it(fitted, capsys):
    tmp, data, fit, _ = fitted
    capsys.readouterr()
    assert main(["validate", str(tmp / "fit.json"), data, "--json"]) == 0
    cap = capsys.readouterr()
    left_out = json.loads(cap.out)
    assert "clipped" in cap.err and len([ln for ln in cap.err.splitlines() if "data check" in ln]) == 1
    assert left_out["nrmse"] < 0.03 and left_out["data_sanity"]["n_invalid"] == N_BAD + 1
    assert main(["validate", str(tmp / "fit.json"), data, "--json", "--keep-invalid"]) == 0
    kept = json.loads(capsys.readouterr().out)
    assert kept["nrmse"] > 3 * left_out["nrmse"]  # the clipped 0.4 s spoil the score when kept


def test_validate_notes_command_and_band_outside_the_fit(fitted, capsys):
    tmp, _, fit, _ = fitted
    higher = gen.Switching(0.05, 1.4, gen.Sines((1.0, 0.7, 0.5), (0.5, 1.1, 1.3), (0.1, 2.0, 4.0)), sharp=2.0)
    g2 = gen.generate(gen.TRUTH, gen.Sines((0.3,), (6.0,), (0.0,)), higher, dt=0.005, duration=2.0, seed=4)
    capsys.readouterr()
    assert main(["validate", str(tmp / "fit.json"), _write(tmp / "higher.csv", g2), "--json"]) == 0
    cap = capsys.readouterr()
    notes = json.loads(cap.out)["range_notes"]
    assert any(n.startswith("the current spans") for n in notes) and any("frequency band" in n for n in notes)
    assert all(n in cap.err for n in notes)
    # the training record itself: no note
    g = fitted[3]
    assert main(["validate", str(tmp / "fit.json"), _write(tmp / "same.csv", g), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["range_notes"] == []


def test_fit_decimates_a_long_record_and_reports_the_rate(tmp_path, capsys):
    """A 5001-sample record (independent generator, 1 kHz) is fitted at the rate the variance rule picks; the
    rate is on stderr and in FIT.json, with the free-run error on the full-rate record beside the fitted one."""
    from duffsym.data import Record
    from duffsym.data.decimate import prepare_for_fit
    from independent_sim import scenario

    g = scenario("clean", 1, kind="sine", dt=0.001, duration=5.0)
    path = tmp_path / "long.csv"
    path.write_text(
        "time,displacement,force\n" + "\n".join(f"{a:.10g},{b:.10g},{c:.10g}" for a, b, c in zip(g.t, g.d, g.y)) + "\n"
    )
    expect = prepare_for_fit(Record(t=g.t, d=g.d, y=g.y))[0].factor
    out = tmp_path / "fit.json"
    assert main(["fit", str(path), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    fit = json.loads(out.read_text())
    dec = fit["decimation"]
    assert expect > 1 and dec["factor"] == expect and f"decimated by {expect}" in err
    assert fit["n_samples"] == -(-g.t.size // expect) and dec["rate_hz"] == pytest.approx(1000.0 / expect)
    assert dec["nrmse_full_rate"] < 0.05 and abs(dec["nrmse_full_rate"] - fit["nrmse"]) < 0.02
