"""Study s01 — the paper's Fig. 3: Duffing-like model (Eq. 3, 5), benchmark and one-at-a-time changes.

The benchmark is ``duffing_like(3)`` with ``FIG3_BASE`` (k1 = c1 = gamma = alpha = 10,
beta = delta = 200, A_f = 2). Each of ``FIG3_CHANGES`` (k1, c1 -> 25; gamma, alpha -> 50;
beta, delta -> 400; n -> 5 via ``duffing_like(5)``; A_f -> 4) is applied alone and overlaid on the
benchmark, in the paper's 3x3 layout: first column the stiffness-related k1, alpha, beta; second
n, benchmark, A_f; third the damping-related c1, gamma, delta. Fig. 3a shows d'–y, Fig. 3b d–y.

Excitation. The paper does not state Fig. 3's excitation. We simulate the benchmark under a
unit-amplitude sine d(t) = sin(2 pi f t) at f = 0.25, 0.5, 1 and 2 Hz (``Config.frequencies``)
and pick the frequency whose steady d'–y loop is most open, measured by the normalised loop
opening |∮ y dd'| / (range(d') * range(y)) (0 for a line, as for a pure damper; pi/4 for an
ellipse, as for a pure spring). All four frequencies give closed, clearly hysteretic loops; the
d'–y opening is largest at 0.5 Hz (about 0.26 against 0.17–0.23 at the others), which is the
frequency used. The scan is written to ``data/derived/s01_fig3_duffing_like.json`` and drawn in
``paper/figures/s01_fig3_duffing_like_excitation.png``.

Each run starts from rest and lasts ``Config.periods`` periods; the last full period is drawn.
The remaining change from the last-but-one period (periodicity residual) is recorded. The mean
offset of x decays slowly (about a factor 15 per 4 periods at 0.5 Hz, also with the Radau
reference), hence 16 periods: the residual of the drawn cycles is then about 1e-4 or less.

Outputs: ``data/derived/s01_fig3_duffing_like.{npz,json}``, figures ``..._fig3a.png``,
``..._fig3b.png``, ``..._excitation.png``, numbers ``paper/output/s01_*.tex``
(``s01_frequency``, ``s01_peak_benchmark``, ``s01_area_benchmark``, ``s01_peak_ratio_Af``, ``s01_scan``,
``s01_table``).
"""
from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np

import _common as C

STUDY = "s01_fig3_duffing_like"
TAG = "s01"  # prefix of the quoted numbers, paper/output/s01_<name>.tex
#: panel layout of the paper: rows x columns, entries are FIG3_CHANGES keys ("benchmark" in the centre)
LAYOUT = (("k1", "n", "c1"), ("alpha", "benchmark", "gamma"), ("beta", "A_f", "delta"))
LATEX = dict(k1=r"k_1", c1=r"c_1", gamma=r"\gamma", alpha=r"\alpha", beta=r"\beta", delta=r"\delta", n="n",
             A_f=r"A_f")


@dataclass(frozen=True)
class Config:
    """Settings of study s01.

    frequencies : candidate excitation frequencies, Hz (the one with the most open d'–y loop is used).
    amplitude : displacement amplitude of the sine (1, as in Fig. 6).
    periods : periods simulated from rest (the last is drawn).
    samples_per_period : output samples per period.
    """

    frequencies: tuple[float, ...] = (0.25, 0.5, 1.0, 2.0)
    amplitude: float = 1.0
    periods: int = 16
    samples_per_period: int = 400

    @classmethod
    def smoke(cls) -> "Config":
        """A few-second variant for CI: two candidate frequencies, fewer periods and samples."""
        return cls(frequencies=(0.5, 2.0), periods=4, samples_per_period=200)

    def summary(self) -> str:
        return (f"s01 config: f in {self.frequencies} Hz, amplitude {self.amplitude:g}, {self.periods} periods "
                f"x {self.samples_per_period} samples")


def _cases():
    """(key, model, params) for the benchmark and each one-at-a-time change."""
    from duffsym.model import duffing_like
    from duffsym.model.presets import FIG3_BASE, FIG3_CHANGES, FIG3_N

    base_model = duffing_like(FIG3_N)
    out = [("benchmark", base_model, dict(FIG3_BASE))]
    for name, value in FIG3_CHANGES.items():
        if name == "n":
            out.append((name, duffing_like(int(value)), dict(FIG3_BASE)))
        else:
            out.append((name, base_model, {**FIG3_BASE, name: float(value)}))
    return out


def _run(model, params, cfg: Config, f: float):
    from duffsym.excitation import Sine
    from duffsym.simulate import simulate, steady_cycle

    T = 1.0 / f
    t = np.linspace(0.0, cfg.periods * T, cfg.periods * cfg.samples_per_period + 1)
    tr = simulate(model, params, t, Sine(cfg.amplitude, f), on_failure="return")
    sl = steady_cycle(tr, T)
    # periodicity residual: last period against the one before (same phase samples)
    k = cfg.samples_per_period
    y = tr.y
    resid = float(np.max(np.abs(y[-k - 1:] - y[-2 * k - 1:-k])) / max(np.max(np.abs(y[-k - 1:])), 1e-300))
    return tr, sl, resid


