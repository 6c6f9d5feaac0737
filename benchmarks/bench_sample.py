"""Benchmark: emcee posterior sampling with duffsym's likelihood vs the same sampler on a scipy likelihood.

Run from the repository root::

    python benchmarks/bench_sample.py            # 32 walkers x 10 000 steps + the scipy baseline (~1-2 min)
    python benchmarks/bench_sample.py --quick    # 32 x 2 000 (no target check)
    python benchmarks/bench_sample.py --calibration 40   # coverage of the 90 % intervals over 40 seeds (~10 min)

Writes ``benchmarks/results/sample.json``. See ``benchmarks/README.md``.

Setting: ``mr_damper(5)``, Table 2 0.4 V row, d = sin(2 pi 2 t), 400 samples at dt = 0.005 s, 2 % white
output noise (seed 20261121); fitted by ``duffsym.identify.fit`` (c1, c2, c3, k1, k2 free; A_f fixed at
its true 1.6, k3 = 0). duffsym: ``duffsym.uncertainty.sample`` (vectorized: all walkers per step in one
call of the compiled fixed-schedule kernel). Baseline: the same emcee ensemble, moves, priors,
coordinates and marginal likelihood, but the log-posterior of each walker from
``scipy.integrate.solve_ivp`` (LSODA, rtol 3e-5, atol 3e-7: the tolerances tuned in bench_simulate to
match duffsym's accuracy) with a Python right-hand side of Eq. 12 interpolating the sampled input --
what a user writes. The baseline runs a short chain; its per-step time is scaled to 10 000 steps.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import duffsym
from duffsym.data import synthetic_record
from duffsym.excitation import Sine
from duffsym.identify import Problem, fit
from duffsym.model.library import mr_damper
from duffsym.model.presets import table2_params
from duffsym.simulate import input_matrix

HERE = Path(__file__).resolve().parent
SEED = 20261121
TARGET_S = 60.0


def machine() -> dict:
    return {"nproc": os.cpu_count(), "platform": platform.platform(), "python": platform.python_version(),
            "processor": platform.processor() or platform.machine()}


def load() -> list[float]:
    return [round(v, 2) for v in os.getloadavg()]


def git_sha() -> str | None:
    try:
        return subprocess.run(["git", "rev-parse", "HEAD"], cwd=HERE, capture_output=True, text=True).stdout.strip()
    except OSError:
        return None


class ScipyLogPosterior:
    """The baseline: duffsym's priors/coordinates and marginal Gaussian likelihood, solve_ivp free run."""

    def __init__(self, post, rec, x0, rtol=3e-5, atol=3e-7):
        self.post = post
        self.t = np.asarray(rec.t)
        self.d = np.asarray(rec.d)
        self.dd = np.asarray(rec.velocity())
        self.y = np.asarray(rec.y)
        self.x0 = np.asarray(x0, dtype=float)
        self.rtol, self.atol = rtol, atol
        self.n_fail = 0

    def __call__(self, z):
        from scipy.integrate import solve_ivp

        z = np.asarray(z, dtype=float)
        if np.any(z < self.post.lo) or np.any(z > self.post.hi):
            return -np.inf
        p = dict(zip(self.post.model.param_names, self.post.params(z)[0]))
        c1, c2, c3, k1, k2, k3, A_f = (p[k] for k in ("c1", "c2", "c3", "k1", "k2", "k3", "A_f"))
        t, d, dd = self.t, self.d, self.dd

        def rhs(tt, x):
            di = np.interp(tt, t, d)
            ddi = np.interp(tt, t, dd)
            return [x[1], k1 * (di - x[0]) + c1 * (ddi - x[1]) - c2 * x[1] - k2 * x[0] - k3 * x[0] ** 5 - c3 * x[1] ** 5]

        x0 = self.post.initial_states(z, 0)
        x0 = self.x0 if x0 is None else x0[0]
        sol = solve_ivp(rhs, (t[0], t[-1]), x0, method="LSODA", t_eval=t, rtol=self.rtol, atol=self.atol)
        if not sol.success or sol.y.shape[1] != t.size:
            self.n_fail += 1
            return -np.inf
        r = A_f * sol.y[1] - self.y
        return -0.5 * r.size * np.log(np.sum(r**2))


