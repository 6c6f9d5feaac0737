"""Figures of a diagnosis and of a ladder (matplotlib; Agg-safe, nothing shown)."""

from __future__ import annotations

import numpy as np

from duffsym.data.record import Record
from duffsym.diagnose.verdict import PLAY_EFFECTS, play_half_width


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def _u(record: Record, key: str) -> str:
    """`` [unit]`` of a record signal for an axis label, or nothing when unknown or dimensionless."""
    unit = dict(record.units).get(key, "")
    if key == "d_dot" and not unit and dict(record.units).get("d", "1") != "1":
        unit = f"{record.units['d']}/s"
    return f" [{unit}]" if unit and unit != "1" else ""


def _steady(record: Record) -> slice:
    """One steady full-stroke cycle of the record (the start-up transient left out), else all of it."""
    from duffsym.plot.loops import steady_window

    return steady_window(record.d) or slice(0, record.n_times)


def _steady_label(record: Record, sl: slice) -> str:
    """What the loop panels show: the whole record, one steady cycle of a repeating input, or a window of one
    that does not repeat (a random or swept record has no steady cycle; :func:`duffsym.plot.windows.loop_windows`)."""
    from duffsym.plot.windows import loop_windows

    t = np.asarray(record.t)[sl]
    if t.size == record.n_times:
        return "whole record"
    if not loop_windows(record.d).whole_cycles:
        return f"a window ({t[0]:.3g}-{t[-1]:.3g} s)"
    return f"one steady cycle ({t[0]:.3g}-{t[-1]:.3g} s)"


def plot_where(diag, record: Record, *, title: str | None = None):
    """Where the model fails: time series with residual, d–y and d'–y loops, the residual map over
    the (d, d') plane, residual RMS per region, and the residual autocorrelation."""
    plt = _plt()
    res = diag.residuals
    t = np.asarray(record.t)
    y = np.asarray(record.y)
    yh = diag.y_base
    r = y - yh
    d = np.asarray(record.d)
    v = np.asarray(record.velocity())
    k = diag.split["n_fit"]  # a Diagnosis (its Split reads like a dict) or one rebuilt from its JSON (s07)
    fig = plt.figure(figsize=(12, 7.5), layout="constrained")
    gs = fig.add_gridspec(3, 3)
    ax = fig.add_subplot(gs[0, :2])
    ax.plot(t, y, color="0.6", lw=0.8, label="measured")
    ax.plot(t, yh, color="k", lw=0.8, label=f"model, free run (NRMSE {diag.nrmse:.3g})")
    ax.axvline(t[k], color="tab:blue", ls=":", lw=1)
    ax.text(t[k], ax.get_ylim()[1], " held out ->", color="tab:blue", va="top", fontsize="small")
    ax.set_ylabel(f"output y{_u(record, 'y')}")
    ax.legend(loc="lower left", fontsize="small", ncols=2)
    ax = fig.add_subplot(gs[1, :2], sharex=fig.axes[0])
    ax.plot(t, r, color="tab:red", lw=0.6)
    ax.axhspan(-2 * res.noise, 2 * res.noise, color="0.85", label="±2σ noise")
    ax.axvline(t[k], color="tab:blue", ls=":", lw=1)
    ax.set_xlabel("time, s")
    ax.set_ylabel(f"residual y − ŷ{_u(record, 'y')}")
    ax.legend(loc="upper left", fontsize="small")
    sl = _steady(record)
    for row, (xs, lab, key) in enumerate(((d, "d", "d"), (v, "d'", "d_dot"))):
        ax = fig.add_subplot(gs[row, 2])
        ax.plot(xs[sl], y[sl], ".", color="0.6", ms=1.5)
        ax.plot(xs[sl], yh[sl], color="k", lw=0.6)
        ax.set_xlabel(lab + _u(record, key))
        ax.set_ylabel("y" + _u(record, "y"))
        ax.set_title(f"{lab}–y loop, {_steady_label(record, sl)}", fontsize="medium")
    ax = fig.add_subplot(gs[2, 0])
    lim = np.nanmax(np.abs(res.map_mean)) or 1.0
    mesh = ax.pcolormesh(res.map_d, res.map_v, res.map_mean.T, cmap="RdBu_r", vmin=-lim, vmax=lim, shading="nearest")
    fig.colorbar(mesh, ax=ax, label="mean residual")
    ax.set_xlabel("d")
    ax.set_ylabel("d'")
    ax.set_title("residual over the (d, d') plane", fontsize="medium")
    ax = fig.add_subplot(gs[2, 1])
    bins = [b for b in res.bins if b.n > 0]
    labels = [b.region.split(" (")[0] for b in bins]
    ratios = [b.rms_ratio for b in bins]
    colors = ["tab:red" if q > 1.5 else "0.6" for q in ratios]
    ax.barh(range(len(bins)), ratios, color=colors)
    ax.axvline(1.0, color="k", lw=0.8)
    ax.set_yticks(range(len(bins)), labels, fontsize="x-small")
    ax.invert_yaxis()
    ax.set_xlabel("residual RMS / overall RMS")
    ax.set_title("where the error is", fontsize="medium")
    ax = fig.add_subplot(gs[2, 2])
    lags = np.arange(res.acf.size)
    ax.vlines(lags[1:], 0, res.acf[1:], color="k", lw=1)
    ax.axhspan(-res.acf_bound, res.acf_bound, color="0.85", label="95 % bound, white noise")
    ax.set_xlabel("lag, samples")
    ax.set_ylabel("autocorrelation")
    ax.set_title(f"whiteness ({100 * res.acf_outside:.0f} % of lags outside)", fontsize="medium")
    ax.legend(fontsize="x-small", loc="upper right")
    fig.suptitle(
        title
        or f"where {diag.model}{' + ' + ' + '.join(diag.effects) if diag.effects else ''} fails "
        f"(residual RMS {res.excess:.1f}x noise)",
        fontsize="large",
    )
    return fig