def _opening(x, y) -> float:
    """|∮ y dx| / (range(x) range(y)) over one closed cycle."""
    from duffsym.derive import loop_area

    t = np.arange(x.size, dtype=float)
    return abs(loop_area(t, x, y)) / (np.ptp(x) * np.ptp(y))


def compute(cfg: Config) -> dict:
    """Simulate the frequency scan and the Fig. 3 cases; write the derived files; return the results."""
    from duffsym.derive import loop_area

    cases = _cases()
    base_key, base_model, base_params = cases[0]
    scan = []
    arrays: dict[str, np.ndarray] = {}
    for f in cfg.frequencies:
        tr, sl, resid = _run(base_model, base_params, cfg, f)
        if not tr.success:
            raise RuntimeError(f"s01: the benchmark failed at {f} Hz: {tr.message}")
        d, v, y = tr.u[sl, 0], tr.u[sl, 1], tr.y[sl]
        scan.append(dict(frequency=f, opening_dy=_opening(d, y), opening_vy=_opening(v, y),
                         peak=float(np.max(np.abs(y))), periodicity_residual=resid))
        arrays[f"scan_{f:g}_d"], arrays[f"scan_{f:g}_v"], arrays[f"scan_{f:g}_y"] = d, v, y
    chosen = max(scan, key=lambda s: s["opening_vy"])["frequency"]

    curves = {}
    for key, model, params in cases:
        tr, sl, resid = _run(model, params, cfg, chosen)
        if not tr.success:
            raise RuntimeError(f"s01: case {key} failed at {chosen} Hz: {tr.message}")
        t, d, v, y = tr.t[sl], tr.u[sl, 0], tr.u[sl, 1], tr.y[sl]
        for name, a in (("t", t), ("d", d), ("v", v), ("y", y)):
            arrays[f"{key}_{name}"] = a
        n = dict(model.structural)["n_x"]
        value = n if key == "n" else params.get(key)
        curves[key] = dict(param=key, value=value, n=int(n), peak=float(np.max(np.abs(y))),
                           loop_area=loop_area(t[:-1], d[:-1], y[:-1]),
                           loop_area_vy=abs(loop_area(t[:-1], v[:-1], y[:-1])), opening_vy=_opening(v, y),
                           periodicity_residual=resid, substeps_max=int(tr.substeps.max()))
    bench = curves["benchmark"]
    for c in curves.values():
        c["peak_ratio"] = c["peak"] / bench["peak"]
        c["area_ratio"] = c["loop_area"] / bench["loop_area"]
        c["area_vy_ratio"] = c["loop_area_vy"] / bench["loop_area_vy"]
    from duffsym.model.presets import FIG3_BASE, FIG3_N

    meta = dict(study=STUDY, **C.provenance(cfg), frequency=chosen, scan=scan, curves=curves,
                base={**FIG3_BASE, "n": FIG3_N},
                selection=("frequency with the largest normalised d'-y loop opening "
                           "|oint y dd'| / (range(d') range(y)) of the benchmark"))
    files = C.write_derived(STUDY, arrays, meta)
    return dict(meta=meta, files=files)


def plot(results: dict | None = None) -> list:
    """Draw Fig. 3a (d'–y), Fig. 3b (d–y) and the excitation scan from the derived files only."""
    arrays, meta = C.read_derived(STUDY)
    curves, f = meta["curves"], meta["frequency"]
    files = []
    with C.style() as plt:
        for panel, xkey, xlabel, which in (("fig3a", "v", r"$\dot d$ (1)", "a"), ("fig3b", "d", r"$d$ (1)", "b")):
            fig, axs = plt.subplots(3, 3, figsize=(7.2, 6.4), sharex=True, sharey=True)
            for r, row in enumerate(LAYOUT):
                for c, key in enumerate(row):
                    ax = axs[r, c]
                    ax.axhline(0, color="0.85", lw=0.5, zorder=0)
                    ax.axvline(0, color="0.85", lw=0.5, zorder=0)
                    bx, by = arrays[f"benchmark_{xkey}"], arrays["benchmark_y"]
                    if key == "benchmark":
                        ax.plot(bx, by, color="k", lw=1.4, label="benchmark")
                        ax.set_title("benchmark", fontweight="bold")
                    else:
                        ax.plot(bx, by, color="0.55", lw=1.0, ls="--", label="benchmark")
                        cv = curves[key]
                        val = f"{cv['value']:g}"
                        ax.plot(arrays[f"{key}_{xkey}"], arrays[f"{key}_y"], color="C1" if c == 0 else
                                ("C0" if c == 2 else "C2"), lw=1.4, label=f"${LATEX[key]} = {val}$")
                        old = f"{meta['base'][key]:g}"
                        ax.set_title(f"${LATEX[key]}$: {old} $\\to$ {val}")
                    if r == 2:
                        ax.set_xlabel(xlabel)
                    if c == 0:
                        ax.set_ylabel(r"$y$ (1)")
            plane = r"$\dot d$–$y$" if which == "a" else r"$d$–$y$"
            fig.suptitle(f"Fig. 3{which} (reproduced): Duffing-like model, {plane} loops, "
                         r"$d = \sin(2\pi f t)$, " f"$f$ = {f:g} Hz, last of {meta['config']['periods']} periods\n"
                         "columns: stiffness-related | $n$, benchmark, $A_f$ | damping-related; "
                         "grey dashed: benchmark", fontsize=9)
            files.append(C.save(fig, STUDY, panel))
        # excitation scan
        scan = meta["scan"]
        fig, axs = plt.subplots(2, len(scan), figsize=(2.1 * len(scan) + 0.6, 4.2), squeeze=False)
        for j, s in enumerate(scan):
            fk = f"{s['frequency']:g}"
            lw = 1.6 if s["frequency"] == f else 1.0
            col = "C1" if s["frequency"] == f else "k"
            axs[0, j].plot(arrays[f"scan_{fk}_v"], arrays[f"scan_{fk}_y"], color=col, lw=lw)
            axs[1, j].plot(arrays[f"scan_{fk}_d"], arrays[f"scan_{fk}_y"], color=col, lw=lw)
            axs[0, j].set_title(f"{fk} Hz" + (" (used)" if s["frequency"] == f else "") +
                                f"\nopening $\\dot d$–$y$ {s['opening_vy']:.2f}")
            axs[0, j].set_xlabel(r"$\dot d$ (1)")
            axs[1, j].set_xlabel(r"$d$ (1)")
        axs[0, 0].set_ylabel(r"$y$ (1)")
        axs[1, 0].set_ylabel(r"$y$ (1)")
        fig.suptitle("Fig. 3 excitation choice: benchmark under unit sines", fontsize=9)
        files.append(C.save(fig, STUDY, "excitation"))
    return files


