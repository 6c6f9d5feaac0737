"""Figures of the posterior: corner plot and predictive bands on loops and time series."""

from __future__ import annotations

import numpy as np


def plot_corner(chains, *, truths=None, names=None, fig=None):
    """Corner plot (the ``corner`` package) of the posterior, the fit's optimum marked in red and
    ``truths`` (by name) in blue."""
    import corner

    s = chains.get_samples(thin=1)
    labels = list(names or chains.names)
    fig = corner.corner(
        s,
        labels=labels,
        quantiles=(0.05, 0.5, 0.95),
        show_titles=True,
        title_fmt=".3g",
        title_kwargs={"fontsize": 8},
        label_kwargs={"fontsize": 9},
        fig=fig,
        plot_datapoints=False,
        fill_contours=True,
        levels=(0.68, 0.95),
        color="tab:blue",
    )
    ndim = s.shape[1]
    axes = np.array(fig.axes).reshape(ndim, ndim)
    opt = chains.optimum
    for i in range(ndim):
        axes[i, i].axvline(opt[i], color="tab:red", lw=1)
        if truths is not None and chains.names[i] in truths:
            axes[i, i].axvline(truths[chains.names[i]], color="tab:blue", lw=1, ls="--")
        for j in range(i):
            axes[i, j].plot(opt[j], opt[i], "s", color="tab:red", ms=3)
            if truths is not None and chains.names[i] in truths and chains.names[j] in truths:
                axes[i, j].plot(truths[chains.names[j]], truths[chains.names[i]], "o", color="tab:blue", ms=3)
    fig.text(0.98, 0.98, "red: IPOPT optimum" + ("; blue: truth" if truths else ""), ha="right", va="top", fontsize=9)
    return fig


def plot_bands(bands, *, period: float | None = None, title: str = ""):
    """Loops (d-y, d'-y) over the last ``period`` and the time series with the 68/95 % bands of the
    noise-free output (model) and the 95 % predictive band, for one :class:`PredictiveBands`."""
    import matplotlib.pyplot as plt

    b = bands
    n_in = b.u.shape[1]
    fig, axes = plt.subplots(1, n_in + 2, figsize=(3.6 * (n_in + 2), 3.4), constrained_layout=True)
    axes = np.atleast_1d(axes)
    sel = slice(None)
    if period:
        start = np.searchsorted(b.t, b.t[-1] - period)
        sel = slice(int(start), None)
    mb, pb = b.model_bands, b.predictive_bands
    for j in range(n_in):
        ax = axes[j]
        x = b.u[sel, j]
        ax.plot(x, b.y[sel], ".", color="0.6", ms=2.5, label="data")
        ax.plot(x, pb[0][sel], color="tab:orange", lw=0.6, label="95 % predictive")
        ax.plot(x, pb[-1][sel], color="tab:orange", lw=0.6)
        ax.plot(x, mb[2][sel], color="k", lw=0.9, label="posterior median")
        ax.plot(x, mb[0][sel], color="tab:blue", lw=0.6, ls="--", label="95 % model band")
        ax.plot(x, mb[-1][sel], color="tab:blue", lw=0.6, ls="--")
        name = b.input_names[j] if j < len(b.input_names) else f"u{j}"
        ax.set_xlabel({"d": "displacement d", "d_dot": "velocity d'"}.get(name, name))
        ax.set_ylabel("output y")
    axes[0].legend(fontsize="x-small", loc="upper left")
    ax = axes[-2]
    ax.fill_between(b.t, pb[0], pb[-1], color="tab:orange", alpha=0.25, lw=0, label="95 % predictive")
    ax.fill_between(b.t, mb[0], mb[-1], color="tab:blue", alpha=0.45, lw=0, label="95 % model band")
    ax.plot(b.t, b.y, ".", color="0.4", ms=1.5, label="data")
    ax.plot(b.t, mb[2], color="k", lw=0.7, label="median")
    ax.set_xlabel("time, s")
    ax.set_ylabel("output y")
    ax.set_title(f"95 % predictive band holds {b.coverage95:.0%} of the data", fontsize=9)
    ax.legend(fontsize="x-small", loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2)
    ax = axes[-1]  # the bands' half-widths: parameter uncertainty (model) against noise (predictive)
    ax.plot(b.t, 0.5 * (pb[-1] - pb[0]), color="tab:orange", lw=0.8, label="95 % predictive")
    ax.plot(b.t, 0.5 * (mb[-1] - mb[0]), color="tab:blue", lw=0.8, label="95 % model (parameters)")
    ax.set_xlabel("time, s")
    ax.set_ylabel("band half-width")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize="x-small", loc="upper right")
    if title:
        fig.suptitle(title, fontsize=10)
    return fig
