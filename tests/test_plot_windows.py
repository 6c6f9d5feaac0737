"""Loop plots pick whole cycles where the input repeats and say "window" where it does not; ``validate --plot``.

Inputs are plain numpy signals (a sine test with a start-up and a ramp-down, a 1-15 Hz sweep, a
band-limited random signal); the validate figure is made on records of the independent generator
(``tests/independent_current_sim.py``).
"""

from __future__ import annotations

import numpy as np

from duffsym.plot.windows import loop_windows

T = np.arange(0, 8, 0.002)


def test_a_sine_test_gives_whole_steady_cycles():
    ramp = np.clip((8 - T) / 0.5, 0, 1)  # the actuator slows down at the end
    d = np.sin(2 * np.pi * 2 * T) * ramp
    w = loop_windows(d, count=2)
    assert w.whole_cycles and len(w.slices) == 2
    for sl in w.slices:
        seg = d[sl]
        assert abs((sl.stop - sl.start - 2) * 0.002 - 0.5) < 0.005  # one period of 2 Hz
        assert abs(seg[0] - seg[-2]) < 0.02 and np.ptp(seg) > 1.99  # closes, full stroke (not the ramp-down)
        assert T[sl.start] > 2.0
    assert "cycle, t = " in w.describe(T, 0)


def test_a_sweep_and_a_random_record_give_windows_not_cycles():
    sweep = 0.3 * np.sin(2 * np.pi * (1.0 * T + 0.5 * (14.0 / 8.0) * T**2))
    rng = np.random.default_rng(0)
    freqs = rng.uniform(0.5, 5, 12)
    rand = sum(np.sin(2 * np.pi * f * T + rng.uniform(0, 6.3)) for f in freqs) / 4
    for d in (sweep, rand):
        w = loop_windows(d, count=2)
        assert not w.whole_cycles and "does not repeat" in w.reason
        assert w.describe(T, 0).startswith("window, t = ")
        # a cycle cut from crossing to crossing of a sweep would not close: the windows never claim it does
        assert all(sl.stop - sl.start > 5 for sl in w.slices)


def test_the_largest_error_gets_a_window():
    d = np.sin(2 * np.pi * 2 * T)
    err = np.zeros_like(T)
    err[(T > 6.1) & (T < 6.3)] = 1.0
    w = loop_windows(d, count=2, error=err)
    assert any(T[sl.start] <= 6.2 <= T[sl.stop - 1] for sl in w.slices)


def test_validate_plot_on_a_random_record(tmp_path):
    import json

    from duffsym.cli import main
    from independent_current_sim import TRUTH, Sines, constant, generate

    def write(path, rec):
        np.savetxt(
            path,
            np.column_stack([rec["t"], rec["d"], rec["d_dot"], rec["y"]]),
            delimiter=",",
            header="time,displacement,velocity,force",
            comments="",
            fmt="%.10g",
        )

    write(tmp_path / "sine.csv", generate(TRUTH, Sines((1.0,), (2.0,), (0.0,)), constant(0.5), dt=0.004, duration=3.0))
    write(
        tmp_path / "rand.csv",
        generate(
            TRUTH,
            Sines((0.5, 0.4, 0.3), (0.7, 1.9, 3.1), (0.1, 1.0, 2.0)),
            constant(0.5),
            dt=0.004,
            duration=5.0,
            seed=2,
        ),
    )
    assert main(["fit", str(tmp_path / "sine.csv"), "--out", str(tmp_path / "f.json"), "--quiet"]) == 0
    png = tmp_path / "val.png"
    assert main(["validate", str(tmp_path / "f.json"), str(tmp_path / "rand.csv"), "--plot", str(png), "--json"]) == 0
    assert png.stat().st_size > 30_000 and png.read_bytes()[:4] == b"\x89PNG"
    # --plot may not name an input
    assert (
        main(["validate", str(tmp_path / "f.json"), str(tmp_path / "rand.csv"), "--plot", str(tmp_path / "rand.csv")])
        != 0
    )
    assert json.loads((tmp_path / "f.json").read_text())["success"]
