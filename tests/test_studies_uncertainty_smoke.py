"""Smoke run of study s08 (posterior, predictive bands, the k3 ridge) with numbers checked."""

from __future__ import annotations

import importlib
import json


def test_s08_smoke(tmp_path, monkeypatch):
    monkeypatch.setenv("DUFFSYM_OUTPUT_ROOT", str(tmp_path))
    s08 = importlib.import_module("s08_uncertainty")
    assert s08.main(["--smoke"]) == 0
    meta = json.loads((tmp_path / "data" / "derived" / "smoke" / "s08_uncertainty.json").read_text())
    truth, a = meta["truth"], meta["a"]
    post = a["posterior"]
    for n in s08.FREE:
        # the posterior median sits where the Laplace approximation says the truth may be
        assert abs(post["median"][n] - truth[n]) < 3.5 * a["fit"]["stderr"][n], n
        assert post["q05"][n] < post["median"][n] < post["q95"][n]
    assert 0.8 < a["predictive_coverage95"] <= 1.0
    assert post["evaluations"]["ok"] > 0
    single, multi = meta["ridge"]["single"], meta["ridge"]["multi"]
    kinds = {f["kind"]: f for f in single["identifiability"]["findings"]}
    assert "unidentifiable" in kinds and "k3" in kinds["unidentifiable"]["params"]
    assert "several amplitudes" in kinds["unidentifiable"]["resolve"]
    assert not [f for f in multi["identifiability"]["findings"] if f["kind"] == "unidentifiable"]
    # the ridge: k3's Cramer-Rao variance inflation collapses with three amplitudes
    assert multi["identifiability"]["params"]["k3"]["vif"] < single["identifiability"]["params"]["k3"]["vif"] / 10
    figs = sorted(p.name for p in (tmp_path / "paper" / "smoke" / "figures").glob("*.png"))
    assert figs == [f"s08_uncertainty_{p}.png" for p in ("bands", "corner", "ridge")]
    assert (tmp_path / "paper" / "smoke" / "output" / "s08_uncertainty_table.tex").read_text().count("\\\\") == 5
