"""Hysteresis loops of one steady excitation cycle: which cycle, its numbers, its figure.

- :func:`steady_window`: one full input cycle in steady state of a record.
- :func:`loop_metrics`, :func:`trajectory_loop_metrics`, :class:`LoopMetrics`: numbers measured on one cycle
  of samples of ``d``, ``d_dot`` and ``y`` (simulated or measured; no plotting), which put numbers on the words
  the paper uses for its Figs. 3 and 6: loop area, width, pre-/post-yield slopes, turning sharpness,
  orientation, force amplitude and linearity; :func:`cycle_integral`, :func:`signed_area`.
- :func:`plot_loops`: the d–y and d'–y planes drawn (matplotlib imported inside); :func:`save_figure`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

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
    strokes = [np.ptp(d[a : b + 2]) for a, b in starts]
    best = max(range(len(starts)), key=lambda i: (round(strokes[i] / max(strokes), 3), i))
    a, b = starts[best]
    return slice(int(a), int(b) + 2)


_LABELS = {"d": r"$d$", "d_dot": r"$\dot d$", "F": r"$F$"}


def plot_loops(
    traj_or_list: Trajectory | Sequence[Trajectory],
    *,
    period: float | None = None,
    labels: Sequence[str] | None = None,
    axes=None,
    styles: Sequence[dict] | None = None,
    units: dict | None = None,
    title: str | None = None,
):
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
        fig, ax = plt.subplots(1, 2 if two else 1, figsize=(8.0, 3.4) if two else (4.2, 3.4), constrained_layout=True)
        axes = list(np.atleast_1d(ax))
    else:
        axes = list(np.atleast_1d(axes))
        fig = axes[0].figure
    if two and len(axes) < 2:
        raise DataError("plot_loops: the trajectories have d and d_dot inputs; pass two axes (d–y, d'–y)")

    for i, (tr, (d, v, _dname, _vname)) in enumerate(zip(trajs, cols)):
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
    dname = cols[0][2]
    units = dict(units or {})
    if units.get("d") and units.get("d") != "1" and "d_dot" not in units:
        units["d_dot"] = f"{units['d']}/{units.get('t', 's')}"

    def label(name, text):
        return f"{text} [{units[name]}]" if units.get(name) else text

    axes[0].set_xlabel(label(dname, _LABELS.get(dname, dname)))
    ylabel = label("y", f"${trajs[0].output_name}$")
    axes[0].set_ylabel(ylabel)
    if two:
        # the velocity channel of the first trajectory that has one (the first may have none)
        vname = next(c[3] for c in cols if c[3] is not None)
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
            fig.savefig(tmp, dpi=dpi, format=path.suffix[1:].lower(), **({"metadata": metadata} if metadata else {}))
    finally:
        plt.close(fig)
    return path


# ---------------------------------------------------------------------------------------------- metrics
def signed_area(x: np.ndarray, y: np.ndarray) -> float:
    """Signed area enclosed by the closed polygon (x, y) (shoelace): > 0 when counter-clockwise."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def cycle_integral(x, y) -> float:
    """:math:`\\oint y\\,dx` over a closed cycle of samples, by the trapezoid rule (closed from the last
    sample back to the first): the d–y loop area, i.e. the work per cycle, when x = d and y is the force."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    return float(np.sum(0.5 * (y + np.roll(y, -1)) * (np.roll(x, -1) - x)))


def _crossings(s: np.ndarray, other: np.ndarray) -> list[tuple[float, int]]:
    """Values of ``other`` (linearly interpolated) where ``s`` changes sign, with the crossing direction."""
    out = []
    n = s.size
    for i in range(n):
        j = (i + 1) % n
        if s[i] == 0.0:
            out.append((float(other[i]), int(np.sign(s[j] - s[i]))))
        elif s[i] * s[j] < 0:
            w = s[i] / (s[i] - s[j])
            out.append((float(other[i] + w * (other[j] - other[i])), int(np.sign(s[j] - s[i]))))
    return out


def _gap(s: np.ndarray, other: np.ndarray) -> float:
    """Distance between the values of ``other`` at the rising and the falling zero crossing of ``s``."""
    cross = _crossings(s, other)
    up = [v for v, direction in cross if direction > 0]
    down = [v for v, direction in cross if direction < 0]
    if not up or not down:
        return float("nan")
    return abs(float(np.mean(up)) - float(np.mean(down)))


def _slope(x: np.ndarray, y: np.ndarray) -> float:
    if x.size < 2 or np.ptp(x) == 0:
        return float("nan")
    return float(np.polyfit(x, y, 1)[0])


@dataclass(frozen=True)
class LoopMetrics:
    """Numbers describing one steady hysteresis cycle.

    Attributes
    ----------
    peak : max |y| (the force amplitude).
    area_d : area of the d–y loop, :math:`\\oint y\\,dd` (the energy dissipated per cycle, > 0 for a
        passive device).
    area_v : signed area of the d'–y loop (shoelace): > 0 counter-clockwise, < 0 clockwise.
    orientation : ``"counter-clockwise"`` or ``"clockwise"`` (of the d'–y loop).
    width_v : d'-distance between the two branches at y = 0 (the pre-yield width of the d'–y loop).
    width_d : d-distance between the two branches at y = 0 in the d–y loop.
    height_v : y-distance between the branches at d' = 0.
    pre_yield_slope : mean dy/dd' of the two branches where |y| < ``pre_fraction`` * peak.
    post_yield_slope : dy/dd' where |d'| > ``post_fraction`` * max |d'| (both branches).
    sharpness : pre_yield_slope / post_yield_slope; large for a sharp pre/post-yield turn.
    linearity : R^2 of a straight-line fit of y on d' over the cycle (1 for a purely viscous device).
    """

    peak: float
    area_d: float
    area_v: float
    orientation: str
    width_v: float
    width_d: float
    height_v: float
    pre_yield_slope: float
    post_yield_slope: float
    sharpness: float
    linearity: float

    def summary(self) -> str:
        return (
            f"peak {self.peak:.4g}, d-y area {self.area_d:.4g}, d'-y area {self.area_v:.4g} ({self.orientation}), "
            f"width at y=0: d' {self.width_v:.4g}, d {self.width_d:.4g}; height at d'=0 {self.height_v:.4g}; "
            f"slopes pre {self.pre_yield_slope:.4g}, post {self.post_yield_slope:.4g} (sharpness "
            f"{self.sharpness:.3g}); linearity R^2 {self.linearity:.4f}"
        )


def loop_metrics(d, d_dot, y, *, pre_fraction: float = 0.5, post_fraction: float = 0.8) -> LoopMetrics:
    """Measure one closed cycle of samples ``d, d_dot, y`` (each ``(n_times,)``).

    The samples must cover one period (the first and last samples need not coincide); take them
    with :func:`duffsym.simulate.steady_cycle` from a simulation.

    Parameters
    ----------
    pre_fraction : samples with |y| below this fraction of the peak define the pre-yield region.
    post_fraction : samples with |d'| above this fraction of its maximum define the post-yield region.
    """
    d, v, y = (np.asarray(a, dtype=float).reshape(-1) for a in (d, d_dot, y))
    if not (d.size == v.size == y.size):
        raise DataError(f"loop_metrics: d, d_dot and y must have the same length; got {d.size}, {v.size}, {y.size}")
    if d.size < 8:
        raise DataError(f"loop_metrics needs at least 8 samples of one cycle; got {d.size}")
    if not (np.all(np.isfinite(d)) and np.all(np.isfinite(v)) and np.all(np.isfinite(y))):
        raise DataError("loop_metrics: the cycle has non-finite samples (a failed simulation?); measure a finite cycle")
    peak = float(np.max(np.abs(y)))
    area_d = cycle_integral(d, y)
    area_v = signed_area(v, y)
    # branches of the d'-y loop: the accelerating branch (d' increasing) and the decelerating one
    accel = np.gradient(v) > 0
    pre = np.abs(y) < pre_fraction * peak
    slopes = [_slope(v[pre & mask], y[pre & mask]) for mask in (accel, ~accel)]
    pre_slope = float(np.nanmean(slopes)) if np.any(np.isfinite(slopes)) else float("nan")
    post = np.abs(v) > post_fraction * np.max(np.abs(v))
    post_slope = _slope(v[post], y[post])
    fit = np.polyfit(v, y, 1)
    resid = y - np.polyval(fit, v)
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    linearity = 1.0 - float(np.sum(resid**2)) / ss_tot if ss_tot > 0 else float("nan")
    return LoopMetrics(
        peak=peak,
        area_d=area_d,
        area_v=area_v,
        orientation="counter-clockwise" if area_v > 0 else "clockwise",
        width_v=_gap(y, v),
        width_d=_gap(y, d),
        height_v=_gap(v, y),
        pre_yield_slope=pre_slope,
        post_yield_slope=post_slope,
        sharpness=pre_slope / post_slope if post_slope else float("nan"),
        linearity=linearity,
    )


def trajectory_loop_metrics(traj, period: float, **kwargs) -> LoopMetrics:
    """:func:`loop_metrics` of the last full period of a simulated :class:`~duffsym.simulate.Trajectory`.

    The trajectory must have input channels ``d`` and ``d_dot``.
    """
    names = list(traj.input_names)
    if "d" not in names or "d_dot" not in names:
        raise DataError(f"trajectory of {traj.model} has inputs {names}; loop metrics need d and d_dot")
    sl = steady_cycle(traj, period)
    # steady_cycle includes both ends of the period; drop the repeated end point of the closed cycle
    idx = np.arange(traj.t.size)[sl][:-1]
    return loop_metrics(traj.u[idx, names.index("d")], traj.u[idx, names.index("d_dot")], traj.y[idx], **kwargs)
