"""Measured against predicted: the figure of ``duffsym validate --plot`` (and of any free run on a record)."""

from __future__ import annotations

import numpy as np

from duffsym.plot.windows import LoopWindows, loop_windows


def _zoom(t: np.ndarray, err: np.ndarray, windows: LoopWindows) -> slice:
    """About three loop stretches (at least 5 % of the record) around the largest error."""
    width = max(3 * max((s.stop - s.start) for s in windows.slices), t.size // 20, 10)
    width = min(width, t.size)
    e2 = np.nan_to_num(err, nan=0.0) ** 2
    run = np.convolve(e2, np.ones(width), mode="valid")
    a = int(np.argmax(run)) if run.size else 0
    return slice(a, a + width)


def _label(name: str, units: dict, text: str) -> str:
    return f"{text} [{units[name]}]" if units.get(name) and units[name] != "1" else text


def plot_prediction(t, d, d_dot, y, y_hat, *, units: dict | None = None, title: str = "", count: int = 2):
    """Measured ``y`` and predicted ``y_hat`` over the record, a zoom on the largest error, and loops.

    Parameters
    ----------
    t, d, d_dot, y, y_hat : time, input displacement and velocity (``d_dot`` may be None), measured and
        predicted output, one value per sample.
    units : units of ``t``, ``d``, ``y`` (as :attr:`~duffsym.data.Record.units`), shown on the axes.
    title : what is compared (the figure adds the NRMSE).
    count : how many loop stretches to draw (:func:`~duffsym.plot.windows.loop_windows`: whole cycles
        where the input repeats, windows where it does not; the stretch with the largest stroke and
        the one with the largest error).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    t, d, y, y_hat = (np.asarray(a, dtype=float) for a in (t, d, y, y_hat))
    v = None if d_dot is None else np.asarray(d_dot, dtype=float)
    units = dict(units or {})
    err = y - y_hat
    nrmse = float(np.sqrt(np.nanmean(err**2)) / max(np.std(y), 1e-300))
    windows = loop_windows(d, count=count, error=err)
    zoom = _zoom(t, err, windows)
    n_loop = len(windows.slices) * (2 if v is not None else 1)
    fig = plt.figure(figsize=(max(9.0, 2.6 * n_loop), 8.2), constrained_layout=True)
    grid = fig.add_gridspec(3, n_loop, height_ratios=(1.0, 1.0, 1.25))
    _time_panel(fig.add_subplot(grid[0, :]), t, y, y_hat, units, "whole record", shade=zoom)
    _time_panel(
        fig.add_subplot(grid[1, :]),
        t[zoom],
        y[zoom],
        y_hat[zoom],
        units,
        f"zoom on the largest error, t = {t[zoom][0]:.3g}-{t[zoom][-1]:.3g} s",
        err=err[zoom],
    )
    _loop_panels(fig, grid, windows, t, d, v, y, y_hat, units)
    fig.suptitle(
        f"{title}{': ' if title else ''}free-run NRMSE {nrmse:.3g}\nloops below: "
        f"{'whole cycles' if windows.whole_cycles else 'windows, not cycles'}: {windows.reason}",
        fontsize="medium",
    )
    return fig


def _time_panel(ax, t, y, y_hat, units, what, *, shade=None, err=None) -> None:
    ax.plot(t, y, color="0.55", lw=1.4, label="measured")
    ax.plot(t, y_hat, color="tab:blue", lw=0.9, label="predicted (free run)")
    if err is not None:
        ax.plot(t, err, color="tab:red", lw=0.7, label="measured - predicted")
    if shade is not None:
        ax.axvspan(t[shade][0], t[shade][-1], color="tab:orange", alpha=0.15, lw=0, label="zoom")
    ax.set_xlabel(_label("t", units, "time"))
    ax.set_ylabel(_label("y", units, "y"))
    ax.set_title(what, fontsize="small")
    ax.legend(fontsize="x-small", loc="upper right", ncol=4)


def _loop_panels(fig, grid, windows, t, d, v, y, y_hat, units) -> None:
    col = 0
    d_unit = units.get("d")
    v_units = {**units, "v": f"{d_unit}/{units.get('t', 's')}"} if d_unit and d_unit != "1" else units
    for i, sl in enumerate(windows.slices):
        for x, name, text in ((d, "d", "d"), (v, "v", "d'")):
            if x is None:
                continue
            ax = fig.add_subplot(grid[2, col])
            ax.plot(x[sl], y[sl], ".", color="0.55", ms=2.5, label="measured")
            ax.plot(x[sl], y_hat[sl], color="tab:blue", lw=0.9, label="predicted")
            ax.set_xlabel(_label(name, v_units, text))
            ax.set_ylabel(_label("y", units, "y"))
            ax.set_title(windows.describe(t, i), fontsize="small")
            col += 1
    fig.axes[-1].legend(fontsize="x-small")
