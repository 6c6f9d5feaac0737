"""Rate-physics candidates on the UTFSM campaign, held out by excitation (issue 23, item 3).

For each fold (an amplitude/frequency pair left out at all five currents, chosen before any fit: the worst
ones of s11, ``25mm0x1Hz`` first), the base ``mr-damper-current`` is fitted to the other 25 tests as s11 does
(s11's records at ~25 samples/period, eta held at 100 /s, k1 + k2 >= 0 at 0 and 1 A); then each candidate
(``duffsym.effects.rate.RATE_EFFECTS`` and the catalogue's ``parallel-damping``) is fitted from the base optimum
plus the effect's own data-based guess (median over the training records), and all are run free on the
held-out tests. Printed per candidate and fold: held-out median and worst NRMSE beside in-sample median and
worst (training tests), fit time.

Usage: ``python benchmarks/bench_rate_physics.py [--folds 25mm0x1Hz,2mm5Hz] [--candidates maxwell-branch,...]``
(writes ``benchmarks/results/bench_rate_physics.json`` after every candidate).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "studies"))


def _effect(name):
    from duffsym.effects import ADDABLE

    return ADDABLE[name]


def _scores(res, recs, model):
    import s11_current_driven as s11

    return [s11.free_run(res, r, model) for r in recs]


def _start(model, effect, base_res, base_model, train):
    """Base optimum + the effect's guess (median over the training records of its per-record guess)."""
    import s11_current_driven as s11

    guesses = []
    for r in train:
        y_b, _, _ = s11.free_run(base_res, r, base_model)
        if np.all(np.isfinite(y_b)):
            guesses.append(effect.initial_guess(r, y_b))
    start = dict(base_res.params)
    for k in guesses[0] if guesses else {}:
        start[k] = float(np.median([g[k] for g in guesses]))
    return {p.name: float(min(max(start.get(p.name, p.default), p.lower), p.upper)) for p in model.params}


def run_fold(fold: str, candidates, cfg, recs) -> dict:
    import s11_current_driven as s11

    from duffsym.effects import apply_effects
    from duffsym.identify import Problem, fit
    from duffsym.model import get_model

    train = [r for r in recs if not r.name.startswith(fold)]
    held = [r for r in recs if r.name.startswith(fold)]
    base_model = get_model("mr-damper-current")
    out = {}
    for cand in ("base",) + tuple(candidates):
        model = base_model if cand == "base" else apply_effects(base_model, [_effect(cand)])
        t0 = time.perf_counter()
        if cand == "base":
            res = s11.campaign_fit(model, train, cfg)
            base_res = res
        else:
            x0 = _start(model, _effect(cand), base_res, base_model, train)
            fixed = {"eta": cfg.campaign_eta}
            res = fit(Problem(model, train, fixed=fixed, constraints=s11._constraints(base_model)),
                      x0={k: v for k, v in x0.items() if k not in fixed})
        wall = time.perf_counter() - t0
        ho = [e for _, e, _ in _scores(res, held, model)]
        ins = [e for _, e, _ in _scores(res, train, model)]
        out[cand] = dict(heldout={r.name: e for r, e in zip(held, ho)}, heldout_median=float(np.median(ho)),
                         heldout_worst=float(np.max(ho)), insample_median=float(np.median(ins)),
                         insample_worst=float(np.max(ins)), fit_s=wall, status=res.status, success=bool(res.success),
                         params={k: v for k, v in res.params.items() if k not in base_res.params or cand == "base"})
        print(f"  fold {fold} {cand:16s}: held out median {np.median(ho):.3f} worst {np.max(ho):.3f} | in sample "
              f"median {np.median(ins):.3f} worst {np.max(ins):.3f} | fit {wall:.0f} s {res.status}", flush=True)
        yield cand, out[cand]


def main(argv=None) -> int:
    import s11_current_driven as s11

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--folds", default="25mm0x1Hz")
    ap.add_argument("--candidates", default="maxwell-branch,field-yield,parallel-damping")
    ap.add_argument("--out", default=str(HERE / "results" / "bench_rate_physics.json"))
    args = ap.parse_args(argv)
    cfg = s11.Config()
    recs = s11.campaign_records(cfg)
    results: dict = {"config": dict(samples_per_period=cfg.samples_per_period, eta=cfg.campaign_eta), "folds": {}}
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    for fold in args.folds.split(","):
        results["folds"][fold] = {}
        for cand, r in run_fold(fold, [c for c in args.candidates.split(",") if c], cfg, recs):
            results["folds"][fold][cand] = r
            tmp = out.with_suffix(".tmp")
            tmp.write_text(json.dumps(stamp(results, args), indent=2, default=lambda v: None if isinstance(v, float) and
                                      not math.isfinite(v) else str(v)))
            tmp.replace(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
