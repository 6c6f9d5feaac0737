"""Smoke run of study s09 (SINDy cross-check) into a temporary output root.

The numbers are checked against the truth the study's synthetic records carry (Table 2, 0.4 V
row), not against the study's own code: noise-free rich excitation recovers the SymPy
coefficients, the noisy single sine at the paper's 5 ms is inconclusive, not a wrong model.
"""

from __future__ import annotations

import importlib
import json
import os

import pytest


@pytest.fixture(scope="module")
def s09_root(tmp_path_factory):
    root = tmp_path_factory.mktemp("s09")
    old = os.environ.get("DUFFSYM_OUTPUT_ROOT")
    os.environ["DUFFSYM_OUTPUT_ROOT"] = str(root)
    try:  # studies/ is on the path (tests/conftest.py)
        code = importlib.import_module("s09_sindy").main(["--smoke"])
    finally:
        if old is None:
            os.environ.pop("DUFFSYM_OUTPUT_ROOT", None)
        else:
            os.environ["DUFFSYM_OUTPUT_ROOT"] = old
    return root, code


def test_s09_smoke_writes_its_files(s09_root):
    root, code = s09_root
    assert code == 0
    for ext in ("npz", "json"):
        assert (root / "data" / "derived" / "smoke" / f"s09_sindy.{ext}").is_file()
    assert (root / "paper" / "smoke" / "figures" / "s09_sindy_inclusion.png").stat().st_size > 10_000
    for name in ("rich_max_err", "noisy_exact", "friction_flagged", "sine_noisy_weak"):
        assert (root / "paper" / "smoke" / "output" / f"s09_{name}.tex").is_file()


def test_s09_smoke_numbers_match_the_truth(s09_root):
    root, _ = s09_root
    meta = json.loads((root / "data" / "derived" / "smoke" / "s09_sindy.json").read_text())
    rich = meta["rows"][0]
    assert rich["verdict"] == "consistent"
    assert set(rich["selected"]) == {"x", "x_dot", "x_dot^5", "d", "d_dot"}
    # Table 2, 0.4 V: c1 = c2 = 10, c3 = 320, k1 = 34, k2 = 480 (x'' coefficients from Eq. 12)
    for name, value in {"x_dot": -20.0, "x": -514.0, "x_dot^5": -320.0, "d": 34.0, "d_dot": 10.0}.items():
        assert abs(rich["coefficients"][name] / value - 1) < 0.01, name
    verdicts = {r["label"]: r["verdict"] for r in meta["sine"]}
    assert verdicts["single sine, dt 5 ms, noise 0.02, weak"] == "inconclusive"
    assert verdicts["single sine, dt 5 ms, noise 0, smoothed"] == "inconclusive"
