"""Property-based fuzzing (hypothesis) of the CSV loader, the command-line options and FIT.json.

The properties: every input ends in a result or in one line on stderr with exit 2 (exit 1 for a failed
fit or free run), never an internal error, never a hang; a file broken on purpose is never accepted, and
a file changed only in layout (BOM, CRLF, quoting, column order, ...) reads the same values.

The default run is bounded (about a minute on a busy machine); ``pytest -m fuzz`` runs the long
versions (``slow`` too, so the default run skips them).
"""

from __future__ import annotations

import json
import signal
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).parent))
from _fuzz_mutations import base_rows, mutate_csv, tamper_fit
from duffsym.cli import main
from duffsym.data import read_csv
from duffsym.errors import DataError

QUICK = settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow]
)
LONG = settings(
    max_examples=2000, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow]
)


class Hang(BaseException):
    """Raised by the alarm: not an Exception, so the CLI's handlers cannot swallow it."""


@contextmanager
def time_limit(seconds: int):
    def on_alarm(signum, frame):
        raise Hang(f"no answer within {seconds} s")

    old = signal.signal(signal.SIGALRM, on_alarm)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def cli(argv, capsys, seconds=60):
    """``(exit code, stdout, stderr)``; argparse's own refusals (usage + one error line) come back as
    exit code ``"usage"``."""
    capsys.readouterr()
    try:
        with time_limit(seconds):
            code = main(argv)
    except SystemExit as stop:
        out, err = capsys.readouterr()
        assert stop.code == 2 and err.startswith("usage:") and len(err.strip().splitlines()[-1]) < 300, err
        return "usage", out, err
    out, err = capsys.readouterr()
    return code, out, err


def assert_clean_exit(code, err, allowed=(0, 1, 2, "usage")):
    assert code in allowed, err
    assert "internal error" not in err and "Traceback" not in err, err
    if code == 2:
        assert len(err.strip().splitlines()) == 1 and len(err) < 1000, err


# ------------------------------------------------------------------------------------------- loader
CLEAN = np.array([[float(x) for x in r] for r in base_rows()])


def check_loader(path: Path, broken: bool, name: str) -> str:
    """Read ``path``; return 'refused', 'accepted' or raise on a property violation."""
    try:
        with time_limit(30):
            rec = read_csv(path)
    except DataError as exc:
        msg = str(exc)
        assert "\n" not in msg and len(msg) < 800, msg[:300]
        assert str(path) in msg or "sampling must" in msg, msg
        if not broken:
            raise AssertionError(f"{name}: a valid file was refused: {msg}") from exc
        return "refused"
    if broken:
        raise AssertionError(f"{name}: a broken file was accepted silently")
    got = np.column_stack([rec.t, rec.d, rec.y])
    assert np.allclose(got, CLEAN, rtol=1e-12, atol=0), f"{name}: values changed"
    return "accepted"


def _loader_case(seed, tmp_path):
    name, data, broken = mutate_csv(seed)
    p = tmp_path / f"m{seed}.csv"
    p.write_bytes(data)
    return check_loader(p, broken, name)


@QUICK
@given(seed=st.integers(0, 2**32 - 1))
def test_loader_mutations(seed, tmp_path):
    _loader_case(seed, tmp_path)


@pytest.mark.slow
@pytest.mark.fuzz
@LONG
@given(seed=st.integers(0, 2**32 - 1))
def test_loader_mutations_long(seed, tmp_path):
    _loader_case(seed, tmp_path)


@QUICK
@given(data=st.binary(max_size=4000))
def test_loader_arbitrary_bytes(data, tmp_path):
    p = tmp_path / "b.csv"
    p.write_bytes(b"time,displacement,force\n" + data)
    try:
        with time_limit(30):
            read_csv(p)
    except DataError as exc:
        assert "\n" not in str(exc) and len(str(exc)) < 800


@QUICK
@given(text=st.text(alphabet=st.sampled_from(list("0123456789.,;-+eE \t\n\"'nafiNAFI\ufeff")), max_size=3000))
def test_loader_arbitrary_text(text, tmp_path):
    p = tmp_path / "t.csv"
    p.write_text("time,displacement,force\n" + text)
    try:
        with time_limit(30):
            rec = read_csv(p)
    except DataError as exc:
        assert "\n" not in str(exc) and len(str(exc)) < 800
    else:
        assert rec.n_times >= 20 and np.all(np.isfinite(rec.y)) and np.all(np.diff(rec.t) > 0)


# ------------------------------------------------------------------------------------------- options
@pytest.fixture(scope="module")
def record_csv(tmp_path_factory):
    path = tmp_path_factory.mktemp("fuzz") / "r.csv"
    assert main(["simulate", "--voltage", "0.4", "--periods", "4", "--out", str(path)]) == 0
    return path


NUMBERS = st.sampled_from(
    [
        "0",
        "-1",
        "1",
        "0.5",
        "1e-9",
        "1e9",
        "nan",
        "inf",
        "-inf",
        "1e400",
        "x",
        "",
        "3",
        "2",
        "0.005",
        "5",
        "99999",
        "-0",
    ]
)


