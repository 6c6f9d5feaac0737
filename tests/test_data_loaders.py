"""CSV reader (format of docs/contract.md), its one-line errors, and the loaders of the real data."""

from __future__ import annotations

import numpy as np
import pytest

from duffsym import DataError, Sine, mr_damper
from duffsym.data import (
    Record,
    external_data_dir,
    load_mr_damper_utfsm,
    load_silverbox,
    parse_utfsm_name,
    read_csv,
    synthetic_record,
    write_csv,
)


def _write(tmp_path, text, name="data.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def _rows(n=100, dt=0.01, f=2.0):
    t = np.arange(n) * dt
    return t, np.sin(2 * np.pi * f * t), 2 * np.pi * f * np.cos(2 * np.pi * f * t), 3 * np.cos(2 * np.pi * f * t)


def test_round_trip_default_columns(tmp_path):
    rec = synthetic_record(mr_damper(), None, Sine(1.0, 2.0), dt=0.005, duration=1.0, noise=0.01, rng=1)
    rec = rec.replace(current=0.5)
    path = write_csv(rec, tmp_path / "r.csv")
    back = read_csv(path, units={"input": "mm", "force": "N"})
    assert np.array_equal(back.t, rec.t) and np.array_equal(back.d, rec.d) and np.array_equal(back.y, rec.y)
    assert np.array_equal(back.d_dot, rec.d_dot)
    assert back.current == 0.5 and back.units["d"] == "mm" and back.units["y"] == "N"


def test_column_mapping_and_synonyms(tmp_path):
    t, d, v, y = _rows()
    lines = ["t;V1;V2;junk"] + [f"{a};{b};{c};x" for a, b, c in zip(t, d, y)]
    rec = read_csv(_write(tmp_path, "\n".join(lines)), columns={"time": "t", "input": "V1", "output": "V2"})
    assert np.allclose(rec.d, d) and np.allclose(rec.y, y) and rec.d_dot is None
    rec2 = read_csv(
        _write(tmp_path, "\n".join(lines), "b.csv"), columns={"t": "t", "displacement": "V1", "force": "v2"}
    )
    assert np.allclose(rec2.y, y)
    # canonical role names as file columns
    lines = ["Time,Input,Output"] + [f"{a},{b},{c}" for a, b, c in zip(t, d, y)]
    assert np.allclose(read_csv(_write(tmp_path, "\n".join(lines), "c.csv")).y, y)


def test_empty_file(tmp_path):
    with pytest.raises(DataError, match="the file is empty"):
        read_csv(_write(tmp_path, ""))
    with pytest.raises(DataError, match="the file is empty"):
        read_csv(_write(tmp_path, "\n \n", "b.csv"))


def test_header_only(tmp_path):
    with pytest.raises(DataError, match="header but no data rows"):
        read_csv(_write(tmp_path, "time,displacement,force\n"))


def test_binary_file(tmp_path):
    p = tmp_path / "x.csv"
    p.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(DataError, match="binary file"):
        read_csv(p)


def test_missing_column(tmp_path):
    t, d, v, y = _rows()
    text = "time,displacement,f\n" + "\n".join(f"{a},{b},{c}" for a, b, c in zip(t, d, y))
    with pytest.raises(DataError, match=r"missing column 'force' \(the output\).*--columns output="):
        read_csv(_write(tmp_path, text))
    with pytest.raises(DataError, match=r"missing column 'V9' \(for input\)"):
        read_csv(_write(tmp_path, text, "b.csv"), columns={"input": "V9", "output": "f"})


def test_unknown_role(tmp_path):
    with pytest.raises(DataError, match="unknown column role 'speed'"):
        read_csv(_write(tmp_path, "time,displacement,force\n0,0,0\n"), columns={"speed": "v"})


def test_unparsable_value_names_row_and_column(tmp_path):
    t, d, v, y = _rows()
    rows = [f"{a},{b},{c}" for a, b, c in zip(t, d, y)]
    rows[6] = f"{t[6]},1.2.3,{y[6]}"
    with pytest.raises(DataError, match=r"row 8, column 'displacement': cannot read '1.2.3'"):
        read_csv(_write(tmp_path, "time,displacement,force\n" + "\n".join(rows)))


def test_ragged_row(tmp_path):
    t, d, v, y = _rows()
    rows = [f"{a},{b},{c}" for a, b, c in zip(t, d, y)]
    rows[3] = f"{t[3]},{d[3]}"
    with pytest.raises(DataError, match="row 5 has 2 field"):
        read_csv(_write(tmp_path, "time,displacement,force\n" + "\n".join(rows)))


def test_numeric_first_row_is_not_a_header(tmp_path):
    with pytest.raises(DataError, match="is numeric, not a header"):
        read_csv(_write(tmp_path, "0,1,2\n1,2,3\n"))


def test_nan_field_and_policy(tmp_path):
    t, d, v, y = _rows()
    rows = [f"{a},{b},{c}" for a, b, c in zip(t, d, y)]
    rows[10] = f"{t[10]},{d[10]},"
    text = "time,displacement,force\n" + "\n".join(rows)
    with pytest.raises(DataError, match=r"NaN/inf values in y: 1 \(first at index 10\)"):
        read_csv(_write(tmp_path, text))
    with pytest.warns(UserWarning, match="dropped 1 of 100"):
        assert read_csv(_write(tmp_path, text, "b.csv"), nan_policy="omit").n_times == 99


def test_unsorted_time_from_csv(tmp_path):
    t, d, v, y = _rows()
    t[[20, 21]] = t[[21, 20]]
    text = "time,displacement,force\n" + "\n".join(f"{a},{b},{c}" for a, b, c in zip(t, d, y))
    with pytest.raises(DataError, match="strictly increasing.*first at index 21"):
        read_csv(_write(tmp_path, text))


def test_varying_current_is_the_command_history(tmp_path):
    """A varying current column is the record's command history (for command-driven models); a model without
    a command input refuses it instead of averaging the levels."""
    from duffsym.identify.problem import check_command
    from duffsym.model import get_model

    t, d, v, y = _rows()
    text = "time,displacement,force,current\n" + "\n".join(
        f"{a},{b},{c},{0.5 if i < 50 else 1.0}" for i, (a, b, c) in enumerate(zip(t, d, y))
    )
    rec = read_csv(_write(tmp_path, text))
    assert rec.current is None and rec.command_name == "current" and rec.command_varies
    np.testing.assert_array_equal(rec.command_signal(), np.where(np.arange(rec.n_times) < 50, 0.5, 1.0))
    with pytest.raises(DataError, match=r"current varies \(0.5 to 1\) but model mr-damper has no command input"):
        check_command(get_model("mr-damper"), [rec])
    check_command(get_model("mr-damper-current"), [rec], free=("c1_u",))


def test_no_such_file(tmp_path):
    with pytest.raises(DataError, match="no such file"):
        read_csv(tmp_path / "nope.csv")


def test_utfsm_name_parsing():
    assert parse_utfsm_name("25mm0x1Hz0x75A.txt") == {"amplitude_mm": 25.0, "frequency_hz": 0.1, "current_a": 0.75}
    assert parse_utfsm_name("2mm5Hz1A") == {"amplitude_mm": 2.0, "frequency_hz": 5.0, "current_a": 1.0}
    with pytest.raises(DataError, match="does not follow"):
        parse_utfsm_name("ME10mm2Hz.txt")


def test_external_data_dir_env(monkeypatch, tmp_path):
    monkeypatch.setenv("DUFFSYM_EXTERNAL_DATA", str(tmp_path))
    assert external_data_dir() == tmp_path
    monkeypatch.setenv("DUFFSYM_EXTERNAL_DATA", str(tmp_path / "missing"))
    with pytest.raises(DataError, match="is not a folder; set DUFFSYM_EXTERNAL_DATA"):
        external_data_dir()


# ---------------------------------------------------------------------------- real data (skipped when absent)
def _external():
    try:
        return external_data_dir()
    except DataError as exc:
        pytest.skip(f"external data not available: {exc}")


def test_utfsm_sine_file():
    base = _external() / "mr_damper_utfsm_quiroz2022" / "sinusoidal_preprocessed"
    if not base.is_dir():
        pytest.skip("UTFSM MR damper data not present")
    rec = load_mr_damper_utfsm(base / "5mm3Hz1A.txt")
    assert isinstance(rec, Record) and rec.current == 1.0 and rec.metadata["frequency_hz"] == 3.0
    assert rec.units == {"t": "s", "d": "mm", "d_dot": "mm/s", "y": "N"}
    assert rec.dt == pytest.approx(0.001)
    # SOURCE.md: 5mm3Hz x within +-4.55 mm, force up to ~1530 N at 1 A
    assert 4.0 < np.max(np.abs(rec.d)) < 5.0 and 1300 < np.max(np.abs(rec.y)) < 1700
    # the file's velocity is a one-sided difference: it matches the centred derivative shifted by half a sample
    derived = load_mr_damper_utfsm(base / "5mm3Hz1A.txt", velocity="derive")
    assert derived.d_dot is None
    v_file, v_ctr = np.asarray(rec.d_dot), np.asarray(derived.velocity())
    amp = np.max(np.abs(v_ctr))
    assert np.sqrt(np.mean((v_file - v_ctr) ** 2)) / amp < 0.05
    assert rec.period == pytest.approx(1 / 3, rel=0.02)
    with pytest.raises(DataError, match="file name says 1 A"):
        load_mr_damper_utfsm(base / "5mm3Hz1A.txt", current=0.5)


def test_utfsm_earthquake_mat():
    path = _external() / "mr_damper_utfsm_quiroz2022" / "earthquake_validation" / "validacion.mat"
    if not path.is_file():
        pytest.skip("UTFSM validation record not present")
    rec = load_mr_damper_utfsm(path, current=0.6)
    assert rec.n_times == 64648 and rec.dt == pytest.approx(0.001) and rec.current == 0.6
    # SOURCE.md: displacement -7.95 ... 6.66 mm, force peak ~908 N at 0.6 A
    assert rec.d.min() == pytest.approx(-7.95, abs=0.01) and np.max(np.abs(rec.y)) == pytest.approx(908, abs=1)
    with pytest.raises(DataError, match="give current= one of"):
        load_mr_damper_utfsm(path)


def test_silverbox_split():
    path = _external() / "silverbox" / "SNLS80mV.csv"
    if not path.is_file():
        pytest.skip("Silverbox data not present")
    rec = load_silverbox(path, part="multisine_test")
    assert rec.n_times == 21688 and rec.units["d"] == "V"
    assert rec.dt == pytest.approx(2**14 / 1e7)
    assert np.max(np.abs(rec.d)) < 0.2 and np.max(np.abs(rec.y)) < 0.31
    with pytest.raises(DataError, match="part must be one of"):
        load_silverbox(path, part="train")
