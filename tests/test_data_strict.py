"""Strict CSV reading and time stamps printed with rounding (issue 15, defects 2 and 4)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from duffsym.data import Record, read_csv
from duffsym.data import record as _record
from duffsym.errors import DataError

HEADER = "time,displacement,force"


def _sine(n=400, fs=200.0, f=2.0):
    t = np.arange(n) / fs
    return t, np.sin(2 * np.pi * f * t), 3 * np.cos(2 * np.pi * f * t)


def _csv(tmp_path, text, name="data.csv", encoding="utf-8"):
    p = tmp_path / name
    p.write_bytes(text.encode(encoding) if isinstance(text, str) else text)
    return p


def _body(fmt="{:.10g}", **kw):
    t, d, y = _sine(**kw)
    return [",".join(fmt.format(v) for v in row) for row in zip(t, d, y)]


# ------------------------------------------------------------------------------------------- header
def test_bom_is_accepted(tmp_path):
    rec = read_csv(_csv(tmp_path, "\ufeff" + HEADER + "\n" + "\n".join(_body())))
    assert rec.n_times == 400 and np.allclose(rec.y, _sine()[2])


def test_duplicate_column_name_is_refused(tmp_path):
    rows = [r + ",0" for r in _body()]
    with pytest.raises(DataError, match=r"row 1, columns 2 and 3: duplicate column name 'displacement'"):
        read_csv(_csv(tmp_path, "time,displacement,displacement,force\n" + "\n".join(rows)))
    with pytest.raises(DataError, match="duplicate column name 'Force'"):
        read_csv(_csv(tmp_path, "time,displacement,force,Force\n" + "\n".join(rows), "b.csv"))


def test_empty_column_name_is_refused(tmp_path):
    rows = [r + ",0" for r in _body()]
    with pytest.raises(DataError, match="row 1, column 3: the header has an empty column name"):
        read_csv(_csv(tmp_path, "time,displacement,,force\n" + "\n".join(rows)))


def test_trailing_delimiter_still_reads(tmp_path):
    rec = read_csv(_csv(tmp_path, HEADER + ",\n" + "\n".join(r + "," for r in _body())))
    assert rec.n_times == 400


# ------------------------------------------------------------------------------------------- rows
def test_long_row_is_refused(tmp_path):
    rows = _body()
    rows[7] += ",5"
    with pytest.raises(DataError, match="row 9 has 4 field.*header has 3"):
        read_csv(_csv(tmp_path, HEADER + "\n" + "\n".join(rows)))


def test_decimal_comma_in_a_comma_file_is_named(tmp_path):
    t, d, y = _sine()
    rows = _body()
    rows[20] = f"{t[20]:.10g},{d[20]:.10g},{str(round(y[20], 4)).replace('.', ',')}"
    with pytest.raises(DataError, match=r"row 22 has 4 field.*decimal comma"):
        read_csv(_csv(tmp_path, HEADER + "\n" + "\n".join(rows)))


def test_decimal_comma_in_a_semicolon_file_is_named(tmp_path):
    rows = [r.replace(",", ";") for r in _body()]
    rows[5] = rows[5].split(";")[0] + ";0,5;" + rows[5].split(";")[2]
    with pytest.raises(
        DataError, match=r"row 7, column 'displacement': cannot read '0,5' as a number; a decimal comma"
    ):
        read_csv(_csv(tmp_path, HEADER.replace(",", ";") + "\n" + "\n".join(rows)))


def test_latin1_byte_after_the_first_8kB_is_refused(tmp_path):
    rows = [r + ",ok" for r in _body()]
    rows[-5] = rows[-5][:-2] + "\xe9t\xe9"  # an unused column: formerly replaced silently
    p = _csv(tmp_path, (HEADER + ",note\n" + "\n".join(rows)).encode("latin-1"))
    assert p.stat().st_size > 8192
    with pytest.raises(DataError, match="not UTF-8"):
        read_csv(p)


def test_utf16_is_named(tmp_path):
    p = _csv(tmp_path, HEADER + "\n" + "\n".join(_body()), encoding="utf-16")
    with pytest.raises(DataError, match="UTF-16"):
        read_csv(p)


def test_huge_single_line_is_not_echoed(tmp_path):
    p = _csv(tmp_path, "a," * 2_500_000 + "\n")
    with pytest.raises(DataError) as info:
        read_csv(p)
    assert len(str(info.value)) < 600 and "\n" not in str(info.value)


def test_huge_field_is_a_data_error(tmp_path):
    p = _csv(tmp_path, HEADER + '\n0,1,"' + "9" * 300_000 + "\n")
    with pytest.raises(DataError, match="row 2") as info:
        read_csv(p)
    assert len(str(info.value)) < 600


def test_huge_value_is_not_echoed(tmp_path):
    rows = _body()
    rows[3] = "0.015,x" + "1" * 100_000 + ",0"
    with pytest.raises(DataError, match=r"row 5, column 'displacement'") as info:
        read_csv(_csv(tmp_path, HEADER + "\n" + "\n".join(rows)))
    assert len(str(info.value)) < 600


# ------------------------------------------------------------------------------------------- time stamps
def test_printed_quantum():
    assert np.allclose(
        _record.printed_quantum(np.array([24.6496, 0.0003328, 3.0, 0.5, 1e-3])), [1e-4, 1e-7, 1.0, 0.1, 1e-3]
    )


def _dyke_like_times(n=20_000, fs=3004.8):
    """Times printed like the Dyke record: 6 significant digits ('%g'), so 0.1 ms steps past 10 s."""
    return np.array([float(f"{v:g}") for v in np.arange(n) / fs]), np.arange(n) / fs


def test_rounded_grid_is_rebuilt_to_the_exact_rate():
    printed, exact = _dyke_like_times(40_000)
    assert not np.allclose(np.diff(printed), np.diff(exact), rtol=0.1, atol=0)  # 0.0003/0.0004 steps
    t, info = _record.rebuild_rounded_grid(printed)
    assert info["rebuilt"] and info["uniform"]
    assert info["rate_hz"] == pytest.approx(3004.8, rel=1e-7)
    assert np.max(np.abs(t - exact)) < 1e-9
    assert "rebuilt" in info["rule"]


def test_truncated_and_fixed_decimal_grids_are_rebuilt():
    k = np.arange(5000)
    fs = 1e7 / 2**14  # Silverbox
    for printed in (np.round(k / fs, 6), np.floor(k / 3004.8 * 1e4) / 1e4):
        t, info = _record.rebuild_rounded_grid(printed)
        assert info["rebuilt"], info
        assert np.allclose(np.diff(t), np.diff(t)[0], rtol=1e-12)
    assert _record.rebuild_rounded_grid(np.round(k / fs, 6))[1]["rate_hz"] == pytest.approx(fs, rel=1e-6)


def test_jittered_time_is_not_called_uniform():
    rng = np.random.default_rng(3)
    t = np.arange(5000) * 1e-3 + rng.uniform(-2e-5, 2e-5, 5000)
    for stamps in (t, np.round(t, 5)):
        out, info = _record.rebuild_rounded_grid(stamps)
        assert not info["uniform"] and not info["rebuilt"] and np.array_equal(out, stamps)


def _write_record(tmp_path, t, name="r.csv", t_true=None):
    """A record stamped ``t`` whose signals were sampled at ``t_true`` (default ``t``)."""
    t_true = t if t_true is None else t_true
    d = np.sin(2 * np.pi * 5 * t_true)
    y = np.cos(2 * np.pi * 5 * t_true)
    rows = [f"{a:g},{b:.9g},{c:.9g}" for a, b, c in zip(t, d, y)]
    return _csv(tmp_path, HEADER + "\n" + "\n".join(rows), name)


def test_read_csv_rebuilds_a_rounded_time_column_and_says_so(tmp_path):
    printed, exact = _dyke_like_times(40_000)
    rec = read_csv(_write_record(tmp_path, printed, t_true=exact))
    assert np.max(np.abs(rec.t - exact)) < 1e-9
    s = rec.metadata["sampling"]
    assert s["rebuilt"] and s["rate_hz"] == pytest.approx(3004.8, rel=1e-7)
    # the velocity (which needs uniform steps) is now available and right
    v = rec.velocity()
    assert np.allclose(v[100:-100], 2 * np.pi * 5 * np.cos(2 * np.pi * 5 * exact[100:-100]), rtol=0, atol=1e-3 * 31.4)


def test_six_decimal_silverbox_times_allow_derivatives(tmp_path):
    fs = 1e7 / 2**14
    t = np.round(np.arange(6000) / fs, 6)
    rows = [f"{a:.6f},{math.sin(2 * math.pi * 7 * a):.9g},{math.cos(2 * math.pi * 7 * a):.9g}" for a in t]
    rec = read_csv(_csv(tmp_path, "time,input,output\n" + "\n".join(rows)))
    assert rec.is_uniform() and rec.metadata["sampling"]["rate_hz"] == pytest.approx(fs, rel=1e-6)
    rec.acceleration()  # formerly: "1212 steps differ ... by more than 1e-06 relative"


def test_non_uniform_time_is_refused_unless_asked(tmp_path):
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.8e-3, 1.2e-3, 3000))
    p = _write_record(tmp_path, np.round(t, 9))
    with pytest.raises(DataError, match="not uniformly sampled.*--sampling resample"):
        read_csv(p)
    given = read_csv(p, sampling="as-given")
    assert not given.is_uniform() and "as given" in given.metadata["sampling"]["rule"]
    res = read_csv(p, sampling="resample")
    assert res.is_uniform() and res.metadata["sampling"]["resampled"]
    assert np.allclose(res.d, np.sin(2 * np.pi * 5 * res.t), atol=2e-3)


def test_missing_samples_keep_their_exact_stamps(tmp_path):
    t = np.arange(1000) * 1e-3
    keep = np.ones(1000, dtype=bool)
    keep[[100, 500, 501]] = False
    rec = read_csv(_write_record(tmp_path, t[keep]))
    assert np.array_equal(rec.t, [float(f"{v:g}") for v in t[keep]]) and "3 missing" in rec.metadata["sampling"]["rule"]


def test_record_metadata_reports_sampling():
    t, d, y = _sine()
    s = Record(t=t, d=d, y=y).metadata["sampling"]
    assert s["uniform"] and not s["rebuilt"] and s["rate_hz"] == pytest.approx(200.0)


@pytest.mark.parametrize("value", ["\u0661\u0662", "1_000", "\uff11"])
def test_numbers_python_would_take_but_a_csv_should_not(tmp_path, value):
    """float() reads '١٢' as 12, '1_000' as 1000 and a full-width '１' as 1: in a data file they are typos
    or foreign formats, not numbers (found by the fuzz corpus)."""
    rows = _body()
    rows[9] = rows[9].split(",")[0] + f",{value}," + rows[9].split(",")[2]
    with pytest.raises(DataError, match="row 11, column 'displacement': cannot read"):
        read_csv(_csv(tmp_path, HEADER + "\n" + "\n".join(rows)))