def calibration(n_seeds: int, steps: int) -> int:
    """Coverage of the 90 % posterior intervals (and of the Laplace +-1.645 se intervals) of the truth over
    ``n_seeds`` synthetic records (seeds 1000 + i) of the benchmark setting; writes results/sample_calibration.json."""
    import warnings

    from duffsym.uncertainty import sample

    model = mr_damper(5)
    truth = table2_params(0.4)
    rows = []
    t_start = time.perf_counter()
    for i in range(n_seeds):
        rec = synthetic_record(model, truth, Sine(1.0, 2.0), dt=0.005, duration=2.0, noise=0.02, rng=1000 + i)
        res = fit(Problem(model, rec, fixed={"A_f": truth["A_f"]}))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            ch = sample(res, rec, n_walkers=32, n_steps=steps, rng=i, recheck_draws=4, sigma_draws=200)
        d = ch.to_dict()
        row = {"seed": 1000 + i, "fit_success": res.success, "chain_over_tau": d["chain_over_tau"],
               "acceptance": d["acceptance"], "converged": d["converged"], "warnings": [str(w.message) for w in caught],
               "evaluations": d["evaluations"], "covered": {}, "laplace_covered": {}, "q05": d["q05"], "q95": d["q95"],
               "median": d["median"], "optimum": dict(res.params), "stderr": dict(res.stderr)}
        for n in res.free:
            row["covered"][n] = bool(d["q05"][n] <= truth[n] <= d["q95"][n])
            row["laplace_covered"][n] = bool(abs(res.params[n] - truth[n]) <= 1.645 * res.stderr[n])
        rows.append(row)
        print(f"seed {1000 + i}: covered {sum(row['covered'].values())}/5, chain/tau {d['chain_over_tau']:.0f}, "
              f"acc {d['acceptance']:.2f} ({time.perf_counter() - t_start:.0f} s)", flush=True)
    names = list(rows[0]["covered"])
    table = {n: {"posterior_90": float(np.mean([r["covered"][n] for r in rows])),
                 "laplace_90": float(np.mean([r["laplace_covered"][n] for r in rows])),
                 "n": len(rows)} for n in names}
    ok = {n: 0.80 <= table[n]["posterior_90"] <= 0.98 for n in names}
    out = {"machine": machine(), "git": git_sha(), "setting": {"row": "Table 2 0.4 V", "n_samples": 400, "noise": 0.02,
                                                                "free": names, "A_f": "fixed at truth", "steps": steps,
                                                                "walkers": 32, "seeds": [r["seed"] for r in rows]},
           "coverage": table, "target_80_98": ok, "rows": rows, "wall_s": time.perf_counter() - t_start}
    (HERE / "results").mkdir(exist_ok=True)
    (HERE / "results" / "sample_calibration.json").write_text(json.dumps(duffsym._json.jsonable(out), indent=2))
    print(f"{'param':>6} {'posterior 90%':>14} {'Laplace 90%':>12}  (n = {len(rows)})")
    for n in names:
        print(f"{n:>6} {table[n]['posterior_90']:14.2f} {table[n]['laplace_90']:12.2f}  {'ok' if ok[n] else 'OUT'}")
    print("wrote benchmarks/results/sample_calibration.json")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--calibration", type=int, default=0, metavar="N_SEEDS",
                    help="run the coverage calibration over N seeds instead of the timing")
    ap.add_argument("--calibration-steps", type=int, default=3000)
    ap.add_argument("--steps", type=int, default=10_000)
    ap.add_argument("--baseline-steps", type=int, default=8)
    args = ap.parse_args(argv)
    if args.calibration:
        return calibration(args.calibration, args.calibration_steps)
    steps = 2000 if args.quick else args.steps
    import emcee

    from duffsym.uncertainty import sample
    from duffsym.uncertainty._setup import build_posterior

    model = mr_damper(5)
    truth = table2_params(0.4)
    rec = synthetic_record(model, truth, Sine(1.0, 2.0), dt=0.005, duration=2.0, noise=0.02, rng=SEED)
    res = fit(Problem(model, rec, fixed={"A_f": truth["A_f"]}))
    out = {"machine": machine(), "git": git_sha(), "versions": {"duffsym": duffsym.__version__, "emcee": emcee.__version__,
                                                                "numpy": np.__version__},
           "setting": {"model": "mr_damper(5)", "row": "Table 2, 0.4 V", "n_samples": rec.n_times, "noise": 0.02,
                       "seed": SEED, "free": list(res.free), "n_walkers": 32, "n_steps": steps},
           "fit": {"params": res.params, "stderr": res.stderr, "nrmse": res.nrmse}}
    # warm-up (compile / load the kernel) is not part of a run's time in a fresh process? it is: measure both
    t0 = time.perf_counter()
    sample(res, rec, n_walkers=32, n_steps=20, rng=1, recheck_draws=0, sigma_draws=0)
    first = time.perf_counter() - t0
    ld0 = load()
    t0 = time.perf_counter()
    ch = sample(res, rec, n_walkers=32, n_steps=steps, rng=0)
    wall = time.perf_counter() - t0
    d = ch.to_dict()
    out["duffsym"] = {"wall_s": wall, "sampling_s": ch.timings["sampling"],
                      "sampling_cpu_s": ch.timings["sampling_cpu"], "setup_s": ch.timings["setup"],
                      "per_step_ms": 1e3 * ch.timings["per_step"],
                      "per_evaluation_us": 1e6 * ch.timings["sampling"] / (32 * steps),
                      "first_call_s (20 steps, incl. kernel load/compile)": first,
                      "load_before": ld0, "load_after": load(), "tau": d["tau"], "ess": d["ess"],
                      "acceptance": d["acceptance"], "converged": d["converged"], "chain_over_tau": d["chain_over_tau"],
                      "evaluations": d["evaluations"], "recheck": d["recheck"], "median": d["median"], "q05": d["q05"],
                      "q95": d["q95"], "records": d["records"], "warnings": d["warnings"]}
    print(f"duffsym: 32 x {steps} steps in {wall:.1f} s (sampling {ch.timings['sampling']:.1f} s, CPU "
          f"{ch.timings['sampling_cpu']:.1f} s, "
          f"{1e3 * ch.timings['per_step']:.2f} ms/step), load {ld0} -> {load()}", flush=True)
    print(ch.summary(), flush=True)
    # baseline: same sampler, scipy likelihood, short chain
    post, _, _, setup = build_posterior(res, rec, sample_x0=ch.settings["sample_x0"])
    base = ScipyLogPosterior(post, rec, setup[0]["x0"])
    p0 = ch.chain[-1].copy()  # start in the posterior (no failures from the start ball)
    z0 = post.coords(p0)
    from duffsym.uncertainty.sampler import default_moves

    sampler = emcee.EnsembleSampler(32, post.n_dim, base, moves=default_moves())
    ld1 = load()
    t0 = time.perf_counter()
    c0 = time.process_time()
    sampler.run_mcmc(z0, args.baseline_steps)
    tb = time.perf_counter() - t0
    tb_cpu = time.process_time() - c0
    per_step = tb / args.baseline_steps
    out["baseline"] = {"method": "emcee + solve_ivp LSODA rtol 3e-5 atol 3e-7, Python rhs with np.interp",
                       "steps": args.baseline_steps, "wall_s": tb, "cpu_s": tb_cpu,
                       "extrapolated_cpu_s": tb_cpu / args.baseline_steps * steps, "per_step_ms": 1e3 * per_step,
                       "per_evaluation_us": 1e6 * per_step / 32, "extrapolated_s": per_step * steps,
                       "failures": base.n_fail, "load_before": ld1, "load_after": load()}
    # accuracy of the baseline vs duffsym's likelihood at the same points
    lp_d, _ = post.evaluate(z0[:8])
    lp_b = np.array([base(z) for z in z0[:8]])
    out["baseline"]["max_abs_logpost_difference_vs_duffsym"] = float(np.max(np.abs(lp_d - lp_b)))
    ratio_sampling = per_step * steps / ch.timings["sampling"]
    out["ratio"] = {"baseline_over_duffsym_sampling": ratio_sampling,
                    "baseline_over_duffsym_wall": per_step * steps / wall,
                    "baseline_over_duffsym_cpu": tb_cpu / args.baseline_steps * steps / ch.timings["sampling_cpu"]}
    out["target"] = {"seconds": TARGET_S, "met_wall": bool(wall < TARGET_S) if steps >= 10_000 else None,
                     "met_cpu": bool(ch.timings["sampling_cpu"] < TARGET_S) if steps >= 10_000 else None}
    print(f"baseline: {1e3 * per_step:.0f} ms/step ({args.baseline_steps} steps) -> {per_step * steps:.0f} s for "
          f"{steps} steps; ratio {ratio_sampling:.0f}x (sampling), {per_step * steps / wall:.0f}x (wall); "
          f"max |dlogpost| {out['baseline']['max_abs_logpost_difference_vs_duffsym']:.2g}", flush=True)
    name = "sample_quick.json" if args.quick else "sample.json"
    (HERE / "results").mkdir(exist_ok=True)
    (HERE / "results" / name).write_text(json.dumps(duffsym._json.jsonable(out), indent=2))
    print(f"wrote benchmarks/results/{name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
