"""Smoke runs of the studies (``studies/sNN_*.py --smoke``) into a temporary output root.

Each study's ``main(["--smoke"])`` runs once with ``DUFFSYM_OUTPUT_ROOT`` pointing at a temporary
folder; the tests then check that the expected files exist and that numbers in them agree with
what is known independently of the study code: A_f only scales the output (Fig. 3), the
Lyapunov certificate fails exactly where gamma, alpha or beta is negative (Table 1), and the loop
area of the Table 2 model grows with the coil voltage.
"""

from __future__ import annotations

import importlib
import json
import os
from pathlib import Path

import numpy as np
import pytest

NAMES = ("s01_fig3_duffing_like", "s02_fig6_table1", "s03_table2_loops")


@pytest.fixture(scope="module")
def smoke_root(tmp_path_factory):
    """Run every study with --smoke into one temporary root; return the root and the exit codes."""
    root = tmp_path_factory.mktemp("studies")
    old_env = os.environ.get("DUFFSYM_OUTPUT_ROOT")
    os.environ["DUFFSYM_OUTPUT_ROOT"] = str(root)
    codes = {}
    try:  # studies/ is on the path (tests/conftest.py)
        for name in NAMES:
            codes[name] = importlib.import_module(name).main(["--smoke"])
    finally:
        if old_env is None:
            os.environ.pop("DUFFSYM_OUTPUT_ROOT", None)
        else:
            os.environ["DUFFSYM_OUTPUT_ROOT"] = old_env
    return root, codes


def _meta(root: Path, study: str) -> dict:
    return json.loads((root / "data" / "derived" / "smoke" / f"{study}.json").read_text())


def _files_exist(root: Path, study: str, tag: str, panels, numbers):
    for ext in ("npz", "json"):
        assert (root / "data" / "derived" / "smoke" / f"{study}.{ext}").is_file()
    for p in panels:
        assert (root / "paper" / "smoke" / "figures" / f"{study}_{p}.png").stat().st_size > 10_000
    for n in numbers:
        assert (root / "paper" / "smoke" / "output" / f"{tag}_{n}.tex").is_file()


def test_all_studies_exit_zero(smoke_root):
    _, codes = smoke_root
    assert codes == dict.fromkeys(NAMES, 0)


def test_s01_af_only_scales_the_output(smoke_root):
    root, _ = smoke_root
    study = "s01_fig3_duffing_like"
    _files_exist(
        root, study, "s01", ("fig3a", "fig3b", "excitation"), ("frequency", "peak_benchmark", "peak_ratio_Af", "table")
    )
    meta = _meta(root, study)
    assert meta["config"]["periods"] < 16  # really the smoke config
    cv = meta["curves"]
    # y = A_f x2 and A_f is not in the state equation: A_f = 4 doubles y sample by sample (Fig. 3, A_f = 2 -> 4)
    assert cv["A_f"]["peak"] == pytest.approx(2.0 * cv["benchmark"]["peak"], rel=1e-12)
    assert cv["A_f"]["loop_area"] == pytest.approx(2.0 * cv["benchmark"]["loop_area"], rel=1e-12)
    with np.load(root / "data" / "derived" / "smoke" / f"{study}.npz") as f:
        np.testing.assert_allclose(f["A_f_y"], 2.0 * f["benchmark_y"], rtol=1e-12, atol=0)
        np.testing.assert_allclose(
            f["benchmark_d"], np.sin(2 * np.pi * meta["frequency"] * f["benchmark_t"]), atol=1e-12
        )
    assert (
        float((root / "paper" / "smoke" / "output" / "s01_peak_ratio_Af.tex").read_text().splitlines()[0].rstrip("%"))
        == 2.0
    )
    # c1 = 25 raises the peak, delta = 400 lowers it (paper's Fig. 3 text; s01 table: x1.37, x0.80)
    assert cv["c1"]["peak_ratio"] > 1.2 and cv["delta"]["peak_ratio"] < 0.9


def test_s02_certificate_fails_exactly_where_gamma_alpha_or_beta_is_negative(smoke_root):
    from duffsym.model.presets import TABLE1_BASE, TABLE1_SWEEPS

    root, _ = smoke_root
    study = "s02_fig6_table1"
    _files_exist(root, study, "s02", ("fig6",), ("table", "n_uncertified", "uncertified"))
    rows = _meta(root, study)["sets"]
    expected = []
    for name, values in TABLE1_SWEEPS.values():
        for v in values:
            p = {**TABLE1_BASE, name: v} if name != "n" else dict(TABLE1_BASE)
            negative = min(p["c1"] + p["c2"], p["k1"] + p["k2"], p["k3"]) < 0
            expected.append((name, float(v), not negative))
    got = [(r["param"], float(r["value"]), r["certified"]) for r in rows]
    assert got == expected
    assert sum(not c for *_, c in expected) == 5  # c1 = -20, c2 = -30, k2 = -5, k3 = -40, k3 = -5
    assert (root / "paper" / "smoke" / "output" / "s02_n_uncertified.tex").read_text().splitlines()[0].rstrip(
        "%"
    ) == "5"
    # gamma = 0 (c1 = -10) and alpha = 0 (k1 = -5) are outside the paper's "all positive" but certified
    by = {(r["param"], float(r["value"])): r for r in rows}
    assert by[("c1", -10.0)]["certified"] and not by[("c1", -10.0)]["paper_condition"]
    assert by[("k1", -5.0)]["certified"] and not by[("k1", -5.0)]["paper_condition"]
    # n = 1 is the linear model: its peak is the linear steady-state amplitude (closed form)
    r = by[("n", 1.0)]
    p = TABLE1_BASE
    w = 2 * np.pi * 0.25
    gamma, alpha = p["c1"] + p["c2"] + p["c3"], p["k1"] + p["k2"] + p["k3"]  # n = 1: x^n = x, x'^n = x'
    amp = p["A_f"] * w * abs(complex(p["k1"], w * p["c1"]) / complex(alpha - w**2, w * gamma))
    assert r["peak"] == pytest.approx(amp, rel=5e-4)  # smoke run: 6 periods, 200 samples per period (7e-5)


