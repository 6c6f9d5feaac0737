"""``duffsym fit A.csv B.csv ...`` and ``duffsym fit --manifest``: one parameter set for several records.

Records come from the independent numpy generator (``tests/independent_current_sim.py``, no duffsym
import): one device whose coefficients depend on the coil current, measured at three constant
currents (1 % noise). The campaign fit must predict a fourth current it never saw, in free run, far
better than a fit at one current can; the manifest route (currents as manifest labels, files without
a current column) must give the same fit; misuse gets one line and a non-zero exit.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from duffsym.cli import main
from independent_current_sim import TRUTH, Sines, constant, generate

DISP = Sines(amps=(1.0, 0.3), freqs=(1.0, 2.3), phases=(0.0, 0.7))


def _write(path, rec, current=None):
    cols = [rec["t"], rec["d"], rec["d_dot"], rec["y"]] + (
        [np.full(rec["t"].size, current)] if current is not None else []
    )
    header = "time,displacement,velocity,force" + (",current" if current is not None else "")
    np.savetxt(path, np.column_stack(cols), delimiter=",", header=header, comments="", fmt="%.10g")


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    folder = tmp_path_factory.mktemp("campaign")
    for k, amps in enumerate((0.0, 0.5, 1.0, 0.75)):
        rec = generate(TRUTH, DISP, constant(amps), dt=0.005, duration=4.0, noise=0.01, seed=k)
        _write(folder / f"i{k}.csv", rec, current=amps)
        _write(folder / f"nolabel{k}.csv", rec)
    return folder


def _run(argv, capsys):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_campaign_fit_predicts_an_unseen_current(campaign, capsys):
    f = campaign
    code, out, err = _run(
        [
            "fit",
            str(f / "i0.csv"),
            str(f / "i1.csv"),
            str(f / "i2.csv"),
            "--model",
            "mr-damper-current",
            "--out",
            str(f / "camp.json"),
            "--plot",
            str(f / "camp.png"),
            "--json",
            "--quiet",
        ],
        capsys,
    )
    assert code == 0, err
    (f / "camp_stdout.json").write_text(out)  # the manifest test compares its fit with this one
    fit = json.loads(out)
    assert (
        fit["success"]
        and len(fit["records"]) == 3
        and fit["params"]["eta"] == pytest.approx(json.loads((f / "camp.json").read_text())["params"]["eta"])
    )
    assert fit["nrmse"] < 0.03  # in sample, 1 % noise
    assert (f / "camp.png").stat().st_size > 10_000
    code, out, err = _run(["validate", str(f / "camp.json"), str(f / "i3.csv"), "--json"], capsys)
    held_out = json.loads(out)["nrmse"]
    assert code == 0 and held_out < 0.05, (held_out, err)
    # one current alone cannot say how the device changes with it: its fit misses the unseen current
    code, out, err = _run(["fit", str(f / "i1.csv"), "--out", str(f / "one.json"), "--quiet"], capsys)
    assert code == 0, err
    code, out, _ = _run(["validate", str(f / "one.json"), str(f / "i3.csv"), "--json"], capsys)
    single = json.loads(out)["nrmse"]
    print(f"campaign in sample {fit['nrmse']:.4f}, unseen current {held_out:.4f}; one-current fit there {single:.4f}")
    assert single > 3 * held_out


def test_manifest_labels_give_the_same_fit(campaign, capsys):
    f = campaign
    (f / "m.csv").write_text(
        "file,current,amplitude\n"
        + "".join(
            f"nolabel{k},{c},1\n".replace("nolabel" + str(k), f"nolabel{k}.csv")
            for k, c in ((0, 0.0), (1, 0.5), (2, 1.0))
        )
    )
    code, out, err = _run(
        ["fit", "--manifest", str(f / "m.csv"), "--model", "mr-damper-current", "--json", "--quiet"], capsys
    )
    assert code == 0, err
    by_manifest = json.loads(out)
    assert by_manifest["records"] == ["nolabel0.csv", "nolabel1.csv", "nolabel2.csv"]
    by_files = json.loads((f / "camp_stdout.json").read_text())["params"]
    by_manifest = by_manifest["params"]
    for name, value in by_files.items():
        assert math.isclose(by_manifest[name], value, rel_tol=1e-6, abs_tol=1e-8), name


@pytest.mark.parametrize(
    "manifest, expect",
    [
        ("file,model\ni0.csv,mr-damper\n", "per record"),
        ("file,current\ni0.csv,0.3\n", "the file's current is 0 but the manifest says 0.3"),
        ("file\nmissing.csv\n", "missing.csv"),
    ],
)
def test_campaign_misuse_is_one_line(campaign, capsys, manifest, expect):
    (campaign / "bad.csv").write_text(manifest)
    code, _, err = _run(["fit", "--manifest", str(campaign / "bad.csv")], capsys)
    assert code != 0 and expect in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_fit_without_a_record_is_one_line(capsys):
    code, _, err = _run(["fit"], capsys)
    assert code != 0 and "give the record(s) to fit" in err
