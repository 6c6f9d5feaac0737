"""Smoke run of study s07 (hidden effects: where it fails, which effect, the error falls).

Runs ``main(["--smoke"])`` with ``DUFFSYM_OUTPUT_ROOT`` in a temporary folder (a 2.5 s record with
friction and an offset hidden, three candidate effects) and checks the numbers it wrote.
"""

from __future__ import annotations

import importlib
import json

import pytest


@pytest.mark.slow
@pytest.mark.ci
def test_s07_ladder_finds_both_hidden_effects_and_reaches_the_noise(tmp_path, monkeypatch):
    monkeypatch.setenv("DUFFSYM_OUTPUT_ROOT", str(tmp_path))
    s07 = importlib.import_module("s07_hidden_effect")
    assert s07.main(["--smoke"]) == 0
    meta = json.loads((tmp_path / "data" / "derived" / "smoke" / "s07_hidden_effect.json").read_text())
    case = meta["cases"][0]
    steps = case["steps"]
    assert sorted(steps[-1]["effects"]) == ["coulomb-friction", "force-offset"]
    held = [s["nrmse_heldout"] for s in steps]
    assert held == sorted(held, reverse=True) and held[-1] < held[0] / 5
    assert steps[-1]["needed"] == [] and steps[-1]["verdict"].startswith("The model fits to the noise")
    final = case["final"]["params"]
    assert abs(final["fric_mu"] - 20.0) < 1.0 and abs(final["off_y0"] - 0.2) < 0.01
    for panel in ("where", "candidates", "ladder"):
        assert (
            tmp_path / "paper" / "smoke" / "figures" / f"s07_hidden_effect_synthetic_{panel}.png"
        ).stat().st_size > 20_000
