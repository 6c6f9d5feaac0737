"""duffsym batch and the Engine: results equal to the single commands, on a Dask LocalCluster of 2 worker
processes and in this process; resumable after a kill; atomic files; per-record failures; the engine as
the diagnosis' candidate runner and as emcee's pool."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

import duffsym
from duffsym import batch
from duffsym.cli import main
from duffsym.data import read_csv, synthetic_record, write_csv
from duffsym.engine import Engine
from duffsym.errors import ConvergenceWarning, DataError
from duffsym.excitation import Sine
from duffsym.identify import Problem, fit
from duffsym.model.library import mr_damper
from duffsym.model.presets import table2_params

MODEL = mr_damper(5)
VOLTS = (0.2, 0.4, 0.6, 0.8)


def _records(folder: Path, n: int, periods: float = 3.0) -> list[Path]:
    """Tiny noisy sine records of Table 2 rows (150 samples each at 3 periods)."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for i in range(n):
        v = VOLTS[i % len(VOLTS)]
        rec = synthetic_record(
            MODEL, table2_params(v), Sine(1.0, 2.0), dt=0.01, duration=periods / 2.0, noise=0.02, rng=i
        )
        p = folder / f"rec{i}_{v:g}V.csv"
        write_csv(rec, p)
        paths.append(p)
    return paths


@pytest.fixture(scope="module")
def cluster():
    with Engine(2) as engine:
        yield engine


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    folder = tmp_path_factory.mktemp("batch")
    _records(folder / "recs", 3)
    (folder / "recs" / "short.csv").write_text("time,displacement,force\n0,0,0\n0.01,0.1,0.2\n")
    return folder


def _params(doc):
    return {k: v for k, v in doc.items() if k in ("params", "stderr", "nrmse", "status", "success", "n_iter")}


def test_batch_on_a_local_cluster_equals_serial_and_the_single_fits(data, cluster, tmp_path):
    recs = sorted((data / "recs").glob("rec*.csv"))
    par = batch([data / "recs"], command="fit", out=tmp_path / "par", engine=cluster, progress=False)
    ser = batch([data / "recs"], command="fit", out=tmp_path / "ser", workers=0, progress=False)
    assert "local" in par.engine and "serial" in ser.engine
    assert [r["record"] for r in par] == ["rec0_0.2V", "rec1_0.4V", "rec2_0.6V", "short"]
    for r in recs:
        a, b = par.result(r.stem), ser.result(r.stem)
        assert _params(a) == _params(b) and a["success"] is True
        # the same numbers as the library's own fit of that file (an independent route: no CLI, no engine)
        direct = fit(Problem(MODEL, read_csv(r)))
        assert a["params"] == pytest.approx(direct.params, rel=0, abs=0)
        assert a["nrmse"] == direct.nrmse
    assert len({par[r.stem]["worker"] for r in recs}) == 2  # both worker processes served records
    # the bad record is reported with its message and did not stop the others
    bad = par["short"]
    assert bad["status"] == "error" and not bad["success"] and "too few samples" in bad["message"]
    assert str(data / "recs" / "short.csv") in bad["message"]  # the user's path, not the worker's copy
    assert par.counts == {"ok": 3, "failed": 0, "error": 1, "interrupted": 0} and not par.all_ok
    summary = json.loads((tmp_path / "par" / "summary.json").read_text())
    for row in summary["records"]:
        assert {"record", "status", "success", "nrmse", "result", "message"} <= set(row)
    csv_lines = (tmp_path / "par" / "summary.csv").read_text().splitlines()
    assert csv_lines[0].startswith("record,status,success,nrmse,result,message") and len(csv_lines) == 5
    assert (tmp_path / "par" / "summary.png").stat().st_size > 10_000
    # a batch fit result is a FIT.json: validate reads it
    assert main(["validate", str(tmp_path / "par" / "rec1_0.4V.json"), str(recs[1]), "--json"]) == 0


def test_rerun_skips_complete_records_and_reruns_changed_ones(data, tmp_path, monkeypatch):
    out = tmp_path / "res"
    first = batch(
        [data / "recs" / "rec0_0.2V.csv", data / "recs" / "rec1_0.4V.csv"],
        command="fit",
        out=out,
        workers=0,
        progress=False,
    )
    assert first.n_ran == 2
    again = batch(
        [data / "recs" / "rec0_0.2V.csv", data / "recs" / "rec1_0.4V.csv"],
        command="fit",
        out=out,
        workers=0,
        progress=False,
    )
    assert again.n_ran == 0 and all(r["reused"] for r in again)
    # a result of another duffsym release is recomputed, not reused
    monkeypatch.setattr(duffsym, "__version__", "0.0.0-other")
    other = batch([data / "recs" / "rec0_0.2V.csv"], command="fit", out=out, workers=0, progress=False)
    assert other.n_ran == 1
    monkeypatch.undo()
    # changed options rerun every record; the stored result then holds the new options
    opt = batch(
        [data / "recs" / "rec0_0.2V.csv"],
        command="fit",
        out=out,
        workers=0,
        progress=False,
        options={"fix": ["c1=2.5"]},
    )
    assert opt.n_ran == 1 and opt.result("rec0_0.2V")["params"]["c1"] == 2.5
    # changed input bytes rerun that record only
    changed = tmp_path / "rec1_0.4V.csv"
    changed.write_text((data / "recs" / "rec1_0.4V.csv").read_text().replace("time,", "time,", 1) + "\n")
    assert batch([changed], command="fit", out=out, workers=0, progress=False).n_ran == 1


