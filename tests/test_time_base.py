"""Time bases a real file can have (issue 24): stamps rounded twice, large offsets, milliseconds, a text
(ISO date-time) column, each read as it should be; the grids are written here with numpy only."""

from __future__ import annotations

import json

import numpy as np
import pytest

from duffsym.cli import main
from duffsym.data import read_csv
from duffsym.data.record import rebuild_rounded_grid, time_unit_note


def _signals(n, dt):
    t = np.arange(n) * dt
    d = np.sin(2 * np.pi * 1.3 * t) + 0.3 * np.sin(2 * np.pi * 3.1 * t)
    return d, 0.5 * d + 0.2 * np.cos(2 * np.pi * 1.3 * t)


@pytest.mark.parametrize("seed", range(6))
def test_stamps_rounded_twice_are_a_uniform_grid(seed):
    """7 decimals, then printed to 4: up to half a printed digit plus the first rounding from the grid."""
    rng = np.random.default_rng(seed)
    fs, off, n = rng.uniform(200, 5000), rng.uniform(0, 1), int(rng.uniform(10_000, 60_000))
    truth = off + np.arange(n) / fs
    t, info = rebuild_rounded_grid(np.round(np.round(truth, 7), 4))
    assert info["uniform"] and info["rebuilt"]
    assert np.max(np.abs(t - truth)) < 1e-6 and abs(info["rate_hz"] / fs - 1) < 1e-6  # 1 % of the printed digit


def test_a_jittered_clock_is_still_refused():
    rng = np.random.default_rng(0)
    t = np.round(np.cumsum(rng.uniform(0.9e-3, 1.1e-3, 5000)), 4)
    assert not rebuild_rounded_grid(t)[1]["uniform"]


@pytest.mark.parametrize("offset", [1e9, 1.7e9])
def test_large_time_offsets_are_uniform(tmp_path, offset, capsys):
    """Unix-time stamps: float64 holds 1e9 s + k ms only to ~1.2e-7 s; the steps jitter by that much."""
    n, dt = 1500, 0.002
    t = offset + np.arange(n) * dt
    d, y = _signals(n, dt)
    path = tmp_path / "unix.csv"
    np.savetxt(
        path, np.column_stack([t, d, y]), delimiter=",", header="time,displacement,force", comments="", fmt="%.17g"
    )
    rec = read_csv(path)
    assert rec.metadata["sampling"]["uniform"] and rec.is_uniform()
    assert rec.require_uniform("the velocity") == pytest.approx(dt, rel=1e-4)  # steps quantised to 1.2e-7 s
    assert main(["fit", str(path), "--model", "mr-damper", "--json", "--quiet"]) in (0, 1)
    assert json.loads(capsys.readouterr().out)["nrmse"] < 10


def test_a_time_column_in_milliseconds_gets_a_note(tmp_path, capsys):
    n = 600
    d, y = _signals(n, 0.005)
    path = tmp_path / "ms.csv"
    np.savetxt(
        path,
        np.column_stack([np.arange(n) * 5.0, d, y]),
        delimiter=",",
        header="time,displacement,force",
        comments="",
        fmt="%.10g",
    )
    assert time_unit_note(np.arange(n) * 5.0) and time_unit_note(np.arange(n) * 0.005) is None
    assert (
        main(["convert", str(path), "--columns", "time=1,displacement=2,force=3", "--out", str(tmp_path / "o.csv")])
        == 0
    )
    err = capsys.readouterr().err
    assert "milliseconds" in err and "--dt 0.005" in err
    main(["fit", str(path), "--model", "mr-damper"])
    assert "milliseconds" in capsys.readouterr().err


def test_convert_reads_past_an_iso_date_time_column(tmp_path, capsys):
    n = 400
    d, y = _signals(n, 0.01)
    rows = [f"2025-11-14 20:09:{i * 0.01:09.6f},{a:.8g},{b:.8g}" for i, (a, b) in enumerate(zip(d, y))]
    src = tmp_path / "logger.csv"
    src.write_text("stamp,disp,force\n" + "\n".join(rows) + "\n")
    out = tmp_path / "o.csv"
    assert main(["convert", str(src), "--columns", "displacement=2,force=3", "--dt", "0.01", "--out", str(out)]) == 0
    rec = read_csv(out)
    assert rec.n_times == n and np.allclose(rec.d, d, rtol=1e-7, atol=1e-9)
    # selecting it as time is still an error, one line naming the column and what to do
    assert main(["convert", str(src), "--columns", "time=1,displacement=2,force=3", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "time column (1)" in err and "--dt" in err
    # without a header too
    src.write_text("\n".join(rows) + "\n")
    assert main(["convert", str(src), "--columns", "displacement=2,force=3", "--dt", "0.01", "--out", str(out)]) == 0
