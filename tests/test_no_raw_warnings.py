"""No command prints a raw Python warning (``path.py:123: SomeWarning: ...``) on the real data in ``../shared``.

Expected numerical conditions reach the user as the package's one-line notes (``note: ...``,
:func:`duffsym.errors.show_notes`, installed when ``duffsym`` is imported), from the command line and
from the API alike (a campaign fit through :func:`duffsym.identify.fit`). Runs each command in its own
process on real UTFSM MR-damper tests (skipped when the external data are absent).
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from _external import external_file

#: what Python's default warning display looks like: ``/x/y.py:351: ConvergenceWarning: ...``
RAW = re.compile(r"\.py:\d+: \w*Warning\b|^\s*warnings\.warn\(", re.M)


def _utfsm(name: str) -> Path:
    return external_file("mr_damper_utfsm_quiroz2022", "sinusoidal_preprocessed", f"{name}.txt")


def _run(args, cwd) -> subprocess.CompletedProcess:
    env_bin = str(Path(sys.executable).parent)
    proc = subprocess.run(
        [*args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=600,
        env={**__import__("os").environ, "PATH": env_bin + ":" + __import__("os").environ["PATH"], "MPLBACKEND": "Agg"},
    )
    return proc


def test_raw_warning_pattern_catches_python_s_format():
    assert RAW.search("/x/duffsym/identify/collocation.py:351: ConvergenceWarning: the Hessian is singular")
    assert not RAW.search("note: the Gauss-Newton Hessian is singular (condition number 1e+17)")


@pytest.mark.slow
@pytest.mark.ci
def test_commands_on_real_records_print_no_raw_warning(tmp_path):
    currents = {"2mm5Hz0A": 0.0, "2mm5Hz0x5A": 0.5, "2mm5Hz1A": 1.0, "2mm5Hz0x25A": 0.25}
    conv = "--columns time=1,displacement=2,velocity=3,force=4".split()
    commands = [
        ["duffsym", "convert", str(_utfsm(n)), *conv, "--current", str(c), "--out", f"{n}.csv"]
        for n, c in currents.items()
    ]
    commands += [
        ["duffsym", "fit", "2mm5Hz1A.csv", "--units", "input=mm,output=N", "--out", "one.json", "--plot", "one.png"],
        ["duffsym", "validate", "one.json", "2mm5Hz0x25A.csv", "--plot", "val.png"],
        [
            "duffsym",
            "fit",
            "2mm5Hz0A.csv",
            "2mm5Hz0x5A.csv",
            "2mm5Hz1A.csv",
            "--model",
            "mr-damper-current",
            "--out",
            "camp.json",
            "--plot",
            "camp.png",
        ],
        ["duffsym", "validate", "camp.json", "2mm5Hz0x25A.csv"],
        [
            sys.executable,
            "-c",
            "import duffsym\nfrom duffsym.identify import Problem, fit\n"
            "from duffsym.model import get_model\n"
            "recs = [duffsym.read_csv(f) for f in ('2mm5Hz0A.csv', '2mm5Hz0x5A.csv', '2mm5Hz1A.csv')]\n"
            "print(fit(Problem(get_model('mr-damper-current'), recs)).summary())",
        ],
    ]
    for cmd in commands:
        proc = _run(cmd, tmp_path)
        text = proc.stdout + proc.stderr
        assert not RAW.search(text), f"{' '.join(cmd[:3])}: raw warning in\n{text[-2000:]}"
        assert "Traceback" not in text, text[-2000:]
    assert (tmp_path / "camp.json").is_file() and (tmp_path / "val.png").is_file()
