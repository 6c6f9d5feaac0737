"""Lever measurement (issue 16, item 6): do candidate fits converge faster when their collocation states
start from the base model's trajectory instead of from the data?

``duffsym.identify.fit`` takes starting *parameters* only; the states always start from the data
(``duffsym.identify.states.initial_states``). To measure what a state warm start would give, this script
replaces that function where the NLP looks it up (``duffsym.identify.nlp.initial_states``), for the duration
of one fit, by the base model's free-run trajectory (the base fit's parameters and initial state, simulated
over the fitting part), extended by each effect's own state guess as usual.
Each candidate is fitted from the same parameters (``extended_start``) both ways on a 100-iteration budget.

    nice -n 10 python benchmarks/lever_warm_states.py [--case synth1600|s07_1A|...]

``--lever tol`` instead compares IPOPT's ``tol`` 1e-10 (``fit``'s default, used by the diagnosis) with 1e-8.

Writes ``benchmarks/results/lever_<lever>_<case>.json``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

CANDS = ("force-offset", "gas-accumulator", "asymmetry", "coulomb-friction", "cubic-damping", "output-lag",
         "input-delay", "backlash")


def main(argv=None) -> int:
    from bench_diagnose_speed import _record

    import duffsym.identify.nlp as nlp_module
    from duffsym.diagnose.prepare import prepare_record
    from duffsym.diagnose.search import _fit, _part, split_record, with_default_af
    from duffsym.effects import CATALOGUE, apply_effects
    try:
        from duffsym.identify import extended_start
    except ImportError:  # before extended_start moved next to the fitting code
        from duffsym.effects import extended_start
    from duffsym.identify.result import nrmse
    from duffsym.model.library import mr_damper
    from duffsym.simulate import simulate_record

    ap = argparse.ArgumentParser()
    ap.add_argument("--case", default="synth1600")
    ap.add_argument("--lever", choices=("states", "tol"), default="states",
                    help="states: data vs base trajectory; tol: IPOPT tol 1e-10 (fit's default) vs 1e-8")
    args = ap.parse_args(argv)
    rec, fixed = _record(args.case)
    model = mr_damper()
    k = split_record(rec, 0.3)
    fixed = with_default_af(model, fixed, _part(rec, k))
    prep, rf = prepare_record(_part(rec, k))
    q = prep.factor
    base = _fit(model, rf, fixed, None)
    y_base = simulate_record(model, base.params, rec, x0=base.x0[0], on_failure="return").y
    traj = simulate_record(model, base.params, rf, x0=base.x0[0], on_failure="return")
    X_base = np.asarray(traj.x, dtype=float)
    data_states = nlp_module.initial_states

    def warm_states(m, r, p):
        if not m.effects and r.n_times == X_base.shape[0]:
            return X_base.copy()
        return data_states(m, r, p)

    rows = []
    y = np.asarray(rec.y)
    for name in CANDS:
        eff = CATALOGUE[name]
        ext = apply_effects(model, [eff])
        x0 = extended_start(ext, eff, rf, base.params, y_base[:k:q], fixed=fixed)
        for how in (("data", "base trajectory") if args.lever == "states" else ("tol 1e-10", "tol 1e-8")):
            nlp_module.initial_states = warm_states if how == "base trajectory" else data_states
            try:
                t0 = time.perf_counter()
                if how == "tol 1e-8":
                    fr = _fit_tol(ext, rf, fixed, x0, 1e-8)
                else:
                    fr = _fit(ext, rf, fixed, x0, max_iter=100)
                secs = time.perf_counter() - t0
            finally:
                nlp_module.initial_states = data_states
            tr = simulate_record(ext, fr.params, rec, x0=fr.x0[0], on_failure="return")
            ye = tr.y if tr.success else None
            row = dict(effect=name, states=how, n_iter=fr.n_iter, status=fr.status, seconds=secs,
                       solve=fr.timings["solve"], heldout=nrmse(y[k:], ye[k:]) if ye is not None else None,
                       params={p: fr.params[p] for p in ext.param_names if p not in model.param_names})
            rows.append(row)
            print(f"{name:<18} {how:<16} it {fr.n_iter:3d} {fr.status:<28} {secs:6.1f} s  held-out "
                  f"{row['heldout'] if row['heldout'] is None else round(row['heldout'], 5)}", flush=True)
    out = HERE / "results" / f"lever_{args.lever}_{args.case}.json"
    doc = dict(case=args.case, lever=args.lever, n_fit=rf.n_times, factor=q, base_iter=base.n_iter, rows=rows)
    out.write_text(json.dumps(stamp(doc, args), indent=1, default=str))
    return 0


def _fit_tol(model, record, fixed, x0, tol):
    """``search._fit`` with another IPOPT tol (the rest as in the diagnosis)."""
    from duffsym.identify import Problem, fit

    problem = Problem(model, record, fixed={k: v for k, v in fixed.items() if k in model.param_names})
    start = {k: v for k, v in x0.items() if k in problem.free}
    return fit(problem, start, tol=tol, compute_stderr=True, max_iter=100, bound_restart=False)


if __name__ == "__main__":
    sys.exit(main())
