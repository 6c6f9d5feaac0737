"""Study s03 — hysteresis loops of every Table 2 row (the identified 3-kN MR damper, Fig. 7's model).

``mr_damper(5)`` with each ``TABLE2`` row (0 to 0.8 V), driven by a unit-amplitude sine at 2 Hz,
d(t) = sin(4 pi t), sampled at dt = 0.005 s as in the paper's experiment (100 samples per period).
Each row is simulated from rest for ``Config.periods`` periods and the last full period is drawn
in the d–y and d'–y planes, one colour per voltage (colour bar in volts). The paper's measured
data are not reproduced here (they are not public); the curves are the model's side of Fig. 7.

Numbers per voltage: the peak force max |y| of the last period (and its ratio to A_f, which the
paper defines as "the maximum amplitude of y"), the d–y loop area ∮ y dd (``duffsym.derive.
loop_area``; positive = clockwise = work done on the damper), which in the periodic steady state
is the energy the damper dissipates per cycle, and the same area from a 10x finer sampling to show
the quadrature error of dt = 0.005 s. ``duffsym.derive.cycle_energy`` gives the model's internal
balance (input work = dissipation + change of V) as a check. The displacement amplitude of the
paper's experiment is not stated, so the numbers hold for unit amplitude in the model's units.

Outputs: ``data/derived/s03_table2_loops.{npz,json}``, figure
``paper/figures/s03_table2_loops_loops.png``, numbers ``paper/output/s03_table.tex`` (peak force,
loop area per voltage), ``s03_area_lo.tex``/``s03_area_hi.tex`` (0.2 and 0.8 V), ``s03_peak_ratio_min``/
``_max`` (peak/A_f range).
"""
from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np

import _common as C

STUDY = "s03_table2_loops"
TAG = "s03"


@dataclass(frozen=True)
class Config:
    """Settings of study s03.

    frequency : Hz (2, as in Table 2). amplitude : displacement amplitude (1).
    dt : sample time, s (0.005, as in the paper). periods : periods simulated from rest.
    refine : factor of the finer sampling used to check the loop-area quadrature.
    """

    frequency: float = 2.0
    amplitude: float = 1.0
    dt: float = 0.005
    periods: int = 10
    refine: int = 10

    @classmethod
    def smoke(cls) -> "Config":
        """CI variant: 3 periods (already periodic to ~1e-4 at 2 Hz), same sampling."""
        return cls(periods=3)

    def summary(self) -> str:
        return (f"s03 config: {self.amplitude:g} sin(2 pi {self.frequency:g} t), dt {self.dt:g} s, "
                f"{self.periods} periods, refinement x{self.refine}")


def compute(cfg: Config) -> dict:
    """Simulate every Table 2 row; write the derived files; return the results."""
    from duffsym.derive import cycle_energy, loop_area
    from duffsym.excitation import Sine
    from duffsym.model import mr_damper
    from duffsym.model.presets import TABLE2, TABLE2_N
    from duffsym.simulate import simulate, steady_cycle

    model = mr_damper(TABLE2_N)
    T = 1.0 / cfg.frequency
    spp = int(round(T / cfg.dt))
    if abs(spp * cfg.dt - T) > 1e-9 * T:
        raise ValueError(f"s03: dt = {cfg.dt} s does not divide the period {T} s; choose dt = T / integer")
    t = np.linspace(0.0, cfg.periods * T, cfg.periods * spp + 1)
    tf = np.linspace(0.0, cfg.periods * T, cfg.periods * spp * cfg.refine + 1)
    exc = Sine(cfg.amplitude, cfg.frequency)
    arrays, rows = {}, []
    for v, params in TABLE2.items():
        tr = simulate(model, params, t, exc)
        sl = steady_cycle(tr, T)
        tt, d, dv, y = tr.t[sl], tr.u[sl, 0], tr.u[sl, 1], tr.y[sl]
        key = f"v{v:.1f}"
        arrays[f"{key}_t"], arrays[f"{key}_d"], arrays[f"{key}_v"], arrays[f"{key}_y"] = tt, d, dv, y
        area = loop_area(tt[:-1], d[:-1], y[:-1])  # one period: the last sample repeats the first
        fine = simulate(model, params, tf, exc)
        fsl = steady_cycle(fine, T)
        area_fine = loop_area(fine.t[fsl][:-1], fine.u[fsl, 0][:-1], fine.y[fsl][:-1])
        ce = cycle_energy(fine, T, model)
        prev = tr.y[-2 * spp - 1:-spp]
        rows.append(dict(voltage=v, params=params, A_f=params["A_f"], peak=float(np.max(np.abs(y))),
                         peak_over_Af=float(np.max(np.abs(y)) / params["A_f"]), loop_area=area,
                         loop_area_fine=area_fine, power=area * cfg.frequency,
                         internal_input_work=ce.input_work, internal_dissipated=ce.dissipated,
                         internal_balance_residual=ce.balance_residual,
                         periodicity_residual=float(np.max(np.abs(y - prev)) / np.max(np.abs(y))),
                         substeps_max=int(tr.substeps.max())))
    meta = dict(study=STUDY, **C.provenance(cfg), rows=rows,
                areas_increasing=bool(np.all(np.diff([r["loop_area"] for r in rows]) > 0)))
    files = C.write_derived(STUDY, arrays, meta)
    return dict(meta=meta, files=files)