def test_manifest_labels_options_and_validate_with_a_fit_folder(data, tmp_path):
    recs = sorted((data / "recs").glob("rec*.csv"))
    manifest = tmp_path / "m.json"
    manifest.write_text(
        json.dumps(
            {
                "records": [
                    {"file": str(r), "name": f"r{i}", "voltage": VOLTS[i], "amplitude": 1.0} for i, r in enumerate(recs)
                ]
                + [{"file": str(recs[0]), "name": "typo", "options": "--bogus 1"}]
            }
        )
    )
    res = batch(command="fit", manifest=manifest, out=tmp_path / "fits", workers=0, progress=False)
    assert res["typo"]["status"] == "error" and "unrecognized arguments: --bogus" in res["typo"]["message"]
    assert res["r1"]["labels"] == {"voltage": 0.4, "amplitude": 1.0} and res["r1"]["params"]["c3"] > 0
    # parameters against the manifest's voltage in the summary figure
    assert (tmp_path / "fits" / "summary.png").stat().st_size > 20_000
    # validate every record with the fit of the same name from the batch fit's folder
    val = batch(
        command="validate", manifest=manifest, fit=tmp_path / "fits", out=tmp_path / "val", workers=0, progress=False
    )
    # the same record: validate re-estimates the initial state, so the free run is close to the fit's
    assert val["r2"]["nrmse"] == pytest.approx(res["r2"]["nrmse"], rel=0.02)
    assert val["typo"]["status"] == "error"  # the fit of 'typo' is an error record, not a fit
    with pytest.raises(DataError, match="needs a fit"):
        batch(command="sample", manifest=manifest, out=tmp_path / "x", workers=0, progress=False)
    with pytest.raises(DataError, match="set by the batch"):
        batch([recs[0]], command="fit", out=tmp_path / "x", options="--out f.json", workers=0, progress=False)


def test_a_record_task_returns_the_result_the_command_prints(data, capsys):
    """A batch record is a library task (no command line in the worker): it returns the command's result object,
    whose JSON is what ``duffsym fit --json`` prints for the record, and a bad option is the parser's message."""
    from duffsym.campaign.manifest import collect_jobs
    from duffsym.cli.batch_worker import record_task
    from duffsym.engine import Task

    rec = sorted((data / "recs").glob("rec*.csv"))[1]
    (job,) = collect_jobs([rec], command="fit", options="--seed 3")
    task = record_task("fit", job)
    assert isinstance(task, Task) and task.func.__name__ == "run_record"
    run = Engine().run([task])
    (outcome,) = list(run)
    got = outcome.value
    assert got.exit_code == 0 and got.message == "" and got.result.command == "fit" and got.result.value is None
    assert main(["fit", str(rec), "--seed", "3", "--json", "--quiet"]) == 0
    printed = json.loads(capsys.readouterr().out)
    mine = got.result.to_dict()
    assert list(mine) == list(printed)  # the same keys, in the contract's order
    assert _params(mine) == _params(printed) and mine["params"]["c3"] > 0 and mine["records"] == printed["records"]
    (bad,) = collect_jobs([rec], command="fit", options="--starts two")
    refused = record_task("fit", bad).execute()
    assert refused.exit_code == 2 and refused.result is None
    assert refused.message == "duffsym fit: error: argument --starts: invalid int value: 'two'"