#: a candidate whose held-out NRMSE is above this multiple of the base model's counts as diverged:
#: drawn to the edge of the axis and marked, so it does not squeeze the meaningful range
DIVERGED = 3.0


def _candidate_colour(c, chosen) -> str:
    if c.effect in chosen:
        return "tab:green"
    if c.needed:
        return "yellowgreen"
    return "tab:olive" if c.supported else "0.65"


def _candidate_note(c) -> str:
    text = (c.message or "not fitted").split(":")[0]
    return text if text.startswith("screened out") else f"not fitted: {text[:60]}"


def plot_candidates(diag, record: Record | None = None, *, title: str | None = None):
    """Held-out NRMSE with each candidate effect added, against the base model and the noise floor.

    Every candidate tried is listed: fitted ones as bars; screened-out or failed ones as rows
    without a bar that say why. A candidate far worse than the base model (``DIVERGED`` times its
    error) is drawn to the edge of the axis, marked with its value, and kept off the scale.
    Colours: green, the effect the diagnosis calls missing; light green, another that explains the
    error as well (an alternative); olive, supported but explaining less; grey, no gain.
    """
    from matplotlib.patches import Patch

    plt = _plt()
    cands = list(diag.candidates)
    chosen = set(diag.needed)
    base = diag.nrmse_heldout
    fitted = [c for c in cands if c.success and np.isfinite(c.nrmse_after)]
    shown = [c.nrmse_after for c in fitted if c.nrmse_after <= DIVERGED * base]
    xmax = 1.12 * max([base, *shown])
    fig, ax = plt.subplots(figsize=(7.5, 0.42 * max(len(cands), 3) + 1.6), layout="constrained")
    for i, c in enumerate(cands):
        if c not in fitted:
            ax.text(
                0.01 * xmax,
                i,
                _candidate_note(c),
                va="center",
                fontsize="x-small",
                color="0.35",
                style="italic",
                bbox=dict(facecolor="white", edgecolor="none", pad=1.0),
                zorder=3,
            )
            continue
        value = min(c.nrmse_after, xmax)
        diverged = c.nrmse_after > xmax
        ax.barh(
            i,
            value,
            color=_candidate_colour(c, chosen),
            hatch="//" if diverged else None,
            edgecolor="0.3" if diverged else None,
        )
        if diverged:
            ax.text(
                0.98 * xmax,
                i,
                f"diverged: {c.nrmse_after:.3g} (off the scale)",
                ha="right",
                va="center",
                fontsize="x-small",
                color="k",
            )
    ax.set_xlim(0, xmax)
    ax.axvline(base, color="k", lw=1)
    handles = [plt.Line2D([], [], color="k", lw=1, label=f"base model ({base:.3g})")]
    if record is not None:
        held = np.asarray(record.y)[diag.split["n_fit"] :]
        floor = diag.noise / np.std(held)
        if floor < xmax:
            ax.axvline(floor, color="tab:blue", ls=":")
            handles.append(plt.Line2D([], [], color="tab:blue", ls=":", label=f"noise floor ({floor:.2g})"))
    used = {_candidate_colour(c, chosen) for c in fitted}
    handles += [
        Patch(color=col, label=text)
        for col, text in (
            ("tab:green", "called missing"),
            ("yellowgreen", "explains it as well"),
            ("tab:olive", "supported, helps partly"),
            ("0.65", "no real gain"),
        )
        if col in used
    ]
    labels = [f"+ {c.effect}" + (f"\n(ΔBIC {c.delta_bic:.0f})" if c in fitted else "") for c in cands]
    ax.set_yticks(range(len(cands)), labels, fontsize="small")
    ax.set_ylim(len(cands) - 0.5, -0.5)
    ax.set_xlabel("held-out free-run NRMSE with the effect added (lower is better)")
    ax.legend(handles=handles, fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    n_other = len(cands) - len(fitted)
    counted = f"{len(cands)} candidates tried, {len(fitted)} fitted" + (
        f", {n_other} not (listed, no bar)" if n_other else ""
    )
    ax.set_title(f"{title}\n{counted}" if title else f"which effect is missing: {counted}", fontsize="medium")
    return fig


def ladder_outcome(lad) -> str:
    """The ladder's result in words, from its numbers: what was added and how the held-out error moved."""
    steps = lad.steps
    if not getattr(lad, "complete", True) or getattr(lad, "final_fit", True) is None:  # stopped, or still running
        where = (
            "running"
            if lad.final_fit is None
            else ("stopped by the time budget" if "time budget" in lad.stopped else "stopped")
        )
        return f"{where} after {len(steps)} step(s): held-out NRMSE " + " -> ".join(
            f"{s.nrmse_heldout:.3g}" for s in steps
        )
    if len(steps) == 1:
        return f"nothing added: no effect is supported (held-out NRMSE {steps[0].nrmse_heldout:.3g})"
    a, b = steps[0].nrmse_heldout, steps[-1].nrmse_heldout
    verb = "falls" if b < a else "does not fall"
    added = ", ".join(_step_name(s, steps[0]).lstrip("+ ") for s in steps[1:])
    return f"added {added}: held-out NRMSE {verb}, {' -> '.join(f'{s.nrmse_heldout:.3g}' for s in steps)}"


def _on(step, first) -> str:
    """`` on <element>`` when the ladder step's element replaced the first step's, else ""."""
    model = getattr(step, "model", "")
    return f" on {model}" if model and model != getattr(first, "model", model) else ""


def _step_name(step, first) -> str:
    """``+ effect`` for a ladder step, with its element when the step replaced the first step's."""
    return f"+ {step.effects[-1]}{_on(step, first)}"


def plot_ladder(lad, record: Record, *, title: str | None = None):
    """The error at each step of the ladder, and the d–y / d'–y loops of the base and the last model.

    Titles state the outcome (:func:`ladder_outcome`): what was added and whether the held-out
    error fell, or that nothing was added."""
    plt = _plt()
    steps = lad.steps
    names = ["base"] + [_step_name(s, steps[0]) for s in steps[1:]]
    fig = plt.figure(figsize=(12, 4.2), layout="constrained")
    gs = fig.add_gridspec(1, 3)
    ax = fig.add_subplot(gs[0, 0])
    x = np.arange(len(steps))
    ax.plot(x, [s.nrmse_fit for s in steps], "o-", color="0.5", label="fitting part")
    ax.plot(x, [s.nrmse_heldout for s in steps], "s-", color="k", label="held out")
    floor = steps[-1].diagnosis.noise / max(float(np.std(record.y)), 1e-300)
    lowest = min(min(s.nrmse_fit for s in steps), min(s.nrmse_heldout for s in steps))
    if floor >= lowest / 10:
        ax.axhline(floor, color="tab:blue", ls=":", label="noise level")
    else:  # e.g. pre-smoothed measurements: the noise floor would squash the scale
        ax.plot([], [], " ", label=f"noise level {floor:.1e} (off the scale)")
    ax.set_yscale("log")
    ax.set_xticks(x, names, rotation=20, ha="right", fontsize="small")
    ax.set_ylabel("free-run NRMSE")
    if len(steps) == 1:
        ax.set_title("nothing added: base model only", fontsize="medium")
    else:
        a, b = steps[0].nrmse_heldout, steps[-1].nrmse_heldout
        ax.set_title(f"held-out error {'falls' if b < a else 'does not fall'} ({a:.3g} -> {b:.3g})", fontsize="medium")
    ax.legend(fontsize="small")
    sl = _steady(record)
    d = np.asarray(record.d)[sl]
    v = np.asarray(record.velocity())[sl]
    y = np.asarray(record.y)[sl]
    for j, (xs, lab, key) in enumerate(((d, "d", "d"), (v, "d'", "d_dot"))):
        ax = fig.add_subplot(gs[0, 1 + j])
        ax.plot(xs, y, ".", color="0.7", ms=1.5, label="measured")
        ax.plot(xs, steps[0].diagnosis.y_base[sl], color="tab:red", lw=0.7, label=f"base (NRMSE {steps[0].nrmse:.3g})")
        if len(steps) > 1:
            ax.plot(
                xs,
                steps[-1].diagnosis.y_base[sl],
                color="k",
                lw=0.7,
                label=f"+ {' + '.join(steps[-1].effects)}{_on(steps[-1], steps[0])} ({steps[-1].nrmse:.3g})",
            )
        ax.set_xlabel(lab + _u(record, key))
        ax.set_ylabel("y" + _u(record, "y"))
        ax.set_title(f"{lab}–y loop, {_steady_label(record, sl)}", fontsize="medium")
        if j == 0:
            ax.legend(fontsize="x-small", loc="center")
    fig.suptitle(title or ladder_outcome(lad), fontsize="large")
    return fig


def _gap_start(travel, y_fit, top: float) -> float:
    """Where the fitted model's force enters the low-force band (``|y| < 0.2 max|y|``, as
    :func:`duffsym.effects.inputs.plateau_half_width` measures it) after the reversal: the gap of a contact gap
    lies inside the branch, not at the reversal."""
    inside = np.flatnonzero(np.abs(np.asarray(y_fit)) < 0.2 * top)
    return float(travel[inside[0]]) if inside.size else 0.0


def plot_play(diag, record: Record, *, effect: str | None = None, title: str | None = None):
    """The play candidate against the plateaus: the d–y loop over one steady cycle and the force after one
    reversal against the actuator travel from it, measured, base model and with the fitted play (free runs).
    The flat low-force stretch after the reversal is the gap ``2h`` the actuator crosses; its fitted
    half-width (± standard error) is in the title. ``effect``: one of ``PLAY_EFFECTS`` (default: the one with the
    lower held-out error). None when the candidate has no result."""
    plt = _plt()
    names = PLAY_EFFECTS if effect is None else (effect,)
    done = [c for c in diag.candidates if c.effect in names and c.success and c.effect in diag.y_candidates]
    c = min(done, key=lambda c: c.nrmse_after, default=None)
    if c is None:
        return None
    effect = c.effect
    y, d = np.asarray(record.y), np.asarray(record.d)
    v = np.asarray(record.velocity())
    yp = diag.y_candidates[effect]
    sl = _steady(record)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.4), layout="constrained")
    ax = axes[0]
    ax.plot(d[sl], y[sl], "o", color="0.55", ms=3, label="measured")
    ax.plot(d[sl], diag.y_base[sl], color="tab:red", lw=0.8, label=f"base model (held-out {diag.nrmse_heldout:.3g})")
    ax.plot(d[sl], yp[sl], color="k", lw=0.8, label=f"+ {effect} (held-out {c.nrmse_after:.3g})")
    ax.set_xlabel("d" + _u(record, "d"))
    ax.set_ylabel("y" + _u(record, "y"))
    ax.set_title(f"d–y loop, {_steady_label(record, sl)}", fontsize="medium")
    ax.legend(fontsize="x-small")
    ax = axes[1]
    idx = np.arange(record.n_times)[sl]
    s = np.sign(v[idx])
    flips = idx[1:][(s[1:] != s[:-1]) & (s[1:] != 0)]
    r = int(flips[0]) if flips.size else int(idx[0])
    stop = int(flips[1]) if flips.size > 1 else int(idx[-1])
    travel = np.abs(d[r:stop] - d[r])
    ax.plot(travel, y[r:stop], "o", color="0.55", ms=3, label="measured")
    ax.plot(travel, diag.y_base[r:stop], color="tab:red", lw=0.9, label="base model")
    ax.plot(travel, yp[r:stop], color="k", lw=0.9, label=f"+ {effect}")
    h, se = play_half_width(c, record, yp)
    if h is not None:
        lo = _gap_start(travel, yp[r:stop], float(np.max(np.abs(y)))) if effect == "contact-gap" else 0.0
        ax.axvspan(lo, lo + 2 * h, color="tab:blue", alpha=0.12, label=f"gap 2h = {2 * h:.3g}")
    ax.set_xlabel("actuator travel since the reversal |d - d(reversal)|" + _u(record, "d"))
    ax.set_ylabel("y" + _u(record, "y"))
    ax.set_title(f"after the reversal at t = {float(record.t[r]):.3g} s: the plateau", fontsize="medium")
    ax.legend(fontsize="x-small")
    fig.suptitle(
        title or (f"play fitted ({effect}): half-width h = {h:.4g} ± {se:.2g}" if h is not None else effect),
        fontsize="large",
    )
    return fig