def plot(results: dict | None = None) -> list:
    """Draw the d–y and d'–y loops per voltage and peak/area against voltage, from the derived files."""
    arrays, meta = C.read_derived(STUDY)
    rows, cfg = meta["rows"], meta["config"]
    with C.style() as plt:
        import matplotlib as mpl

        volts = [r["voltage"] for r in rows]
        norm = mpl.colors.Normalize(vmin=min(volts), vmax=max(volts))
        cmap = mpl.colormaps["viridis"]
        fig, axs = plt.subplots(1, 3, figsize=(10.0, 4.0), width_ratios=[1, 1, 0.8])
        for r in rows:
            key = f"v{r['voltage']:.1f}"
            col = cmap(norm(r["voltage"]))
            axs[0].plot(arrays[f"{key}_d"], arrays[f"{key}_y"], color=col, lw=1.3)
            axs[1].plot(arrays[f"{key}_v"], arrays[f"{key}_y"], color=col, lw=1.3)
        for ax in axs[:2]:
            ax.axhline(0, color="0.85", lw=0.5, zorder=0)
            ax.axvline(0, color="0.85", lw=0.5, zorder=0)
            ax.set_ylabel(r"$y = F_{\mathrm{mr}}$ (1)")
        axs[0].set_xlabel(r"$d$ (1)")
        axs[1].set_xlabel(r"$\dot d$ (1)")
        axs[0].set_title("Fig. 7 left column (model): $d$–$y$")
        axs[1].set_title(r"Fig. 7 right column (model): $\dot d$–$y$")
        sm = mpl.cm.ScalarMappable(norm=norm, cmap=cmap)
        cb = fig.colorbar(sm, ax=axs[:2], pad=0.01, aspect=30)
        cb.set_label("coil voltage (V)")
        cb.set_ticks(volts)
        ax = axs[2]
        ax.plot(volts, [r["loop_area"] for r in rows], "o-", color="C0", label="loop area (energy per cycle)")
        ax.plot(volts, [r["peak"] for r in rows], "s-", color="C1", label=r"peak $|y|$")
        ax.plot(volts, [r["A_f"] for r in rows], "^:", color="0.4", label=r"$A_f$ (Table 2)")
        ax.set_xlabel("coil voltage (V)")
        ax.set_ylabel("(1)")
        ax.set_title("per cycle, last period")
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=1)
        fig.suptitle(f"Table 2 rows (mr_damper, $n = 5$): $d = \\sin(2\\pi\\,{cfg['frequency']:g}\\,t)$, "
                     f"$\\Delta t$ = {cfg['dt']:g} s, last of {cfg['periods']} periods from rest", fontsize=9)
        return [C.save(fig, STUDY, "loops")]


def write_numbers(meta: dict) -> list:
    rows = meta["rows"]
    lines = [f"{r['voltage']:.1f} & {r['A_f']:g} & {r['peak']:.3f} & {r['peak_over_Af']:.2f} & "
             f"{r['loop_area']:.3f} & {r['loop_area_fine']:.3f} \\\\" for r in rows]
    table = ("\\begin{tabular}{rrrrrr}\n\\hline\n"
             "voltage (V) & $A_f$ & peak $|y|$ & peak$/A_f$ & energy per cycle $\\oint y\\,\\mathrm{d}d$ & "
             "same, $\\Delta t/10$ \\\\\n\\hline\n" + "\n".join(lines) + "\n\\hline\n\\end{tabular}\n")
    by_v = {round(r["voltage"], 1): r for r in rows}
    ratios = [r["peak_over_Af"] for r in rows]
    return [C.write_number(TAG, "table", table),
            C.write_number(TAG, "area_lo", f"{by_v[0.2]['loop_area']:.2f}"),
            C.write_number(TAG, "area_hi", f"{by_v[0.8]['loop_area']:.2f}"),
            C.write_number(TAG, "area_zero", f"{by_v[0.0]['loop_area']:.2f}"),
            C.write_number(TAG, "peak_ratio_min", f"{min(ratios):.2f}"),
            C.write_number(TAG, "peak_ratio_max", f"{max(ratios):.2f}")]


def summarize(meta: dict) -> str:
    rows = meta["rows"]
    per = "; ".join(f"{r['voltage']:.1f} V: peak {r['peak']:.3f} ({r['peak_over_Af']:.2f} A_f), area "
                    f"{r['loop_area']:.3f}" for r in rows)
    qerr = max(abs(r["loop_area"] - r["loop_area_fine"]) / abs(r["loop_area_fine"]) for r in rows)
    bal = max(abs(r["internal_balance_residual"]) / abs(r["internal_input_work"]) for r in rows)
    return (f"s03 (Table 2 loops, 2 Hz, unit amplitude): {per}. Loop areas "
            f"{'increase' if meta['areas_increasing'] else 'do NOT increase'} monotonically with voltage; peak |y| "
            f"is {min(r['peak_over_Af'] for r in rows):.2f}-{max(r['peak_over_Af'] for r in rows):.2f} of A_f, "
            f"not A_f. Quadrature error of the dt = 0.005 s loop area <= {qerr:.1e} (relative); internal energy "
            f"balance residual <= {bal:.1e}; periodicity residual <= "
            f"{max(r['periodicity_residual'] for r in rows):.1e}.")


def main(argv=None) -> int:
    return C.run_study(argv, doc=__doc__, label="s03", config=Config, compute=compute, plot=plot,
                       write_numbers=write_numbers, summarize=summarize, read=lambda: C.read_derived(STUDY))


if __name__ == "__main__":
    sys.exit(main())
