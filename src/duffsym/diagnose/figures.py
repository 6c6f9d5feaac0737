"""Figures of a diagnosis and of a ladder (matplotlib; Agg-safe, nothing shown)."""
from __future__ import annotations

import numpy as np

from duffsym.data.record import Record


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


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
    k = diag.split["n_fit"]
    fig = plt.figure(figsize=(12, 7.5), layout="constrained")
    gs = fig.add_gridspec(3, 3)
    ax = fig.add_subplot(gs[0, :2])
    ax.plot(t, y, color="0.6", lw=0.8, label="measured")
    ax.plot(t, yh, color="k", lw=0.8, label=f"model, free run (NRMSE {diag.nrmse:.3g})")
    ax.axvline(t[k], color="tab:blue", ls=":", lw=1)
    ax.text(t[k], ax.get_ylim()[1], " held out ->", color="tab:blue", va="top", fontsize="small")
    ax.set_ylabel("output y")
    ax.legend(loc="lower left", fontsize="small", ncols=2)
    ax = fig.add_subplot(gs[1, :2], sharex=fig.axes[0])
    ax.plot(t, r, color="tab:red", lw=0.6)
    ax.axhspan(-2 * res.noise, 2 * res.noise, color="0.85", label="±2σ noise")
    ax.axvline(t[k], color="tab:blue", ls=":", lw=1)
    ax.set_xlabel("time, s")
    ax.set_ylabel("residual y − ŷ")
    ax.legend(loc="upper left", fontsize="small")
    for row, (xs, lab) in enumerate(((d, "d"), (v, "d'"))):
        ax = fig.add_subplot(gs[row, 2])
        ax.plot(xs, y, ".", color="0.6", ms=1.5)
        ax.plot(xs, yh, color="k", lw=0.6)
        ax.set_xlabel(lab)
        ax.set_ylabel("y")
        ax.set_title(f"{lab}–y loop", fontsize="medium")
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
    fig.suptitle(title or f"where {diag.model}{' + ' + ' + '.join(diag.effects) if diag.effects else ''} fails "
                 f"(residual RMS {res.excess:.1f}x noise)", fontsize="large")
    return fig


def plot_candidates(diag, record: Record | None = None, *, title: str | None = None):
    """Held-out NRMSE with each candidate effect added, against the base model and the noise floor."""
    plt = _plt()
    cands = [c for c in diag.candidates if c.success]
    fig, ax = plt.subplots(figsize=(7, 0.45 * max(len(cands), 3) + 1.4), layout="constrained")
    colors = ["tab:green" if c.needed else ("tab:olive" if c.supported else "0.65") for c in cands]
    ax.barh(range(len(cands)), [c.nrmse_after for c in cands], color=colors)
    ax.axvline(diag.nrmse_heldout, color="k", lw=1, label=f"base model ({diag.nrmse_heldout:.3g})")
    if record is not None:
        held = np.asarray(record.y)[diag.split["n_fit"]:]
        ax.axvline(diag.noise / np.std(held), color="tab:blue", ls=":", label="noise floor")
    ax.set_yticks(range(len(cands)), [f"+ {c.effect}\n(ΔBIC {c.delta_bic:.0f})" for c in cands], fontsize="small")
    ax.invert_yaxis()
    ax.set_xlabel("held-out free-run NRMSE (lower is better)")
    ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_title(title or "which effect is missing: green = needed, olive = helps partly", fontsize="medium")
    return fig


def plot_ladder(lad, record: Record, *, title: str | None = None):
    """The error falling step by step, and the d–y / d'–y loops of the base and the last model."""
    plt = _plt()
    steps = lad.steps
    names = ["base"] + ["+ " + s.effects[-1] for s in steps[1:]]
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
    ax.set_title("the error falls", fontsize="medium")
    ax.legend(fontsize="small")
    d = np.asarray(record.d)
    v = np.asarray(record.velocity())
    y = np.asarray(record.y)
    for j, (xs, lab) in enumerate(((d, "d"), (v, "d'"))):
        ax = fig.add_subplot(gs[0, 1 + j])
        ax.plot(xs, y, ".", color="0.7", ms=1.5, label="measured")
        ax.plot(xs, steps[0].diagnosis.y_base, color="tab:red", lw=0.7, label=f"base ({steps[0].nrmse:.3g})")
        if len(steps) > 1:
            ax.plot(xs, steps[-1].diagnosis.y_base, color="k", lw=0.7,
                    label=f"{' + '.join(steps[-1].effects)} ({steps[-1].nrmse:.3g})")
        ax.set_xlabel(lab)
        ax.set_ylabel("y")
        ax.legend(fontsize="x-small", loc="upper left")
    fig.suptitle(title or "base model -> " + " -> ".join(names[1:] or ["(nothing needed)"]), fontsize="large")
    return fig
