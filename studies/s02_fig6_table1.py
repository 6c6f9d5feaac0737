"""Study s02 — the paper's Fig. 6: MR-damper model (Eq. 12–14) under the Table 1 parameter sweeps.

Base set ``TABLE1_BASE`` (c1 = 20, c2 = 10, c3 = 100, k1 = 3, k2 = 5, k3 = 5, A_f = 2) with
``mr_damper(3)``; each panel (a)–(f) of ``TABLE1_SWEEPS`` changes one parameter over the Table 1
values, panel (g) sweeps n over 1, 3, 5 with ``mr_damper(n)``. The excitation is the paper's
unit-amplitude sine at 0.25 Hz, d(t) = sin(2 pi 0.25 t). Every set is simulated from rest for
``Config.periods`` periods (160 s by default: the slowest certified sets, alpha = k1 + k2 = 0 or 2,
need about 30 periods to settle to 1e-5) and the last full period is drawn in the d'–y plane.

Stability. ``duffsym.derive.stability_certificate`` is run on every set. It fails exactly where
gamma = c1 + c2, alpha = k1 + k2 or beta = k3 is negative: c1 = -20 and c2 = -30 (gamma = -10),
k2 = -5 (alpha = -2: a double well, the origin is a saddle) and k3 = -40 and -5 (beta < 0: the
potential is unbounded below). The sets with gamma = 0 (c1 = -10) or alpha = 0 (k1 = -5) are
outside the paper's stated condition ("all positive gamma, delta, alpha and beta") but are still
certified, because delta x'^n and beta x^n alone make V and -dV/dt positive away from the origin.
Uncertified curves are drawn dashed with "(not certified)" in the legend. The sets are simulated
with ``on_failure="return"``: k3 = -40 leaves the bounded region and diverges after some tens of
seconds (the exact time depends on the integrator, so it is not a property of the model alone); its
panel shows the last full period before the failure, dotted, and the legend says so.

Outputs: ``data/derived/s02_fig6_table1.{npz,json}`` (per set: certificate, status, peak |y|,
orientation and area of the d'–y loop, d–y loop area = work done on the damper per cycle, slope at
y = 0, periodicity residual), figure ``paper/figures/s02_fig6_table1_fig6.png``, numbers
``paper/output/s02_*.tex`` (``table``, ``n_uncertified``, ``uncertified``, ``peak_range_k``,
``peak_range_c``, ``clockwise``, ``negative_work``, ``escape``, ``failed``). Orientation is the sign of
∮ y dd' over the loop (net, for a loop that crosses itself).
"""
from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np

import _common as C

STUDY = "s02_fig6_table1"
TAG = "s02"
LATEX = dict(c1="c_1", c2="c_2", c3="c_3", k1="k_1", k2="k_2", k3="k_3", n="n")


@dataclass(frozen=True)
class Config:
    """Settings of study s02.

    frequency : excitation frequency, Hz (0.25, as in the paper).
    amplitude : displacement amplitude (1, "unitary").
    periods : periods simulated from rest; the last complete one is drawn.
    samples_per_period : output samples per period.
    """

    frequency: float = 0.25
    amplitude: float = 1.0
    periods: int = 40
    samples_per_period: int = 400

    @classmethod
    def smoke(cls) -> "Config":
        """A few-second variant for CI (not at steady state for the slow sets).

        200 samples per period, not fewer: at 100 (dt = 0.04 s) the compiled RK4 reports a blow-up
        in the first sample for c3 = 1000, a certified set (a simulator issue, reported).
        """
        return cls(periods=6, samples_per_period=200)

    def summary(self) -> str:
        return (f"s02 config: {self.amplitude:g} sin(2 pi {self.frequency:g} t), {self.periods} periods x "
                f"{self.samples_per_period} samples")


def sets():
    """(panel, param, value, model, params) for every Table 1 set, in the table's order."""
    from duffsym.model import mr_damper
    from duffsym.model.presets import TABLE1_BASE, TABLE1_N, TABLE1_SWEEPS

    models = {}

    def model(n):
        if n not in models:
            models[n] = mr_damper(n)
        return models[n]

    out = []
    for panel, (name, values) in TABLE1_SWEEPS.items():
        for v in values:
            if name == "n":
                out.append((panel, name, v, model(int(v)), dict(TABLE1_BASE)))
            else:
                out.append((panel, name, v, model(TABLE1_N), {**TABLE1_BASE, name: float(v)}))
    return out


