"""The UTFSM damper at excitation frequencies it was never fitted on, test by test against the authors' Spencer model.

Training: the 30 preprocessed sinusoid tests (6 amplitude/frequency pairs: 2 mm 5 Hz, 5 mm 3 Hz, 10 mm 1 Hz,
25 mm 0.1/0.25/0.5 Hz, each at 0, 0.25, 0.5, 0.75, 1 A), fitted with one parameter set as study s11 does
(``mr-damper-current``, eta held at 100 /s, ~25 samples per period), and the same with the rate module's
``field-yield`` (a Bingham yield that follows the current; the term the campaign discovery proposes first on these
tests), then with the catalogue's ``parallel-damping`` beside it (a viscous force that follows the current), each
started from the previous optimum and its own data-based guess (``--variants``).

Unseen: the two raw DAQ exports that have **no** preprocessed counterpart and whose frequencies are not in the
training set, ``ME5mm4Hz`` (5 mm, 4 Hz) and ``ME10mm2Hz`` (10 mm, 2 Hz), each at the five currents (the segments
between the DAQ's pause events, in the order 0, 0.25, 0.5, 0.75, 1 A; SOURCE.md). They are preprocessed here as the
authors preprocessed the training tests (SOURCE.md: channels scaled to mm and N, a moving average of a tenth of the
period on both, trimmed to the motion, means removed), with numpy only.

Reference: the authors' Spencer model with their published parameters (design.md; the same evaluation that
``tests/test_classical_models.py`` checks against their quoted errors), simulated from rest on the same records.
Scored: free-run NRMSE per test (duffsym's models from the state estimated over the first period, as ``validate``).

    python benchmarks/bench_unseen_frequencies.py

Writes ``benchmarks/results/unseen_frequencies.json`` and prints the table.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from _provenance import write_result  # benchmarks/ is on sys.path (the script's folder)

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "studies"))
CURRENTS = (0.0, 0.25, 0.5, 0.75, 1.0)
UNSEEN = {"ME5mm4Hz": 4.0, "ME10mm2Hz": 2.0}
#: The UTFSM authors' Spencer fit (design.md): p1..p12, A = 300, n = 2, gamma = beta = p7 exp(p8 i)
UTFSM_P = [1.50e-4, 1.239, 2.31e-3, -38.15, 41.51, 15.22, 1.894, -3.656, 7.626, 0.925, 78.34, 9.867]


def spencer_params(i: float) -> dict:
    p1, p2, p3, p4, p5, p6, p7, p8, p9, p10, p11, p12 = UTFSM_P
    g = p7 * math.exp(p8 * i)
    return dict(alpha=p4 * i * i + p5 * i + p6, alpha_u=0.0, c0=p9 * i + p10, c0_u=0.0, c1=p11 * i + p12, c1_u=0.0,
                k0=p1, k1=p2, x0=p3, gamma=g, beta=g, A=300.0, eta=190.0)  # fmt: skip


def raw_segments(path: Path, freq: float):
    """The five current segments of a raw export, preprocessed as the authors did (module docstring)."""
    from duffsym.data.record import Record

    lines = path.read_text().splitlines()
    rate = float(next(ln.split(":")[1] for ln in lines[:7] if ln.startswith("Sampling Rate")))
    rows = [ln.split(",") for ln in lines[7:]]
    ch = np.array([[float(r[2]), float(r[3])] for r in rows])
    events = [r[4].strip() if len(r) > 4 else "" for r in rows]
    pauses = [i for i, e in enumerate(events) if "Pause" in e]
    starts = [0] + [i + 1 for i in pauses[:-1]]
    d_raw, f_raw = (ch[:, 1], ch[:, 0]) if rate < 500 else (ch[:, 0], ch[:, 1])  # the 200 Hz file is swapped
    width = max(1, round(rate / (10 * freq)))  # a tenth of the period
    kernel = np.ones(width) / width
    out = []
    for cur, a, b in zip(CURRENTS, starts, pauses):
        d = np.convolve(d_raw[a:b] * 10.0, kernel, mode="valid")
        y = np.convolve(f_raw[a:b] * 980.665, kernel, mode="valid")
        period = int(round(rate / freq))
        span = np.array([np.ptp(d[max(0, k - period // 2) : k + period // 2]) for k in range(d.size)])
        moving = np.flatnonzero(span > 0.8 * span.max())
        d, y = d[moving[0] : moving[-1] + 1], y[moving[0] : moving[-1] + 1]
        n = (d.size // period) * period  # whole periods
        d, y = d[:n] - d[:n].mean(), y[:n] - y[:n].mean()
        t = np.arange(n) / rate
        out.append(Record(t=t, d=d, y=y, current=cur, name=f"{path.stem[2:]}{cur:g}A", units={"d": "mm", "y": "N"},
                          source=str(path)))  # fmt: skip
    return out


def spencer_nrmse(rec, current: float) -> float:
    from duffsym.identify.result import nrmse
    from duffsym.model import get_model
    from duffsym.simulate import simulate

    model = get_model("spencer")
    tr = simulate(model, spencer_params(current), rec.t, rec.inputs_for(model), x0=np.array([0.0, 0.0, current]))
    return float(nrmse(rec.y, tr.y)) if tr.success else math.inf


def main(argv=None) -> int:
    import s11_current_driven as s11

    from duffsym.data import external_data_dir
    from duffsym.effects import CATALOGUE, apply_effects
    from duffsym.effects.rate import RATE_EFFECTS
    from duffsym.identify import Problem, fit, validate
    from duffsym.model import get_model

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(HERE / "results" / "unseen_frequencies.json"))
    ap.add_argument("--variants", default="field-yield,field-yield+parallel-damping",
                    help="effects added to the base, each variant started from the one without its last effect")  # fmt: skip
    args = ap.parse_args(argv)
    folder = external_data_dir() / "mr_damper_utfsm_quiroz2022" / "raw_sinusoidal"
    unseen = [r for name, f in UNSEEN.items() for r in raw_segments(folder / f"{name}.txt", f)]
    cfg = s11.Config()
    recs = s11.campaign_records(cfg)
    base_model = get_model("mr-damper-current")
    t0 = time.perf_counter()
    base = s11.campaign_fit(base_model, recs, cfg)
    fits = {"mr-damper-current": (base, base_model, time.perf_counter() - t0)}
    known = {**CATALOGUE, **RATE_EFFECTS}
    for variant in args.variants.split(","):
        names = variant.split("+")
        prev = fits[" + ".join(["mr-damper-current", *names[:-1]])]  # the variant without its last effect starts it
        model = apply_effects(base_model, [known[e] for e in names])
        eff = known[names[-1]]
        guesses = [eff.initial_guess(r, s11.free_run(prev[0], r, prev[1])[0]) for r in recs]
        start = {**prev[0].params, **{k: float(np.median([g[k] for g in guesses])) for k in guesses[0]}}
        t0 = time.perf_counter()
        res = fit(Problem(model, recs, fixed={"eta": cfg.campaign_eta}, constraints=s11._constraints(base_model)),
                  x0={k: v for k, v in start.items() if k != "eta" and k in model.param_names})  # fmt: skip
        fits[" + ".join(["mr-damper-current", *names])] = (res, model, time.perf_counter() - t0)
    rows = []
    for r in unseen:
        row = {"test": r.name, "samples": r.n_times, "spencer (published)": spencer_nrmse(r, r.current)}
        for name, (fr, m, _) in fits.items():
            v = validate(fr, r, m)
            row[name] = float(v.nrmse)
        rows.append(row)
        print("  ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in row.items()), flush=True)
    summary = {}
    for name in fits:
        wins = sum(row[name] < row["spencer (published)"] for row in rows)
        summary[name] = dict(beats_spencer=f"{wins} of {len(rows)}", median=float(np.median([x[name] for x in rows])),
                             worst=float(max(x[name] for x in rows)), fit_seconds=fits[name][2],
                             training_median=float(np.median([s11.free_run(fits[name][0], q, fits[name][1])[1]
                                                              for q in recs])))  # fmt: skip
    summary["spencer (published)"] = dict(median=float(np.median([x["spencer (published)"] for x in rows])),
                                          worst=float(max(x["spencer (published)"] for x in rows)))  # fmt: skip
    print(json.dumps(summary, indent=1))
    doc = dict(benchmark="unseen_frequencies", rows=rows, summary=summary,
               params={k: dict(v[0].params) for k, v in fits.items()})  # fmt: skip
    write_result(args.out, doc, args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
