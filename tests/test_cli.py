"""The command line: results against the Python API, and one-line errors with non-zero exits."""

import json
import re
import subprocess
import sys

import numpy as np
import pytest

from duffsym import Sine, mr_damper, simulate
from duffsym.cli import main
from duffsym.model.presets import TABLE2


def run(argv, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_models_json_lists_the_paper_models(capsys):
    code, out, err = run(["models", "--json"], capsys)
    assert code == 0
    names = [m["model"] for m in json.loads(out)["models"]]
    # the classical models (issue 25) follow the paper's; duffing-gain: Eq. 1 with an input gain; structure: a
    # mass carrying the element; *-current: driven by the coil command
    assert names == [
        "mr-damper",
        "mr-damper-path",
        "mr-damper-current",
        "mr-damper-current-quadratic",
        "mr-damper-current-saturating",
        "mr-damper-current-path-viscous",
        "duffing-like",
        "duffing",
        "duffing-gain",
        "structure",
        "bouc-wen",
        "bouc-wen-current",
        "spencer",
        "dahl",
        "lugre",
        "bingham",
        "bingham-current",
        "biviscous",
        "biviscous-current",
    ]


def test_simulate_table2_row_matches_python_api(tmp_path, capsys):
    csv = tmp_path / "sim.csv"
    code, out, err = run(
        [
            "simulate",
            "--voltage",
            "0.6",
            "--periods",
            "2",
            "--frequency",
            "2",
            "--dt",
            "0.005",
            "--out",
            str(csv),
            "--json",
        ],
        capsys,
    )
    assert code == 0
    summary = json.loads(out)
    assert summary["success"] and summary["params"]["k2"] == 450.0
    data = np.genfromtxt(csv, delimiter=",", names=True)
    assert data.dtype.names == ("time", "displacement", "velocity", "force")
    t = np.arange(201) * 0.005
    ref = simulate(mr_damper(), TABLE2[0.6], t, Sine(1.0, 2.0))
    np.testing.assert_allclose(data["time"], t, atol=1e-12)
    np.testing.assert_allclose(data["force"], ref.y, rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(data["velocity"], 2 * np.pi * 2 * np.cos(2 * np.pi * 2 * t), rtol=1e-8, atol=1e-8)


def test_simulate_param_override(tmp_path, capsys):
    code, out, _ = run(
        [
            "simulate",
            "--voltage",
            "0.4",
            "--param",
            "c3=100,A_f=3",
            "--periods",
            "1",
            "--out",
            str(tmp_path / "a.csv"),
            "--json",
        ],
        capsys,
    )
    params = json.loads(out)["params"]
    assert code == 0 and params["c3"] == 100.0 and params["A_f"] == 3.0 and params["k1"] == 34.0


@pytest.mark.parametrize(
    "argv, message",
    [
        (["simulate", "--voltage", "0.35"], "0.35 V is not a row of Table 2"),
        (["simulate", "--param", "c4=1"], r"unknown parameter\(s\) \['c4'\]"),
        (["simulate", "--param", "c3=inf"], "must be finite"),
        (["simulate", "--param", "c3"], "must look like NAME=VALUE"),
        (["simulate", "--n", "4"], "n must be odd"),
        (["simulate", "--dt", "0"], "--dt must be a positive"),
        (["simulate", "--param", "c3=-300", "--amplitude", "3", "--periods", "2"], "blew up at t="),
        (["simulate", "--voltage", "0.4", "--model", "duffing"], "--voltage selects a Table 2 row"),
        (["derive", "--model", "bouc"], "unknown model 'bouc'"),
    ],
)
def test_bad_input_exits_nonzero_with_one_line(argv, message, capsys):
    code, out, err = run(argv, capsys)
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err
    assert re.search(message, lines[0]), lines[0]


def test_reproduce_without_studies_says_where_to_run(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(["reproduce", "--smoke"], capsys)
    assert code == 2 and "no studies/run_all.py found" in err


def test_console_script_reports_without_traceback(tmp_path):
    """The installed entry point, as a user runs it: one stderr line, exit 2."""
    proc = subprocess.run(
        [sys.executable, "-m", "duffsym.cli", "simulate", "--n", "2"], capture_output=True, text=True, cwd=tmp_path
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and proc.stderr.count("\n") == 1
    assert "n must be odd" in proc.stderr


def test_derive_json_reproduces_eq13_and_eq9(capsys):
    """`duffsym derive --json` for the MR damper: Eq. 13's A and f, and Eq. 9's dV/dt, against the paper's."""
    import sympy as sp

    code, out, err = run(["derive", "--model", "mr-damper", "--n", "5", "--json"], capsys)
    assert code == 0
    items = {it["key"]: it for it in json.loads(out)["items"]}
    c1, c2, c3, k1, k2, k3, x1, x2 = sp.symbols("c1 c2 c3 k1 k2 k3 x1 x2", real=True)
    loc = {str(s): s for s in (c1, c2, c3, k1, k2, k3, x1, x2)}
    A = sp.Matrix(sp.sympify(items["state_space"]["data"]["A"], locals=loc))
    assert sp.simplify(A - sp.Matrix([[0, 1], [-(k1 + k2), -(c1 + c2)]])) == sp.zeros(2, 2)
    v_dot = sp.sympify(items["lyapunov_derivative"]["data"]["V_dot"], locals=loc)
    gamma, delta = c1 + c2, c3
    assert sp.simplify(v_dot - (-gamma * x2**2 - delta * x2**6)) == 0
    mapping = items["normalization"]["data"]["mapping"]
    assert sp.simplify(sp.sympify(mapping["gamma"], locals=loc) - (c1 + c2)) == 0
    assert sp.simplify(sp.sympify(mapping["alpha"], locals=loc) - (k1 + k2)) == 0


def test_derive_latex_and_text(capsys):
    code, out, _ = run(["derive", "--model", "duffing-like", "--n", "3", "--latex"], capsys)
    assert code == 0 and r"\dot{x}" in out and r"\delta" in out
    code, out, _ = run(["derive", "--model", "duffing-like", "--n", "3"], capsys)
    import sympy as sp

    line = re.search(r"dV/dt \(unforced\) = (.+)", out).group(1)
    gamma, delta, x2 = sp.symbols("gamma delta x2", real=True)
    derived = sp.sympify(line, locals={"gamma": gamma, "delta": delta, "x2": x2})
    assert code == 0 and sp.simplify(derived - (-gamma * x2**2 - delta * x2**4)) == 0  # Eq. 7 with n = 3


@pytest.fixture(scope="module")
def table2_csv(tmp_path_factory):
    """A noise-free record of Table 2's 0.4 V row written by `duffsym simulate` (4 periods at 2 Hz, dt 0.005)."""
    path = tmp_path_factory.mktemp("fit") / "t2.csv"
    assert main(["simulate", "--voltage", "0.4", "--periods", "4", "--out", str(path)]) == 0
    return path


def test_fit_recovers_symmetry_invariant_combinations(table2_csv, tmp_path, capsys):
    """A_f is fixed to max|y|, so the fit lands on the scaling-symmetric image of the truth:
    c1*A_f, k1*A_f, c1 + c2, k1 + k2 and c3/A_f^4 (n = 5) are what the data determine."""
    out = tmp_path / "fit.json"
    code, stdout, err = run(["fit", str(table2_csv), "--out", str(out), "--json", "--quiet"], capsys)
    assert code == 0, err
    d = json.loads(stdout)
    assert list(d)[:7] == ["model", "effects", "params", "stderr", "nrmse", "status", "success"]
    assert d["success"] and d["nrmse"] < 1e-3 and d["effects"] == []
    p, t = d["params"], TABLE2[0.4]
    assert p["k3"] == 0.0 and "k3" not in d["stderr"]
    for got, want in [
        (p["c1"] * p["A_f"], t["c1"] * t["A_f"]),
        (p["k1"] * p["A_f"], t["k1"] * t["A_f"]),
        (p["c1"] + p["c2"], t["c1"] + t["c2"]),
        (p["k1"] + p["k2"], t["k1"] + t["k2"]),
        (p["c3"] / p["A_f"] ** 4, t["c3"] / t["A_f"] ** 4),
    ]:
        assert got == pytest.approx(want, rel=2e-3)
    code, stdout, err = run(["validate", str(out), str(table2_csv), "--json"], capsys)
    v = json.loads(stdout)
    assert code == 0 and v["nrmse"] < 1e-3 and v["rmse"] < 1e-3


def test_fit_with_an_unknown_effect_lists_the_catalogue(table2_csv, capsys):
    code, _, err = run(["fit", str(table2_csv), "--add", "gremlins"], capsys)
    assert code == 2 and "unknown effect(s) ['gremlins']; choose from {" in err


def _bad_files(folder):
    t = np.arange(401) * 0.005
    rows = np.column_stack([t, np.sin(4 * np.pi * t), np.cos(4 * np.pi * t)])
    files = {"empty": b"", "header": b"time,displacement,force\n", "binary": bytes(range(256)) * 4}
    nan, unsorted = rows.copy(), rows.copy()
    nan[50, 2] = np.nan
    unsorted[[10, 11]] = unsorted[[11, 10]]
    for name, data, header in [
        ("nan", nan, "time,displacement,force"),
        ("unsorted", unsorted, "time,displacement,force"),
        ("missing", rows[:, :2], "time,displacement"),
        ("short", rows[:10], "time,displacement,force"),
    ]:
        path = folder / f"{name}.csv"
        np.savetxt(path, data, delimiter=",", header=header, comments="")
    for name, raw in files.items():
        (folder / f"{name}.csv").write_bytes(raw)
    return folder


@pytest.mark.parametrize(
    "name, message",
    [
        ("empty", "the file is empty"),
        ("header", "header but no data rows"),
        ("nan", "NaN/inf values in y"),
        ("unsorted", "strictly increasing"),
        ("missing", "missing column 'force'"),
        ("short", "too few samples"),
        ("binary", "binary file"),
    ],
)
def test_fit_bad_files_exit_2_with_one_line(name, message, tmp_path, capsys):
    folder = _bad_files(tmp_path)
    code, out, err = run(["fit", str(folder / f"{name}.csv")], capsys)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and message in err and "Traceback" not in err


def test_validate_reports_a_failed_free_run(table2_csv, tmp_path, capsys):
    """A fit whose parameters diverge on the record: a FAILED summary, exit 1, one stderr line, null errors in JSON."""
    out = tmp_path / "fit.json"
    assert main(["fit", str(table2_csv), "--out", str(out), "--quiet", "--json"]) == 0
    capsys.readouterr()
    saved = json.loads(out.read_text())
    saved["params"]["c3"] = -abs(saved["params"]["c3"])  # negative n-th power damping: finite-time blow-up
    out.write_text(json.dumps(saved))
    code, stdout, err = run(["validate", str(out), str(table2_csv)], capsys)
    assert code == 1 and "FAILED" in stdout and "blew up" in stdout
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    code, stdout, _ = run(["validate", str(out), str(table2_csv), "--json"], capsys)
    d = json.loads(stdout)
    assert code == 1 and d["success"] is False and d["nrmse"] is None and d["rmse"] is None


def test_every_help_text_renders(capsys):
    """argparse formats help strings with %: a stray "90 % intervals" once crashed `duffsym --help`."""
    from duffsym.cli import build_parser

    parser = build_parser()
    commands = sorted(parser._subparsers._group_actions[0].choices)
    assert {"fit", "diagnose", "ladder", "effects", "sample", "sindy"} <= set(commands)
    for argv in [["--help"]] + [[c, "--help"] for c in commands]:
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 0, argv
        assert "usage: duffsym" in capsys.readouterr().out