def _slope_at_zero(v, y) -> float:
    """Median |dy/dd'| where the closed loop crosses y = 0 (the pre-yield slope of Fig. 6)."""
    slopes = []
    yc, vc = np.append(y, y[0]), np.append(v, v[0])
    for i in np.flatnonzero(np.sign(yc[:-1]) * np.sign(yc[1:]) < 0):
        dv = vc[i + 1] - vc[i]
        if dv != 0:
            slopes.append(abs((yc[i + 1] - yc[i]) / dv))
    return float(np.median(slopes)) if slopes else float("nan")


def compute(cfg: Config) -> dict:
    """Certify and simulate every Table 1 set; write the derived files; return the results."""
    from duffsym.derive import loop_area, stability_certificate
    from duffsym.excitation import Sine
    from duffsym.simulate import simulate

    T = 1.0 / cfg.frequency
    k = cfg.samples_per_period
    t = np.linspace(0.0, cfg.periods * T, cfg.periods * k + 1)
    exc = Sine(cfg.amplitude, cfg.frequency)
    arrays, rows = {}, []
    for i, (panel, name, value, model, params) in enumerate(sets()):
        cert = stability_certificate(model, params)
        tr = simulate(model, params, t, exc, on_failure="return")
        p = dict(params)
        gamma, alpha, beta, delta = p["c1"] + p["c2"], p["k1"] + p["k2"], p["k3"], p["c3"]
        if tr.success:
            last = cfg.periods  # index of the period that ends the record
            escape = None
        else:
            # the last complete period before the failure whose |x| stays within twice that of the
            # first period: the loop just before the escape, not the escape itself
            amp = [np.max(np.abs(tr.x[j * k:(j + 1) * k + 1, 0])) for j in range(tr.failed_at // k)]
            bounded = [j for j, a in enumerate(amp) if a <= 2.0 * amp[0]] if amp else []
            last = (bounded[-1] + 1) if bounded else 0
            escape = float(last * T) if amp else None
        row = dict(index=i, panel=panel, param=name, value=value, n=int(dict(model.structural)["n_x"]),
                   gamma=gamma, alpha=alpha, beta=beta, delta=delta,
                   paper_condition=bool(min(gamma, alpha, beta, delta) > 0),
                   certified=bool(cert.holds), failed_conditions=[c.name for c in cert.conditions if not c.holds],
                   certificate=cert.summary(), status=tr.status, message=tr.message,
                   failed_at_time=float(t[tr.failed_at]) if not tr.success else None,
                   periods_drawn_end=last, escape_time=escape)
        if last >= 1:
            sl = slice((last - 1) * k, last * k + 1)
            tt, d, v, y = t[sl], tr.u[sl, 0], tr.u[sl, 1], tr.y[sl]
            arrays[f"set{i}_t"], arrays[f"set{i}_d"], arrays[f"set{i}_v"], arrays[f"set{i}_y"] = tt, d, v, y
            area_v = loop_area(tt[:-1], v[:-1], y[:-1])
            row.update(drawn_from=float(tt[0]), drawn_to=float(tt[-1]), peak=float(np.max(np.abs(y))),
                       area_vy=area_v, orientation_vy="clockwise" if area_v > 0 else "counterclockwise",
                       area_dy=loop_area(tt[:-1], d[:-1], y[:-1]), slope_at_zero=_slope_at_zero(v[:-1], y[:-1]),
                       x_range=[float(tr.x[sl, 0].min()), float(tr.x[sl, 0].max())])
            if last >= 2:
                prev = tr.y[(last - 2) * k:(last - 1) * k + 1]
                row["periodicity_residual"] = float(np.max(np.abs(y - prev)) / max(np.max(np.abs(y)), 1e-300))
        rows.append(row)
    meta = dict(study=STUDY, **C.provenance(cfg), sets=rows)
    files = C.write_derived(STUDY, arrays, meta)
    return dict(meta=meta, files=files)


def _label(r: dict) -> str:
    s = f"${LATEX[r['param']]} = {r['value']:g}$"
    if not r["certified"]:
        s += " (not certified)"
    if r["status"] != "ok" and r.get("drawn_from") is not None:
        s += (f":\n  diverges after t = {r['escape_time']:.0f} s ({r['status']}\n  at {r['failed_at_time']:.0f} s); "
              f"drawn: {r['drawn_from']:.0f}–{r['drawn_to']:.0f} s")
    elif r["status"] != "ok":
        s += f":\n  {r['status']} at t = {r['failed_at_time']:.2g} s, nothing to draw"
    return s


def plot(results: dict | None = None) -> list:
    """Draw Fig. 6 (panels a–g, d'–y) and a certificate key from the derived files only."""
    arrays, meta = C.read_derived(STUDY)
    rows = meta["sets"]
    cfg = meta["config"]
    with C.style() as plt:
        fig, axs = plt.subplots(2, 4, figsize=(10.0, 7.0))
        axs = axs.ravel()
        panels = list(dict.fromkeys(r["panel"] for r in rows))
        for j, panel in enumerate(panels):
            ax = axs[j]
            ax.axhline(0, color="0.85", lw=0.5, zorder=0)
            ax.axvline(0, color="0.85", lw=0.5, zorder=0)
            prs = [r for r in rows if r["panel"] == panel]
            for c, r in enumerate(prs):
                key = f"set{r['index']}"
                if f"{key}_y" not in arrays:
                    ax.plot([], [], color=f"C{c}", ls=":", label=_label(r))
                    continue
                ls = ":" if r["status"] != "ok" else ("--" if not r["certified"] else "-")
                ax.plot(arrays[f"{key}_v"], arrays[f"{key}_y"], color=f"C{c}", ls=ls, lw=1.3, label=_label(r))
            ax.set_title(f"Fig. 6{panel}: ${LATEX[prs[0]['param']]}$ varied")
            ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2, fontsize=6.5, columnspacing=1.0)
            ax.set_xlabel(r"$\dot d$ (1)")
            if j % 4 == 0:
                ax.set_ylabel(r"$y = F_{\mathrm{mr}}$ (1)")
        key = axs[len(panels)]
        key.axis("off")
        lines = ["Lyapunov certificate per set", "(duffsym.derive.stability_certificate)", ""]
        for r in rows:
            mark = "certified" if r["certified"] else "NOT certified"
            lines.append(f"({r['panel']}) {r['param']} = {r['value']:g}: {mark}")
        key.text(0.0, 1.0, "\n".join(l for l in lines if "NOT" in l or not l.startswith("(")) +
                 "\nall other sets: certified\n\nsolid: certified; dashed: not certified;\n"
                 "dotted: simulation diverged (the last\nbounded period is drawn)",
                 va="top", ha="left", fontsize=7, transform=key.transAxes, family="monospace")
        fig.suptitle(f"Fig. 6 (reproduced): MR-damper model, Table 1 sets, $A_f = 2$; "
                     f"$d = \\sin(2\\pi\\,{cfg['frequency']:g}\\,t)$, last of {cfg['periods']} periods from rest",
                     fontsize=9)
        files = [C.save(fig, STUDY, "fig6")]
    return files


def write_numbers(meta: dict) -> list:
    rows = meta["sets"]
    out = []
    lines = []
    for r in rows:
        cert = "yes" if r["certified"] else "\\textbf{no}"
        paper = "yes" if r["paper_condition"] else "no"
        peak = f"{r['peak']:.3f}" if "peak" in r else "--"
        orient = {"clockwise": "cw", "counterclockwise": "ccw"}.get(r.get("orientation_vy"), "--")
        status = r["status"] if r["status"] == "ok" else f"{r['status']} ($t = {r['failed_at_time']:.0f}$\\,s)"
        area = f"{r['area_dy']:.2f}" if "area_dy" in r else "--"
        lines.append(f"({r['panel']}) & ${LATEX[r['param']]} = {r['value']:g}$ & {r['gamma']:g} & {r['alpha']:g} & "
                     f"{r['beta']:g} & {paper} & {cert} & {peak} & {area} & {orient} & {status} \\\\")
    table = ("\\begin{tabular}{llrrrccrrcl}\n\\hline\n"
             "panel & set & $\\gamma$ & $\\alpha$ & $\\beta$ & all $>0$ & certified & peak $|y|$ & "
             "$\\oint y\\,\\mathrm{d}d$ & $\\dot d$--$y$ loop & simulation \\\\\n\\hline\n" + "\n".join(lines) + "\n\\hline\n\\end{tabular}\n")
    out.append(C.write_number(TAG, "table", table))
    unc = [r for r in rows if not r["certified"]]
    out.append(C.write_number(TAG, "n_uncertified", f"{len(unc)}"))
    out.append(C.write_number(TAG, "uncertified", ", ".join(f"${LATEX[r['param']]} = {r['value']:g}$" for r in unc)))
    def peak_range(params):
        ps = [r["peak"] for r in rows if r["param"] in params and "peak" in r and r["status"] == "ok"]
        return f"{min(ps):.2f}--{max(ps):.2f}"
    out.append(C.write_number(TAG, "peak_range_k", peak_range(("k1", "k2", "k3"))))
    out.append(C.write_number(TAG, "peak_range_c", peak_range(("c1", "c2", "c3", "n"))))
    cw = [r for r in rows if r.get("orientation_vy") == "clockwise" and r["status"] == "ok"]
    out.append(C.write_number(TAG, "clockwise", ", ".join(f"${LATEX[r['param']]} = {r['value']:g}$" for r in cw)
                              or "none"))
    neg = [r for r in rows if r.get("area_dy", 0.0) < 0 and r["status"] == "ok"]
    out.append(C.write_number(TAG, "negative_work", ", ".join(
        f"${LATEX[r['param']]} = {r['value']:g}$ (${r['area_dy']:.2f}$)" for r in neg) or "none"))
    esc = [r for r in rows if r.get("escape_time") is not None]
    out.append(C.write_number(TAG, "escape", ", ".join(f"{r['escape_time']:.0f}" for r in esc) or "--"))
    failed = [r for r in rows if r["status"] != "ok"]
    out.append(C.write_number(TAG, "failed", ", ".join(
        f"${LATEX[r['param']]} = {r['value']:g}$ ({r['status']} at $t = {r['failed_at_time']:.0f}$\\,s)"
        for r in failed) or "none"))
    return out


def summarize(meta: dict) -> str:
    rows = meta["sets"]
    unc = [f"{r['param']}={r['value']:g} ({', '.join(r['failed_conditions'])})" for r in rows if not r["certified"]]
    outside = [f"{r['param']}={r['value']:g}" for r in rows if r["certified"] and not r["paper_condition"]]
    failed = [f"{r['param']}={r['value']:g}: {r['status']} at t={r['failed_at_time']:.1f} s" for r in rows
              if r["status"] != "ok"]
    ccw = [f"{r['param']}={r['value']:g}" for r in rows if r.get("orientation_vy") == "counterclockwise"]
    kpk = [r["peak"] for r in rows if r["param"] in ("k1", "k2", "k3") and r["status"] == "ok" and "peak" in r]
    cpk = [r["peak"] for r in rows if r["param"] in ("c1", "c2", "c3", "n") and "peak" in r]
    res = [r.get("periodicity_residual", np.nan) for r in rows if r["status"] == "ok"]
    return (f"s02 (Fig. 6): {len(rows)} Table 1 sets; not certified: {'; '.join(unc)}. Certified although outside "
            f"the paper's 'all positive' condition: {', '.join(outside) or 'none'}. Failed simulations: "
            f"{'; '.join(failed) or 'none'}. Peak |y| over the k1/k2/k3 sweeps {min(kpk):.2f}..{max(kpk):.2f}, over "
            f"the c1/c2/c3/n sweeps {min(cpk):.2f}..{max(cpk):.2f}. Counterclockwise d'-y loops: "
            f"{', '.join(ccw) or 'none'} (all others clockwise). Largest periodicity residual of a drawn "
            f"successful set {np.nanmax(res):.1e}.")


def main(argv=None) -> int:
    return C.run_study(argv, doc=__doc__, label="s02", config=Config, compute=compute, plot=plot,
                       write_numbers=write_numbers, summarize=summarize, read=lambda: C.read_derived(STUDY))


if __name__ == "__main__":
    sys.exit(main())
