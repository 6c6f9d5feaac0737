"""Smoke run of study s12 (the inverse for control) into a temporary output root; checks its numbers
against what is known without the study code: the saved forces are the true damper's response to the
saved commands (recomputed here), the commands respect the limits, and the model-based command tracks
the desired force better than the clipped on/off law and the best constant current."""

from __future__ import annotations

import importlib
import json

import numpy as np
import pytest

pytestmark = [pytest.mark.slow, pytest.mark.ci]  # the s12 smoke run takes ~22 s: CI runs it


@pytest.fixture(scope="module")
def s12(tmp_path_factory):
    root = tmp_path_factory.mktemp("s12")
    mp = pytest.MonkeyPatch()
    mp.setenv("DUFFSYM_OUTPUT_ROOT", str(root))
    try:
        study = importlib.import_module("s12_inverse_control")  # studies/ is on the path (conftest)
        code = study.main(["--smoke"])
    finally:
        mp.undo()
    meta = json.loads((root / "data" / "derived" / "smoke" / "s12_inverse_control.json").read_text())
    with np.load(root / "data" / "derived" / "smoke" / "s12_inverse_control.npz") as f:
        arrays = {k: f[k] for k in f.files}
    return root, code, meta, arrays, study


def test_outputs_exist(s12):
    root, code, meta, _, _ = s12
    assert code == 0 and meta["config"]["test_s"] < 6  # really the smoke config
    assert (root / "paper" / "smoke" / "figures" / "s12_inverse_control_tracking.png").stat().st_size > 10_000
    for n in ("inv_nrmse", "onoff_nrmse", "passive_nrmse", "solve_s", "unreachable_pct"):
        assert (root / "paper" / "smoke" / "output" / f"s12_inverse_control_{n}.tex").is_file()


def test_inverse_command_replayed_on_the_true_damper(s12):
    """The saved force of the fitted-model inverse is the true damper driven by the saved command."""
    from duffsym.model import get_model
    from duffsym.simulate import simulate

    _, _, meta, a, study = s12
    k = meta["order"].index("inverse (fitted model)")
    cmd = a[f"cmd_{k}"]
    assert cmd.min() >= 0.0 and cmd.max() <= 1.0
    U = np.column_stack([a["d"], a["d_dot"], cmd])
    y = a[f"force_{k}"]
    # the initial state is the inverse's; re-simulate from the saved trajectory's own start
    tr = simulate(
        get_model("mr-damper-current"), study.TRUTH, a["t"], U, method="radau", rtol=1e-8, atol=1e-10, x0=_x0(meta, cmd)
    )
    skip = a["t"] >= meta["config"]["skip_s"]
    assert np.max(np.abs(tr.y - y)[skip]) < 2e-3 * np.max(np.abs(y))


def _x0(meta, cmd):
    x = meta["methods"]["inverse (fitted model)"]["x0"]
    return [x[0], x[1], float(cmd[0])]


def test_model_based_command_beats_on_off_and_passive(s12):
    _, _, meta, _, _ = s12
    m = meta["methods"]
    inv, on, pa = m["inverse (fitted model)"], m["clipped on/off"], m["passive (best constant)"]
    assert inv["nrmse"] < on["nrmse"] < pa["nrmse"]
    assert inv["nrmse_reachable"] < 0.5 * on["nrmse_reachable"]
    assert set(np.unique(np.round(meta["limits"], 6))) == {0.0, 1.0}