@QUICK
@given(
    dt=NUMBERS,
    duration=NUMBERS,
    freq=NUMBERS,
    amp=NUMBERS,
    lines=NUMBERS,
    fmax=NUMBERS,
    exc=st.sampled_from(["sine", "multisine", "random"]),
    substeps=NUMBERS,
)
def test_simulate_options(dt, duration, freq, amp, lines, fmax, exc, substeps, tmp_path, capsys):
    argv = [
        "simulate",
        "--dt",
        dt,
        "--duration",
        duration,
        "--frequency",
        freq,
        "--amplitude",
        amp,
        "--lines",
        lines,
        "--f-max",
        fmax,
        "--excitation",
        exc,
        "--substeps",
        substeps,
        "--out",
        str(tmp_path / "s.csv"),
    ]
    code, _, err = cli(argv, capsys)
    # a valid combination that is merely large is refused by the sample cap, not simulated for minutes
    assert_clean_exit(code, err)


def _stub_fit(monkeypatch):
    """Replace the solve by a canned result: the options and the Problem are what is fuzzed here."""
    import duffsym.identify as ident
    from duffsym.identify.result import IdentificationResult
    from duffsym.model.presets import TABLE2

    canned = IdentificationResult.from_dict(
        {
            "model": "mr-damper",
            "params": dict(TABLE2[0.4]),
            "stderr": {},
            "nrmse": 0.01,
            "status": "Solve_Succeeded",
            "success": True,
        }
    )

    def fake_fit(problem, **kw):
        assert problem.free  # the Problem was built and checked
        return canned

    monkeypatch.setattr(ident, "fit", fake_fit)


@QUICK
@given(
    fix=st.lists(
        st.tuples(st.sampled_from(["c1", "c2", "c3", "k1", "k2", "k3", "A_f", "bogus", ""]), NUMBERS), max_size=3
    ),
    af=NUMBERS,
    n=NUMBERS,
    mask=st.sampled_from(["none", "auto", "file01", "file2", "fileshort", "missing"]),
    add=st.sampled_from([None, "backlash", "nope", "backlash,backlash", ""]),
)
def test_fit_options(fix, af, n, mask, add, record_csv, tmp_path, capsys, monkeypatch):
    _stub_fit(monkeypatch)
    n_rows = 401
    masks = {
        "file01": "\n".join(str(i % 2) for i in range(n_rows)),
        "file2": "\n".join("2" for _ in range(n_rows)),
        "fileshort": "1\n0\n",
    }
    argv = ["fit", str(record_csv), "--quiet", "--af", af, "--n", n]
    for name, value in fix:
        argv += ["--fix", f"{name}={value}"]
    if mask in masks:
        (tmp_path / "m.txt").write_text(masks[mask])
        argv += ["--mask", str(tmp_path / "m.txt")]
    else:
        argv += ["--mask", mask if mask != "missing" else str(tmp_path / "none.txt")]
    if add is not None:
        argv += ["--add", add]
    code, _, err = cli(argv, capsys)
    assert_clean_exit(code, err)


# ------------------------------------------------------------------------------------------- FIT.json
@pytest.fixture(scope="module")
def good_fit(record_csv, tmp_path_factory):
    path = tmp_path_factory.mktemp("fuzzfit") / "fit.json"
    assert main(["fit", str(record_csv), "--out", str(path), "--quiet"]) == 0
    return json.loads(path.read_text())


def _fit_case(seed, good_fit, record_csv, tmp_path, capsys):
    what, value = tamper_fit(good_fit, seed)
    p = tmp_path / "t.json"
    try:
        p.write_text(json.dumps(value))
    except (RecursionError, ValueError):
        return
    code, out, err = cli(["validate", str(p), str(record_csv), "--json"], capsys)
    assert_clean_exit(code, err)
    if code == 0:
        assert json.loads(out)["nrmse"] is not None, what


@QUICK
@given(seed=st.integers(0, 2**32 - 1))
def test_tampered_fit_json(seed, good_fit, record_csv, tmp_path, capsys):
    _fit_case(seed, good_fit, record_csv, tmp_path, capsys)


@pytest.mark.slow
@pytest.mark.fuzz
@settings(
    max_examples=500, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow]
)
@given(seed=st.integers(0, 2**32 - 1))
def test_tampered_fit_json_long(seed, good_fit, record_csv, tmp_path, capsys):
    _fit_case(seed, good_fit, record_csv, tmp_path, capsys)


def test_a_random_excitation_with_too_many_lines_is_refused_before_allocating():
    """Found by ``test_simulate_options`` in CI rehearsals (2 of 3 full runs): duration 99999 s x f_max 99999 Hz
    asked for 1e10 lines; ``np.arange`` then filled the memory page by page until the kernel killed pytest.
    The library refuses it (the command line refuses it earlier, by its cost)."""
    import resource

    from duffsym.excitation import BandLimitedRandom

    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    with open("/proc/self/status") as status:  # the process's address space now, in kB
        size = next(int(line.split()[1]) * 1024 for line in status if line.startswith("VmSize:"))
    resource.setrlimit(resource.RLIMIT_AS, (size + 2_000_000_000, hard))  # 80 GB of lines would fail here
    try:
        with pytest.raises(DataError, match=r"1e\+10 lines, more than 1000000"):
            BandLimitedRandom(rms=1.0, f_max=99999.0, duration=99999.0)
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def test_an_excitation_that_would_take_minutes_is_refused(tmp_path, capsys):
    """The fuzz test's other trap: 99999 lines at 10 001 samples took 96 s, over its 60 s limit."""
    argv = ["simulate", "--excitation", "multisine", "--lines", "99999", "--frequency", "1", "--f-max", "99999"]
    argv += ["--dt", "99999", "--duration", "1e9", "--out", str(tmp_path / "s.csv")]
    code, _, err = cli(argv, capsys, seconds=20)
    assert code == 2 and "sine evaluations, more than 2e+08" in err, err
