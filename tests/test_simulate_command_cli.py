"""``duffsym simulate`` of a command-driven model: the CSV it writes against the independent numpy generator
(``tests/independent_current_sim.py``, which does not import duffsym), and one-line errors for the command."""

import numpy as np
import pytest

from duffsym.cli import main
from independent_current_sim import TRUTH, Sines, Switching, constant, generate

DT, FREQ, AMP = 0.001, 2.0, 1.0


def run(argv, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_switching_command_matches_the_independent_generator(tmp_path, capsys):
    # command ~0 at t = 0 (the package's free run starts the field at 0), switching 0 <-> 1 A a few times
    switching = Switching(0.0, 1.0, Sines((1.0, 0.6), (0.7, 1.9), (-np.pi / 2, 0.3)), sharp=8.0)
    ref = generate(
        TRUTH, Sines((AMP,), (FREQ,), (0.0,)), switching, dt=DT, duration=2.0, n=5, noise=0.0, settle=0.0, substeps=8
    )
    fine = np.arange(0, 2.0 + 1e-9, 1e-4)  # the command file, fine enough that linear interpolation is exact to 1e-6
    cmd = tmp_path / "cmd.csv"
    np.savetxt(cmd, np.c_[fine, switching(fine)], delimiter=",", header="time,current", comments="")
    out_csv = tmp_path / "sim.csv"
    params = ",".join(f"{k}={v}" for k, v in TRUTH.items())
    code, _, err = run(
        [
            "simulate",
            "--model",
            "mr-damper-current",
            "--n",
            "5",
            "--param",
            params,
            "--command",
            str(cmd),
            "--amplitude",
            str(AMP),
            "--frequency",
            str(FREQ),
            "--dt",
            str(DT),
            "--duration",
            "1.999",
            "--out",
            str(out_csv),
        ],
        capsys,
    )
    assert code == 0, err
    data = np.genfromtxt(out_csv, delimiter=",", names=True)
    assert data.dtype.names == ("time", "displacement", "velocity", "current", "force")
    k = data.size
    np.testing.assert_allclose(data["current"], ref["command"][:k], atol=1e-6)
    scale = np.sqrt(np.mean(ref["y_clean"][:k] ** 2))
    assert np.max(np.abs(data["force"] - ref["y_clean"][:k])) < 1e-4 * scale
    held = generate(
        TRUTH,
        Sines((AMP,), (FREQ,), (0.0,)),
        constant(0.0),
        dt=DT,
        duration=2.0,
        n=5,
        noise=0.0,
        settle=0.0,
        substeps=8,
    )
    assert np.max(np.abs(data["force"] - held["y_clean"][:k])) > 0.1 * scale  # the command does change the force


def test_held_command_gives_the_constant_current_column(tmp_path, capsys):
    out_csv = tmp_path / "sim.csv"
    code, _, err = run(
        [
            "simulate",
            "--model",
            "mr-damper-current",
            "--command",
            "0.5",
            "--periods",
            "1",
            "--param",
            "c2_u=-2",
            "--out",
            str(out_csv),
        ],
        capsys,
    )
    assert code == 0 and "changes nothing" not in err
    data = np.genfromtxt(out_csv, delimiter=",", names=True)
    assert np.all(data["current"] == 0.5)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--model", "mr-damper-current"], "is driven by a command"),
        (["--model", "mr-damper-current", "--command", "nan"], "must be a finite number or a CSV file"),
        (["--model", "mr-damper-current", "--command", "missing.csv"], "no such file"),
        (["--model", "mr-damper", "--command", "1"], "has no command input"),
    ],
)
def test_command_errors_are_one_line(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(["simulate", *argv], capsys)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1


def test_command_file_shorter_than_the_run(tmp_path, capsys):
    cmd = tmp_path / "cmd.csv"
    cmd.write_text("time,voltage\n0,0\n0.5,2.25\n")
    code, _, err = run(["simulate", "--model", "mr-damper-current", "--command", str(cmd), "--duration", "1"], capsys)
    assert code == 2 and "covers 0..0.5 s" in err


def test_defaults_warn_that_the_command_does_nothing(tmp_path, capsys):
    code, _, err = run(
        [
            "simulate",
            "--model",
            "mr-damper-current",
            "--command",
            "1",
            "--periods",
            "1",
            "--out",
            str(tmp_path / "s.csv"),
        ],
        capsys,
    )
    assert code == 0 and "changes nothing" in err