def test_s03_loop_area_grows_with_voltage(smoke_root):
    from duffsym.model.presets import TABLE2

    root, _ = smoke_root
    study = "s03_table2_loops"
    _files_exist(root, study, "s03", ("loops",), ("table", "area_lo", "area_hi"))
    rows = _meta(root, study)["rows"]
    assert [r["voltage"] for r in rows] == list(TABLE2)
    areas = [r["loop_area"] for r in rows]
    assert np.all(np.diff(areas) > 0)  # 0 V < 0.2 V < ... < 0.8 V (checked first in the full run)
    for r in rows:
        # dt = 0.005 s trapezoid against 10x finer sampling: the same loop within 0.2 %
        assert r["loop_area"] == pytest.approx(r["loop_area_fine"], rel=2e-3)
        # the loop is traversed clockwise (work done on the damper) and the peak stays below A_f
        assert r["loop_area"] > 0 and r["peak"] < r["A_f"]
    table = (root / "paper" / "smoke" / "output" / "s03_table.tex").read_text()
    assert table.count("\\\\") == len(TABLE2) + 1


def test_run_all_reports_a_failing_study_and_runs_the_others(monkeypatch, capsys, tmp_path):
    monkeypatch.setenv("DUFFSYM_OUTPUT_ROOT", str(tmp_path))
    run_all = importlib.import_module("run_all")
    monkeypatch.setattr(run_all, "STUDIES", ("no_such_study", "s03_table2_loops"))
    assert run_all.main(["--smoke"]) == 1
    out = capsys.readouterr().out
    assert "no_such_study: FAILED" in out and "s03_table2_loops: ok" in out
    assert (tmp_path / "paper" / "smoke" / "output" / "s03_table.tex").is_file()
    assert run_all.main(["--bogus"]) == 2


def test_smoke_after_a_full_run_leaves_the_full_files_untouched(monkeypatch, tmp_path, capsys):
    """``reproduce --smoke`` writes under paper/smoke/ and data/derived/smoke/; every file records its run."""
    import hashlib

    from PIL import Image

    monkeypatch.setenv("DUFFSYM_OUTPUT_ROOT", str(tmp_path))
    run_all = importlib.import_module("run_all")
    # a real full run of s04 (same settings as its smoke run, seconds) and a faked full run of s03
    assert importlib.import_module("s04_paper_claims").main([]) == 0
    fake = {
        tmp_path / "paper" / "figures" / "s03_table2_loops_loops.png": b"full-run figure",
        tmp_path / "paper" / "output" / "s03_table.tex": b"full-run table\n",
        tmp_path / "data" / "derived" / "s03_table2_loops.json": b'{"run_mode": "full"}',
    }
    for path, content in fake.items():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(content)
    full = [p for p in tmp_path.rglob("*") if p.is_file()]
    before = {p: (hashlib.sha256(p.read_bytes()).hexdigest(), p.stat().st_mtime_ns) for p in full}
    assert "% made by s04_paper_claims, full run" in (tmp_path / "paper" / "output" / "s04_n_hold.tex").read_text()

    monkeypatch.setattr(run_all, "STUDIES", ("s03_table2_loops", "s04_paper_claims"))
    assert run_all.main(["--smoke"]) == 0
    capsys.readouterr()
    after = {p: (hashlib.sha256(p.read_bytes()).hexdigest(), p.stat().st_mtime_ns) for p in full}
    assert after == before
    new = {p for p in tmp_path.rglob("*") if p.is_file()} - set(full)
    assert new and all("smoke" in p.relative_to(tmp_path).parts for p in new)
    smoke_out = tmp_path / "paper" / "smoke" / "output"
    assert (smoke_out / "s03_table.tex").read_text().endswith("% made by s03, smoke run\n")
    assert (smoke_out / "s04_n_hold.tex").read_text().splitlines()[-1] == "% made by s04_paper_claims, smoke run"
    meta = json.loads((tmp_path / "data" / "derived" / "smoke" / "s03_table2_loops.json").read_text())
    assert meta["run_mode"] == "smoke"
    png = Image.open(tmp_path / "paper" / "smoke" / "figures" / "s03_table2_loops_loops.png")
    assert png.info["Description"] == "made by s03_table2_loops, smoke run"
