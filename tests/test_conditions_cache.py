"""The stability conditions a fit's flags check are stored in the code cache and read back safely (issue 24:
start-up): the stored tests agree with SymPy's on random parameter sets, a later process reads them without
deriving, and a stored file that holds anything but conditions is derived again and rewritten."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
import sympy as sp

from duffsym.derive.stability import stability_conditions
from duffsym.identify import conditions_cache, quality
from duffsym.model.library import at_constant_command, get_model


@pytest.fixture
def private_cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    folder.mkdir(mode=0o700)
    monkeypatch.setenv("DUFFSYM_CACHE", str(folder))
    monkeypatch.setattr(quality, "_CONDITIONS", {})
    return folder


@pytest.mark.parametrize("name", ["mr-damper", "mr-damper-current", "duffing-gain"])
def test_stored_tests_agree_with_sympy(private_cache, name):
    model = get_model(name)
    tests = dict(quality._conditions(model))
    target = at_constant_command(model) or model
    named = {k: c for k, c in stability_conditions(target).named().items() if c not in (sp.true, sp.false)}
    assert set(tests) == set(named) and tests
    rng = np.random.default_rng(0)
    for _ in range(200):  # values around the sign changes, zeros included (the conditions use == 0)
        vals = rng.choice([-2.0, -0.5, 0.0, 0.5, 2.0], size=len(target.param_symbols))
        subs = dict(zip(target.param_symbols, vals))
        for k, cond in named.items():
            assert tests[k](*vals) == bool(cond.xreplace(subs)), (k, vals)
    assert len(list(private_cache.glob("conditions_*.json"))) == 1


def test_a_later_process_reads_them_without_deriving(private_cache, monkeypatch):
    model = get_model("mr-damper")
    first = quality._conditions(model)
    monkeypatch.setattr(quality, "_CONDITIONS", {})  # a new process: nothing in memory
    monkeypatch.setattr(quality, "_derived_conditions", lambda m: pytest.fail("derived again"))
    again = quality._conditions(model)
    assert [n for n, _ in again] == [n for n, _ in first]
    assert all(t(10, 10, 300, 30, 400, 0, 1.5) for _, t in again)  # Table 2: inside the certificate
    assert not dict(again)["V positive definite"](10, 10, 300, 30, -400, 0, 1.5)  # k1 + k2 < 0


def test_a_planted_file_is_refused(private_cache, monkeypatch, tmp_path):
    model = get_model("mr-damper")
    quality._conditions(model)
    (path,) = private_cache.glob("conditions_*.json")
    marker = tmp_path / "ran"
    data = json.loads(path.read_text())
    data["conditions"][0][2] = f"__import__('os').system('touch {marker}') or True"
    data["conditions"][1][2] = "c1.__class__ is float"
    path.write_text(json.dumps(data))
    monkeypatch.setattr(quality, "_CONDITIONS", {})
    assert conditions_cache.load_conditions(model) is None
    tests = dict(quality._conditions(model))
    assert not marker.exists()
    assert len(tests) == len(data["conditions"])  # derived again, and the file rewritten
    assert conditions_cache.load_conditions(model) is not None
    # a file others can write to is not read at all: the conditions are derived again
    os.chmod(path, 0o666)
    monkeypatch.setattr(quality, "_CONDITIONS", {})
    assert conditions_cache.load_conditions(model) is None
    assert len(quality._conditions(model)) == len(data["conditions"])


def test_safe_test_accepts_conditions_only():
    ok = conditions_cache.safe_test(["a", "b"], "(a >= 0) and (math.sqrt(abs(b)) > 1) or not (a == b)")
    assert ok is not None and ok(1.0, 4.0) and not ok(-1.0, -1.0)
    for bad in ("a.__class__", "open('x')", "[a for a in ()]", "lambda: 1", "a(1)", "'text'", "b if a else c"):
        assert conditions_cache.safe_test(["a", "b"], bad) is None, bad
    assert conditions_cache.safe_test(["math"], "math > 0") is None