def write_numbers(meta: dict) -> list:
    """Numbers quoted in ``paper/ms.tex``: frequency, peaks and loop-area ratios, a small table."""
    cv = meta["curves"]
    out = [C.write_number(TAG, "frequency", f"{meta['frequency']:g}"),
           C.write_number(TAG, "peak_benchmark", f"{cv['benchmark']['peak']:.3f}"),
           C.write_number(TAG, "area_benchmark", f"{cv['benchmark']['loop_area']:.3f}"),
           C.write_number(TAG, "peak_ratio_Af", f"{cv['A_f']['peak_ratio']:.6g}")]
    rows = []
    for key in ("k1", "alpha", "beta", "n", "A_f", "c1", "gamma", "delta"):
        c = cv[key]
        rows.append(f"${LATEX[key]} = {c['value']:g}$ & {c['peak']:.3f} & {c['peak_ratio']:.2f} & "
                    f"{c['loop_area_vy']:.3f} & {c['area_vy_ratio']:.2f} & "
                    f"{c['loop_area']:.3f} & {c['area_ratio']:.2f} \\\\")
    b = cv["benchmark"]
    table = ("\\begin{tabular}{lrrrrrr}\n\\hline\n"
             "case & peak $|y|$ & ratio & $|\\oint y\\,\\mathrm{d}\\dot d|$ & ratio & "
             "$\\oint y\\,\\mathrm{d}d$ & ratio \\\\\n\\hline\n"
             f"benchmark & {b['peak']:.3f} & 1 & {b['loop_area_vy']:.3f} & 1 & {b['loop_area']:.3f} & 1 \\\\\n"
             + "\n".join(rows) +
             "\n\\hline\n\\end{tabular}\n")
    out.append(C.write_number(TAG, "table", table))
    scan = ", ".join(f"{s['opening_vy']:.2f} at {s['frequency']:g}\\,Hz" for s in meta["scan"])
    out.append(C.write_number(TAG, "scan", scan))
    return out


def summarize(meta: dict) -> str:
    cv = meta["curves"]
    scan = ", ".join(f"{s['frequency']:g} Hz: {s['opening_vy']:.3f}" for s in meta["scan"])
    parts = [f"{k} peak x{cv[k]['peak_ratio']:.2f}, d'-y area x{cv[k]['area_vy_ratio']:.2f}, "
             f"d-y area x{cv[k]['area_ratio']:.2f}"
             for k in ("k1", "alpha", "beta", "n", "A_f", "c1", "gamma", "delta")]
    worst = max(c["periodicity_residual"] for c in cv.values())
    return (f"s01 (Fig. 3): benchmark d'-y loop opening by frequency ({scan}); used {meta['frequency']:g} Hz. "
            f"Benchmark peak |y| = {cv['benchmark']['peak']:.3f}, loop area {cv['benchmark']['loop_area']:.3f}. "
            f"Relative to the benchmark: " + "; ".join(parts) +
            f". Largest periodicity residual of the drawn cycles {worst:.1e}.")


def main(argv=None) -> int:
    return C.run_study(argv, doc=__doc__, label="s01", config=Config, compute=compute, plot=plot,
                       write_numbers=write_numbers, summarize=summarize, read=lambda: C.read_derived(STUDY))


if __name__ == "__main__":
    sys.exit(main())