def test_cli_batch_json_and_bad_input(data, tmp_path, capsys):
    code = main(
        [
            "batch",
            str(data / "recs" / "rec*.csv"),
            "--command",
            "fit",
            "--out",
            str(tmp_path / "o"),
            "--workers",
            "0",
            "--json",
            "--quiet",
        ]
    )
    out = capsys.readouterr()
    assert code == 0 and out.err == ""
    doc = json.loads(out.out)
    assert doc["counts"]["ok"] == 3 and doc["n_ran"] == 3
    assert main(["batch", str(tmp_path / "nothing*.csv"), "--command", "fit", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "matches no file" in err[0]
    assert (
        main(
            [
                "batch",
                str(data / "recs"),
                "--command",
                "fit",
                "--out",
                str(tmp_path / "o2"),
                "--workers",
                "0",
                "--quiet",
            ]
        )
        == 1
    )  # the short record is not usable: exit 1, the summary says which


def _complete_results(out: Path) -> list[str]:
    return sorted(p.stem for p in out.glob("*.json") if not p.name.startswith("summary"))


@pytest.mark.parametrize("sig, workers", [(signal.SIGKILL, 0), (signal.SIGINT, 0), (signal.SIGINT, 2)])
def test_killed_batch_leaves_no_truncated_file_and_resumes(tmp_path, sig, workers):
    recs = _records(tmp_path / "recs", 8, periods=8.0)
    out = tmp_path / "out"
    cmd = [
        sys.executable,
        "-m",
        "duffsym.cli",
        "batch",
        str(tmp_path / "recs"),
        "--command",
        "fit",
        "--out",
        str(out),
        "--workers",
        str(workers),
        "--quiet",
    ]
    # a shell's background job ignores SIGINT and its children inherit that: give the batch the default
    # (Python then turns SIGINT into KeyboardInterrupt, as at a terminal)
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    deadline = time.time() + 120
    while time.time() < deadline and len(_complete_results(out)) < 2 and proc.poll() is None:
        time.sleep(0.01)
    os.kill(proc.pid, sig)
    _, err = proc.communicate(timeout=60)
    done = _complete_results(out)
    assert 2 <= len(done) < len(recs), "the kill should land mid-batch"
    for name in done:  # every result file is whole
        doc = json.loads((out / f"{name}.json").read_text())
        assert doc["batch"]["complete"] and doc["batch"]["status"] == "ok"
    if sig == signal.SIGINT:
        assert proc.returncode == 130 and "interrupted" in err
        assert not list(out.glob(".*.tmp*"))  # an interrupt removes its temporary file
        summary = json.loads((out / "summary.json").read_text())
        assert {r["status"] for r in summary["records"]} == {"ok", "interrupted"}
    before = {n: (out / f"{n}.json").read_bytes() for n in done}
    res = batch([tmp_path / "recs"], command="fit", out=out, workers=0, progress=False)
    assert res.n_ran == len(recs) - len(done)
    assert sorted(r["record"] for r in res if r["reused"]) == done
    assert all((out / f"{n}.json").read_bytes() == before[n] for n in done)  # untouched
    assert res.all_ok and not list(out.glob(".*.tmp*"))


def test_engine_map_and_as_completed(cluster):
    assert cluster.map(np.sqrt, [1.0, 4.0, 9.0]) == [1.0, 2.0, 3.0]
    got = sorted((o.index, o.ok) for o in cluster.as_completed(int, ["1", "x", "3"]))
    assert got == [(0, True), (1, False), (2, True)]
    assert Engine().map(np.sqrt, [4.0]) == [2.0]
    from duffsym.engine import Task

    tasks = [Task(pow, (2, 10)), Task(int, ("x",)), Task(round, (2.567,), {"ndigits": 1})]
    for engine in (cluster, Engine()):
        got = sorted((o.index, o.value if o.ok else type(o.error).__name__) for o in engine.run(tasks))
        assert got == [(0, 1024), (1, "ValueError"), (2, 2.6)]
    with pytest.raises(duffsym.DuffsymError, match="non-negative integer"):
        Engine(-1)


def test_engine_as_emcee_pool_gives_the_serial_chain(cluster):
    from duffsym.uncertainty import sample

    truth = table2_params(0.4)
    rec = synthetic_record(MODEL, truth, Sine(1.0, 2.0), dt=0.01, duration=1.5, noise=0.02, rng=5)
    res = fit(Problem(MODEL, rec, fixed={"A_f": truth["A_f"]}))
    kw = dict(n_walkers=14, n_steps=8, rng=2, recheck_draws=0, sigma_draws=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        serial = sample(res, rec, pool=Engine(), **kw)
        pooled = sample(res, rec, pool=cluster, **kw)
    np.testing.assert_array_equal(serial.chain, pooled.chain)
    assert serial.counts == pooled.counts


def test_diagnosis_candidates_on_the_engine_equal_the_serial_ones(cluster):
    from duffsym.diagnose import diagnose
    from duffsym.effects import CATALOGUE, apply_effects

    m = apply_effects(MODEL, [CATALOGUE["force-offset"]])
    rec = synthetic_record(
        m, {**table2_params(0.4), "off_y0": 0.15}, Sine(1.0, 2.0), dt=0.005, duration=3.0, noise=0.01, rng=1
    )  # the record of test_diagnose's CLI tests
    kw = dict(candidates=["force-offset", "output-lag"], sindy=False, candidate_cpu_time=None)
    a = diagnose(rec, **kw)
    b = diagnose(rec, engine=cluster, **kw)
    assert a.needed == b.needed == ("force-offset",)
    for ca, cb in zip(a.candidates, b.candidates):
        assert (ca.effect, ca.all_params, ca.nrmse_after, ca.delta_bic) == (
            cb.effect,
            cb.all_params,
            cb.nrmse_after,
            cb.delta_bic,
        )
    assert a.verdict == b.verdict
