"""Progress of long work: on stderr with a count, elapsed time and time left; stdout stays pure JSON."""

from __future__ import annotations

import io
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from duffsym import _progress
from duffsym._progress import Progress, reporter

DATA = Path(__file__).resolve().parents[1] / "data"


def _cli(*argv, cwd):
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run(
        [sys.executable, "-m", "duffsym.cli", *argv], cwd=cwd, env=env, capture_output=True, text=True, timeout=600
    )


def test_progress_counts_and_estimates_the_time_left(monkeypatch):
    clock = iter([0.0, 10.0, 30.0, 50.0])  # start, item 1 starts, item 2 starts (20 s per item), item 3 starts
    monkeypatch.setattr(_progress.time, "perf_counter", lambda: next(clock))
    out = io.StringIO()
    p = Progress(stream=out)
    for k in range(3):
        p("trying x", done=k, total=4)
    lines = out.getvalue().splitlines()
    assert lines[0] == "[0:10] trying x (1 of 4)"
    assert lines[1] == "[0:30] trying x (2 of 4, about 1:00 left)"  # 20 s for 1 item, 3 to go
    assert lines[2] == "[0:50] trying x (3 of 4, about 0:40 left)"


def test_reporter_adapts_plain_callables_and_none():
    seen = []
    say = reporter(seen.append)
    say("a")
    say("b", done=1, total=3)
    assert seen == ["a", "b (2 of 3)"]
    reporter(None)("nothing", done=0, total=1)  # silent


@pytest.mark.slow
@pytest.mark.ci
def test_diagnose_json_stdout_stays_pure_with_progress_on(tmp_path):
    proc = _cli(
        "diagnose",
        str(DATA / "synthetic_hidden.csv"),
        "--candidates",
        "force-offset,inertia",
        "--no-sindy",
        "--json",
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)  # one JSON object and nothing else
    assert doc["candidates"][0]["effect"] == "force-offset"
    assert re.search(r"^\[\d+:\d\d\]   trying force-offset \(1 of 2\)$", proc.stderr, re.M)
    assert re.search(r"trying inertia \(2 of 2, about \d+:\d\d left\)", proc.stderr)
    quiet = _cli(
        "diagnose",
        str(DATA / "synthetic_hidden.csv"),
        "--candidates",
        "force-offset",
        "--no-sindy",
        "--json",
        "--quiet",
        cwd=tmp_path,
    )
    assert quiet.returncode == 0 and quiet.stderr == "" and json.loads(quiet.stdout)["needed"] == ["force-offset"]


def test_sample_json_stdout_stays_pure_with_the_progress_bar(tmp_path):
    fit = _cli("fit", str(DATA / "synthetic_sine.csv"), "--out", "fit.json", "--quiet", cwd=tmp_path)
    assert fit.returncode == 0, fit.stderr
    proc = _cli(
        "sample",
        str(DATA / "synthetic_sine.csv"),
        "--fit",
        "fit.json",
        "--walkers",
        "16",
        "--steps",
        "60",
        "--json",
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    assert set(doc) >= {"median", "q05", "q95", "tau"}
    assert "60/60" in proc.stderr and "sampling" in proc.stderr  # emcee's tqdm bar and the start line


def test_run_all_estimate_weights_the_studies_by_their_typical_time():
    import run_all  # studies/ is on sys.path (conftest.py): a failing import is a failure, not a skip

    # s01 took 4x its typical time: the run is 4x slower, so s06 is 4x its typical time away
    typ = run_all.TYPICAL_SECONDS
    left = round(4 * typ["s06"])
    elapsed = 4.0 * typ["s01"]
    assert run_all._estimate(["s01_a"], ["s06_b"], elapsed, smoke=False) == f", about {left // 60}:{left % 60:02d} left"
    assert run_all._estimate(["s01_a", "s02_b"], ["s03_c", "s04_d"], 10.0, smoke=True) == ", about 0:10 left"
    assert run_all._estimate([], ["s01_a"], 0.0, smoke=False) == ""


def test_the_packages_warnings_print_as_one_line_notes(tmp_path):
    code = (
        "import warnings\nfrom duffsym.errors import ConvergenceWarning, show_notes\nshow_notes()\n"
        "warnings.warn('the Gauss-Newton Hessian is singular:\\n  some parameters', ConvergenceWarning)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.stderr == "note: the Gauss-Newton Hessian is singular: some parameters\n"
