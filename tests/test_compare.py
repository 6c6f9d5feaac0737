"""``duffsym compare`` and ``duffsym.compare()`` on records of the independent Bouc-Wen generator: the true model
wins on held-out data at the noise level, the static Bingham law cannot follow the loop, and the table, JSON and
figure say so; bad input gives a one-line error."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import independent_classical_sim as ics
from duffsym.cli import main
from duffsym.data import Record
from duffsym.diagnose.compare import compare, split_records

TRUTH = dict(c0=20.0, k0=40.0, x0=0.0, A=4e4, gamma=0.015, beta=0.01)
DRIVES = [ics.Sines((1.0, 0.4), (1.5, 4.1), (0.3, 1.1)), ics.Sines((0.6, 0.3), (2.0, 3.1), (0.3, 1.1))]


@pytest.fixture(scope="module")
def records():
    out = []
    for s, drive in enumerate(DRIVES):
        t, d, v, _, y, _ = ics.record("bouc-wen", TRUTH, duration=2.0, fs=300.0, drive=drive, noise=0.01, seed=s)
        out.append(Record(t=t, d=d, y=y, d_dot=v, name=f"bw{s}"))
    return out


@pytest.fixture(scope="module")
def comparison(records):
    return compare(records, ["bouc-wen", "bingham"], n_starts=2)


def test_the_true_model_wins_at_the_noise_level(comparison):
    bw, bi = comparison.scores
    assert comparison.best().model == "bouc-wen"
    assert 0.008 < bw.heldout_nrmse < 0.013  # 1 % noise
    assert bi.heldout_nrmse > 0.3  # a static law misses the pre-yield loop
    assert bw.bic < bi.bic
    assert (bw.n_params, bi.n_params) == (6, 3)
    assert bw.certificate == "Bouc-Wen z bound (literature): holds" and bi.certificate == "none derived"
    assert bw.substeps_max >= 1 and bw.sim_seconds_per_sample > 0
    assert 1 <= bw.starts_at_best <= bw.starts == 2


def test_heldout_is_the_tail_scored_from_a_continued_run(records, comparison):
    """The held-out error recomputed from the stored prediction and the record's last 30 %."""
    train, tails = split_records(records, 0.3)
    assert [r.n_times for r in train] == [420, 420] and tails == [420, 420]
    y = np.asarray(records[0].y)[420:]
    pred = comparison.predictions["bouc-wen"]["bw0"]
    assert pred.size == y.size
    err = math.sqrt(np.mean((y - pred) ** 2)) / math.sqrt(np.mean((y - y.mean()) ** 2))
    assert err == pytest.approx(comparison.scores[0].heldout_records["bw0"], rel=1e-9)


def test_summary_and_dict(comparison):
    text = comparison.summary()
    assert "best held-out: bouc-wen" in text and "bingham" in text
    d = comparison.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["best"] == "bouc-wen" and d["models"][0]["start_fraction"] <= 1.0


def _csv(tmp_path, rec, name):
    path = tmp_path / name
    np.savetxt(
        path,
        np.column_stack([rec.t, rec.d, rec.d_dot, rec.y]),
        delimiter=",",
        header="time,displacement,velocity,force",
        comments="",
    )
    return path


def test_cli_compare_with_validation_files(tmp_path, records, capsys):
    a, b = _csv(tmp_path, records[0], "a.csv"), _csv(tmp_path, records[1], "b.csv")
    out, fig = tmp_path / "c.json", tmp_path / "c.png"
    rc = main(
        [
            "compare",
            str(a),
            "--validate",
            str(b),
            "--models",
            "bouc-wen,bingham",
            "--starts",
            "1",
            "--out",
            str(out),
            "--plot",
            str(fig),
            "--json",
            "--quiet",
        ]
    )
    assert rc == 0
    printed = json.loads(capsys.readouterr().out)
    saved = json.loads(out.read_text())
    assert printed["best"] == saved["best"] == "bouc-wen"
    assert saved["heldout"] == ["b.csv"] and saved["training"] == ["a.csv"]
    assert saved["models"][0]["heldout_nrmse"] < 0.02
    assert fig.stat().st_size > 10_000


def test_cli_compare_bad_input(tmp_path, records, capsys):
    a = _csv(tmp_path, records[0], "a.csv")
    assert main(["compare", str(a), "--models", "no-such-model"]) == 2
    assert "unknown model" in capsys.readouterr().err
    assert main(["compare", str(a), "--models", "bouc-wen", "--holdout", "1.5"]) == 2
    err = capsys.readouterr().err
    assert "holdout" in err and "Traceback" not in err
