"""``duffsym reproduce`` / ``studies/run_all.py``: unchanged studies are skipped, changed ones rerun, studies in
parallel.

Runs the fast studies s03 and s04 (seconds each, smoke settings) into a temporary output root.
"""

from __future__ import annotations

import importlib
import json
import sys
from pathlib import Path

import pytest

STUDIES = Path(__file__).resolve().parents[1] / "studies"
sys.path.insert(0, str(STUDIES))


def _all_skipped(out: str) -> bool:
    return "ok in" not in out and all(
        f"{n}: unchanged, skipped" in out for n in ("s03_table2_loops", "s04_paper_claims")
    )


@pytest.fixture()
def run_all(monkeypatch, tmp_path):
    monkeypatch.setenv("DUFFSYM_OUTPUT_ROOT", str(tmp_path))
    mod = importlib.import_module("run_all")
    monkeypatch.setattr(mod, "STUDIES", ("s03_table2_loops", "s04_paper_claims"))
    return mod


def test_an_unchanged_study_is_skipped_and_force_reruns_it(run_all, tmp_path, capsys):
    assert run_all.main(["--smoke"]) == 0
    first = capsys.readouterr().out
    assert "s03_table2_loops: ok in" in first and "skipped" not in first
    entry = json.loads((tmp_path / "data" / "derived" / "smoke" / ".reproduce" / "s03_table2_loops.json").read_text())
    assert entry["files"] and all((tmp_path / f).is_file() for f in entry["files"])
    table = tmp_path / "paper" / "smoke" / "output" / "s03_table.tex"
    stamp = table.stat().st_mtime_ns

    assert run_all.main(["--smoke"]) == 0
    second = capsys.readouterr().out
    assert _all_skipped(second) and table.stat().st_mtime_ns == stamp

    table.unlink()  # a missing output makes the study run again
    assert run_all.main(["--smoke"]) == 0
    third = capsys.readouterr().out
    assert "s03_table2_loops: ok in" in third and "s04_paper_claims: unchanged, skipped" in third and table.is_file()

    assert run_all.main(["--smoke", "--force"]) == 0
    assert "skipped" not in capsys.readouterr().out


def test_the_key_follows_what_a_study_depends_on(run_all, monkeypatch, tmp_path):
    key = run_all.study_key("s03_table2_loops", True, package="p", external="e")
    assert key == run_all.study_key("s03_table2_loops", True, package="p", external="e")
    assert key != run_all.study_key("s03_table2_loops", False, package="p", external="e")  # the mode
    assert key != run_all.study_key("s03_table2_loops", True, package="q", external="e")  # the package source
    assert key != run_all.study_key("s03_table2_loops", True, package="p", external="f")  # the external data
    assert key != run_all.study_key("s04_paper_claims", True, package="p", external="e")
    assert run_all.package_hash() == run_all.package_hash()
    # a stored benchmark result the study reads (s11, s14: their long parts) is part of its key
    stored = tmp_path / "stored.json"
    stored.write_text("{}")
    monkeypatch.setitem(run_all.READS, "s03", (str(stored),))
    before = run_all.study_key("s03_table2_loops", True, package="p", external="e")
    stored.write_text('{"x": 1}')
    assert before != run_all.study_key("s03_table2_loops", True, package="p", external="e")
    # s11 reads s06's results: one task, s06 first; the longest task first
    groups = run_all._groups(["s03_table2_loops", "s11_current_driven", "s06_real_mr_damper", "s07_hidden_effect"])
    assert ("s06_real_mr_damper", "s11_current_driven") in groups and groups[-1] == ("s03_table2_loops",)
    weights = [sum(run_all.TYPICAL_SECONDS.get(n[:3], 60) for n in g) for g in groups]
    assert weights == sorted(weights, reverse=True)


def test_studies_in_parallel_on_the_engine(run_all, tmp_path, capsys):
    assert run_all.main(["--smoke", "--workers", "2"]) == 0
    out = capsys.readouterr().out
    assert "s03_table2_loops: ok in" in out and "s04_paper_claims: ok in" in out
    assert (tmp_path / "paper" / "smoke" / "output" / "s03_table.tex").is_file()
    assert (tmp_path / "data" / "derived" / "smoke" / ".reproduce" / "s04_paper_claims.log").is_file()
    assert run_all.main(["--smoke", "--workers", "2"]) == 0
    assert _all_skipped(capsys.readouterr().out)
    assert run_all.main(["--workers", "0"]) == 2
