"""Hysteresis-loop figures: the d–y and d'–y planes of one steady excitation cycle."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Sequence

import numpy as np

from duffsym.errors import DataError
from duffsym.simulate import Trajectory, steady_cycle


def _loop_columns(traj: Trajectory) -> tuple[np.ndarray, np.ndarray | None, str, str | None]:
    """The displacement and velocity columns of ``traj.u`` and their labels.

    The channels are found by name (``"d"``, ``"d_dot"``) in ``traj.input_names``; a model without
    them is drawn against its first input.
    """
    u = np.asarray(traj.u, dtype=float)
    if u.ndim != 2 or u.shape[0] != np.asarray(traj.t).size:
        raise DataError(f"trajectory {traj.model!r}: u must have shape (n_times, n_inputs); got {u.shape}")
    names = _input_names(traj)
    if "d" in names and "d_dot" in names:
        return u[:, names.index("d")], u[:, names.index("d_dot")], "d", "d_dot"
    if "d" in names:
        return u[:, names.index("d")], None, "d", None
    return u[:, 0], None, names[0] if names else "u", None


def _input_names(traj: Trajectory) -> list[str]:
    """Input channel names of the trajectory (``traj.input_names``; generic names if absent)."""
    n_inputs = np.asarray(traj.u).shape[1]
    if len(traj.input_names) == n_inputs:
        return list(traj.input_names)
    return [f"u{i}" for i in range(n_inputs)]


def steady_window(d, *, skip: float = 0.25) -> slice | None:
    """One full input cycle in steady state: of the cycles (rising sign change to rising sign change
    of ``d - mean(d)``) that start after the first ``skip`` of the record (the start-up transient),
    the one with the largest stroke, the latest of equal ones; None with fewer than two such cycles.

    A measured record often ends with the actuator slowing down, so its last cycle is not steady.
    """
    d = np.asarray(d, dtype=float)
    v = d - np.mean(d)
    rising = np.flatnonzero((v[:-1] <= 0) & (v[1:] > 0))  # sign changes of d - mean(d) upwards
    starts = [(a, b) for a, b in zip(rising[:-1], rising[1:]) if a >= skip * d.size]
    if len(starts) < 2:
        return None
    strokes = [np.ptp(d[a:b + 2]) for a, b in starts]
    best = max(range(len(starts)), key=lambda i: (round(strokes[i] / max(strokes), 3), i))
    a, b = starts[best]
    return slice(int(a), int(b) + 2)


_LABELS = {"d": r"$d$", "d_dot": r"$\dot d$", "F": r"$F$"}


def plot_loops(traj_or_list: Trajectory | Sequence[Trajectory], *, period: float | None = None,
               labels: Sequence[str] | None = None, axes=None, styles: Sequence[dict] | None = None,
               units: dict | None = None, title: str | None = None):
    """Draw the d–y and d'–y hysteresis loops of the last full cycle of one or more trajectories.

    Parameters
    ----------
    traj_or_list : a :class:`~duffsym.simulate.Trajectory` or a sequence of them. The input columns
        named ``"d"`` and ``"d_dot"`` are used; a model without them is drawn against its first input
        (one panel).
    period : excitation period, s. The last full period is drawn (``duffsym.simulate.steady_cycle``);
        ``None`` draws the whole trajectory.
    labels : legend label per trajectory (default: none).
    axes : two matplotlib axes ``(ax_d, ax_ddot)`` to draw into (one axis is enough for a single-input
        model); default: a new figure with two panels.
    styles : optional keyword dicts passed to ``Axes.plot`` per trajectory (colour, line style ...).
    units : unit of each signal, as in :attr:`~duffsym.data.Record.units`
        (``{"t": "s", "d": "mm", "y": "N"}``), shown in the axis labels; the velocity's unit is d's over t's.
    title : the figure title (say what is drawn: record, model, which cycles).

    Returns
    -------
    matplotlib.figure.Figure
        The figure holding the axes. Non-finite samples (a blown-up simulation) are left out.
    """
    import matplotlib.pyplot as plt

    trajs = [traj_or_list] if isinstance(traj_or_list, Trajectory) else list(traj_or_list)
    if not trajs:
        raise DataError("plot_loops needs at least one trajectory; got an empty sequence")
    for i, tr in enumerate(trajs):
        if not isinstance(tr, Trajectory):
            raise DataError(f"plot_loops: item {i} is a {type(tr).__name__}, not a Trajectory")
    if labels is not None and len(labels) != len(trajs):
        raise DataError(f"plot_loops: {len(labels)} labels for {len(trajs)} trajectories; give one per trajectory")
    if styles is not None and len(styles) != len(trajs):
        raise DataError(f"plot_loops: {len(styles)} styles for {len(trajs)} trajectories; give one per trajectory")
    if period is not None and not (np.isfinite(period) and period > 0):
        raise DataError(f"plot_loops: period must be a positive number of seconds; got {period}")

    cols = [_loop_columns(tr) for tr in trajs]
    two = any(c[1] is not None for c in cols)
    if axes is None:
        fig, ax = plt.subplots(1, 2 if two else 1, figsize=(8.0, 3.4) if two else (4.2, 3.4),
                               constrained_layout=True)
        axes = list(np.atleast_1d(ax))
    else:
        axes = list(np.atleast_1d(axes))
        fig = axes[0].figure
    if two and len(axes) < 2:
        raise DataError("plot_loops: the trajectories have d and d_dot inputs; pass two axes (d–y, d'–y)")

    for i, (tr, (d, v, dname, vname)) in enumerate(zip(trajs, cols)):
        sl = steady_cycle(tr, period) if period is not None else slice(0, tr.t.size)
        y = np.asarray(tr.y, dtype=float)[sl]
        kw = dict(styles[i]) if styles is not None else {}
        if labels is not None:
            kw.setdefault("label", labels[i])
        ok = np.isfinite(y) & np.isfinite(d[sl])
        axes[0].plot(np.where(ok, d[sl], np.nan), np.where(ok, y, np.nan), **kw)
        if v is not None:
            okv = np.isfinite(y) & np.isfinite(v[sl])
            kw.pop("label", None)  # one legend entry per trajectory, in the d–y panel
            axes[1].plot(np.where(okv, v[sl], np.nan), np.where(okv, y, np.nan), **kw)
    dname, vname = cols[0][2], cols[0][3]
    units = dict(units or {})
    if units.get("d") and units.get("d") != "1" and "d_dot" not in units:
        units["d_dot"] = f"{units['d']}/{units.get('t', 's')}"

    def label(name, text):
        return f"{text} [{units[name]}]" if units.get(name) else text

    axes[0].set_xlabel(label(dname, _LABELS.get(dname, dname)))
    ylabel = label("y", f"${trajs[0].output_name}$")
    axes[0].set_ylabel(ylabel)
    if two:
        axes[1].set_xlabel(label(vname, _LABELS.get(vname, vname)))
        axes[1].set_ylabel(ylabel)
    if title:
        fig.suptitle(title, fontsize="medium")
    for ax in axes[: 2 if two else 1]:
        ax.axhline(0.0, color="0.8", lw=0.6, zorder=0)
        ax.axvline(0.0, color="0.8", lw=0.6, zorder=0)
    if labels is not None:
        axes[0].legend(fontsize="small")
    return fig


def save_figure(fig, path: str | os.PathLike, *, dpi: int = 150, metadata: dict | None = None) -> Path:
    """Write ``fig`` to ``path`` (format from the suffix), creating folders, and close the figure.

    The figure is drawn on an Agg canvas, so no display is needed. ``metadata`` is stored in the
    file (PNG text chunks, PDF info; e.g. ``{"Description": "made by s07, full run"}``).

    Returns
    -------
    Path
        The path written.
    """
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    path = Path(path)
    if not path.suffix:
        raise DataError(f"save_figure: {str(path)!r} has no suffix; use .png, .pdf or .svg")
    from duffsym._io import atomic_path

    if not isinstance(fig.canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)  # attaches itself to the figure
    try:
        with atomic_path(path) as tmp:  # an interrupt or a failed draw leaves no half-written figure
            fig.savefig(tmp, dpi=dpi, format=path.suffix[1:].lower(),
                        **({"metadata": metadata} if metadata else {}))
    finally:
        plt.close(fig)
    return path
