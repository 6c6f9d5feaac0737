"""``duffsym convert``: the files labs have (text, CSV with other names, .mat) to a record, checked
against the package's own loaders and numpy's reader of the same files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from duffsym.cli import main
from duffsym.data import load_mr_damper_utfsm, read_csv
from duffsym.data.convert import read_table

DATA = Path(__file__).resolve().parents[1] / "data"


@pytest.fixture
def utfsm_txt():
    """One real UTFSM text file (third-party data, never shipped: found through DUFFSYM_EXTERNAL_DATA)."""
    from duffsym.data.loaders import external_data_dir
    from duffsym.errors import DuffsymError

    try:
        f = external_data_dir() / "mr_damper_utfsm_quiroz2022" / "sinusoidal_preprocessed" / "2mm5Hz1A.txt"
    except DuffsymError as exc:
        pytest.skip(str(exc))
    if not f.is_file():
        pytest.skip(f"{f} is missing")
    return f


@pytest.fixture
def plain_txt(tmp_path):
    """A headerless whitespace text file with 4 columns (time, displacement, velocity, force)."""
    rec = read_csv(DATA / "synthetic_sine.csv")
    f = tmp_path / "plain" / "plain.txt"
    f.parent.mkdir()
    np.savetxt(f, np.column_stack([rec.t, rec.d, rec.d_dot, rec.y]))
    return f


def test_utfsm_text_file_converts_to_the_values_numpy_reads(tmp_path, capsys, utfsm_txt):
    out = tmp_path / "real.csv"
    code = main(
        [
            "convert",
            str(utfsm_txt),
            "--columns",
            "time=1,displacement=2,velocity=3,force=4",
            "--current",
            "1",
            "--out",
            str(out),
            "--json",
        ]
    )
    doc = json.loads(capsys.readouterr().out)
    assert code == 0 and doc["n_samples"] == 450 and doc["velocity"]
    raw = np.loadtxt(utfsm_txt)
    rec = read_csv(out)
    np.testing.assert_array_equal(rec.t, raw[:, 0])
    np.testing.assert_array_equal(rec.d, raw[:, 1])
    np.testing.assert_array_equal(rec.d_dot, raw[:, 2])
    np.testing.assert_array_equal(rec.y, raw[:, 3])
    assert rec.current == 1.0
    # the same record as the data set's own loader (which reads the current from the file name)
    named = tmp_path / "2mm5Hz1A.txt"
    named.write_bytes(utfsm_txt.read_bytes())
    ref = load_mr_damper_utfsm(named)
    np.testing.assert_array_equal(ref.y, rec.y)
    assert ref.current == rec.current


def test_mat_matrix_without_time_equals_the_csv_record(tmp_path, capsys):
    out = tmp_path / "m.csv"
    code = main(
        [
            "convert",
            str(DATA / "synthetic_sine.mat"),
            "--variable",
            "data",
            "--columns",
            "displacement=1,force=2",
            "--dt",
            "0.005",
            "--out",
            str(out),
            "--quiet",
        ]
    )
    assert code == 0 and capsys.readouterr().err == ""
    a, b = read_csv(out), read_csv(DATA / "synthetic_sine.csv")
    np.testing.assert_allclose(a.t, b.t, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(a.d, b.d)
    np.testing.assert_array_equal(a.y, b.y)


def test_columns_by_header_name_and_comment_lines(tmp_path):
    f = tmp_path / "lab.txt"
    f.write_text(
        "% exported by a DAQ\nT  X_mm  F_kN\n"
        + "\n".join(
            f"{k * 0.01:.2f} {np.sin(2 * np.pi * k / 25):.6f} {2 * np.cos(2 * np.pi * k / 25):.6f}" for k in range(100)
        )
    )
    rec = read_table(f, columns={"time": "t", "displacement": "X_mm", "force": "3"})
    assert rec.n_times == 100 and rec.dt == pytest.approx(0.01) and rec.y[0] == 2.0


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--columns", "time=1,displacement=9,force=4"], "column 9 for input is out of range; the file has 4 columns"),
        (["--columns", "displacement=2,force=4"], "no time column; give --dt"),
        (["--columns", "time=1,force=4"], "must name the displacement column"),
        (["--columns", "time=1,displacement=2,force=4,temperature=3"], "unknown role 'temperature'"),
        (["--columns", "time=1,displacement=x,force=4"], "no column 'x' for input; it has no header row"),
        (["--columns", "time=1,displacement=2,force=4", "--format", "mat"], "not a readable MATLAB"),
    ],
)
def test_bad_input_one_line_exit_2_and_no_file(tmp_path, capsys, argv, message, plain_txt):
    out = tmp_path / "x.csv"
    code = main(["convert", str(plain_txt), *argv, "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["plain"]


def test_a_bad_row_names_its_line(tmp_path, capsys):
    f = tmp_path / "bad.txt"
    f.write_text("0 0 1\n0.1 1 2\n0.2 oops 3\n")
    code = main(["convert", str(f), "--columns", "time=1,displacement=2,force=3", "--out", str(tmp_path / "o.csv")])
    assert code == 2 and "line 3" in capsys.readouterr().err
