"""Batch outputs no record can overwrite, and two batches sharing a results folder (issue 24)."""

from __future__ import annotations

import json
import os

from duffsym import batch
from duffsym.campaign import LOCK_NAME
from duffsym.campaign import _remove_stale_temporaries as remove_stale
from duffsym.data import synthetic_record, write_csv
from duffsym.excitation import Sine
from duffsym.model.library import mr_damper
from duffsym.model.presets import table2_params


def test_a_record_named_summary_keeps_its_result(tmp_path):
    rec = synthetic_record(mr_damper(5), table2_params(0.4), Sine(1.0, 2.0), dt=0.01, duration=1.5, noise=0.02, rng=0)
    (tmp_path / "recs").mkdir()
    write_csv(rec, tmp_path / "recs" / "summary.csv")
    out = tmp_path / "out"
    res = batch([tmp_path / "recs"], command="fit", out=out, workers=0, progress=False, figure=False)
    assert res.all_ok
    fit_doc = json.loads((out / "record_summary.json").read_text())
    assert fit_doc["model"] == "mr-damper" and fit_doc["batch"]["status"] == "ok"
    assert "records" in json.loads((out / "summary.json").read_text())
    # a rerun reuses it, and `batch validate --fit OUT` finds it
    assert batch([tmp_path / "recs"], command="fit", out=out, workers=0, progress=False, figure=False).n_ran == 0
    val = batch(
        [tmp_path / "recs"], command="validate", fit=out, out=tmp_path / "val", workers=0, progress=False, figure=False
    )
    assert val.all_ok, list(val)


def test_start_up_leaves_another_live_batchs_temporary_files(tmp_path):
    import fcntl

    tmp = tmp_path / ".rec.json.abc.tmp"
    tmp.write_text("{")
    other = open(tmp_path / LOCK_NAME, "a")  # another batch running in this folder holds its lock
    fcntl.flock(other, fcntl.LOCK_SH)
    mine = remove_stale(tmp_path)
    assert tmp.exists()
    mine.close()
    other.close()
    # once no batch runs there, a left-over temporary file is stale and goes
    remove_stale(tmp_path).close()
    assert not tmp.exists() and not any(p.name.endswith(".tmp") for p in tmp_path.iterdir())
    assert os.path.exists(tmp_path / LOCK_NAME)
