"""Benchmark: duffsym's identification (collocation + IPOPT) vs scipy least_squares + solve_ivp single shooting.

Issue 3, "Done when", benchmarks:

(i)  one 1600-sample synthetic record (Table 2 0.4 V row, ``mr_damper()``, 2 Hz unit sine, dt 0.005 s,
     2 % noise, seed 20261121), written as CSV. duffsym: ``duffsym fit FILE --json --quiet`` end to end
     as a subprocess (wall time, Python start-up included) and the in-process ``fit()`` split into
     build/solve. Baseline: scipy ``least_squares`` (trf, default tolerances) over c1, c2, c3, k1, k2
     (A_f = max|y|, k3 = 0 as duffsym does), single shooting with ``solve_ivp`` (LSODA, default
     tolerances, Python rhs with ``np.interp`` of d and d'). Both from the same start (duffsym's
     ``initial_guess``, the one the CLI uses) and the same initial state (duffsym's data-based one).
     Both results are scored by the same free-run NRMSE (``duffsym.simulate.simulate``).
     Then 20 random starts (seeded) log-uniform within a factor 10 of the truth mapped to
     A_f = max|y| by the scaling symmetry, for both methods.
(ii) wall time and peak RSS of ``duffsym fit`` vs record length, each in a fresh process.

Run from the repository root::

    python benchmarks/bench_fit.py                  # everything (about 30-40 minutes on 2 shared cores)
    python benchmarks/bench_fit.py --part main      # (i) timings only
    python benchmarks/bench_fit.py --part starts    # (i) random starts
    python benchmarks/bench_fit.py --part sweep     # (ii)

Each part writes ``benchmarks/results/fit_<part>.json``; ``--part merge`` (run at the end of the
default run) joins them into ``benchmarks/results/fit.json``. See ``benchmarks/README.md``.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import sysconfig
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
SEED = 20261121
N_MAIN = 1600
DT = 0.005
FREQ = 2.0
NOISE = 0.02
FREE = ("c1", "c2", "c3", "k1", "k2")
SIZES = (400, 1600, 6400, 25_600, 100_000)
MAX_SECONDS = 180.0
MAX_RSS_GB = 8.0
#: the baseline a user reaches after the default one stalls at its start: tighter LSODA tolerances and a
#: finite-difference step above the integration noise (the default sqrt(eps) step differentiates noise)
TUNED = {"rtol": 1e-6, "atol": 1e-9, "diff_step": 1e-3}


# ---------------------------------------------------------------------------------------------- helpers
def machine() -> dict:
    return {"nproc": os.cpu_count(), "platform": platform.platform(), "python": platform.python_version(),
            "processor": platform.processor() or platform.machine()}


def load() -> list[float]:
    return [round(v, 2) for v in os.getloadavg()]


def make_record(n: int):
    from duffsym.data import synthetic_record
    from duffsym.excitation import Sine
    from duffsym.model.library import mr_damper
    from duffsym.model.presets import table2_params

    model = mr_damper()
    rec = synthetic_record(model, table2_params(0.4), Sine(amplitude=1.0, frequency=FREQ), dt=DT,
                           duration=n * DT, noise=NOISE, rng=SEED, name=f"table2-0.4V-{n}")
    if rec.n_times != n:
        raise RuntimeError(f"record has {rec.n_times} samples, wanted {n}")
    return model, rec


def write_record(n: int, path: Path):
    from duffsym.data import write_csv

    model, rec = make_record(n)
    write_csv(rec, path)
    return model, rec


def free_run_nrmse(model, rec, params: dict, x0) -> float:
    """NRMSE of the free-run simulation (duffsym.simulate, auto substeps) from x0: rms error / std(y)."""
    from duffsym.identify import nrmse
    from duffsym.simulate import simulate

    y = np.asarray(rec.y)
    tr = simulate(model, params, np.asarray(rec.t), {"d": rec.d, "d_dot": rec.d_dot}, x0=x0, on_failure="return")
    if not tr.success:
        return math.inf
    return nrmse(y, tr.y)


def common_x0(model, rec, start: dict) -> np.ndarray:
    """duffsym's data-based initial state (x2 = y/A_f, x1 its drift-free integral) at t = 0."""
    from duffsym.identify import initial_states

    return initial_states(model, rec, model.param_vector(start))[0]


# ---------------------------------------------------------------------------------------------- baseline
class Baseline:
    """scipy least_squares (trf) + solve_ivp (LSODA) single shooting, as a user would write it."""

    def __init__(self, rec, A_f: float, x0, *, max_nfev=None, time_limit=None, rtol=None, atol=None, diff_step=None):
        self.t = np.asarray(rec.t, dtype=float)
        self.d = np.asarray(rec.d, dtype=float)
        self.v = np.asarray(rec.d_dot, dtype=float)
        self.y = np.asarray(rec.y, dtype=float)
        self.A_f = float(A_f)
        self.x0 = [float(v) for v in x0]
        self.max_nfev = max_nfev
        self.time_limit = time_limit
        self.nsim = 0
        self.diff_step = diff_step
        # None: solve_ivp's defaults (rtol 1e-3, atol 1e-6), what a user writes first
        self.tol = {k: v for k, v in (("rtol", rtol), ("atol", atol)) if v is not None}

    def simulate(self, p):
        from scipy.integrate import solve_ivp

        c1, c2, c3, k1, k2 = p
        t, d, v = self.t, self.d, self.v

        def rhs(tt, x):
            dd = np.interp(tt, t, d)
            vd = np.interp(tt, t, v)
            return [x[1], k1 * (dd - x[0]) + c1 * (vd - x[1]) - c2 * x[1] - k2 * x[0] - c3 * x[1] ** 5]

        self.nsim += 1
        with np.errstate(over="ignore", invalid="ignore"):
            sol = solve_ivp(rhs, (t[0], t[-1]), self.x0, method="LSODA", t_eval=t, **self.tol)
        if not sol.success or sol.y.shape[1] != t.size:
            return None
        return self.A_f * sol.y[1]

    def residual(self, p):
        if self.time_limit is not None and time.perf_counter() - self._t0 > self.time_limit:
            raise TimeoutError
        ys = self.simulate(p)
        if ys is None or not np.all(np.isfinite(ys)):
            return np.full(self.t.size, 1e6 * (np.std(self.y) + 1.0))  # what a user does: a big residual
        return ys - self.y

    def fit(self, start: dict) -> dict:
        from scipy.optimize import least_squares

        p0 = np.array([start[k] for k in FREE], dtype=float)
        self.nsim = 0
        self._t0 = time.perf_counter()
        c0 = time.process_time()
        try:
            res = least_squares(self.residual, p0, method="trf", bounds=(0.0, np.inf), max_nfev=self.max_nfev,
                                diff_step=self.diff_step)
            out = {"params": dict(zip(FREE, map(float, res.x))), "converged": bool(res.status > 0),
                   "status": int(res.status), "message": str(res.message), "nfev": int(res.nfev),
                   "njev": int(res.njev or 0), "cost": float(res.cost), "timed_out": False}
        except TimeoutError:
            out = {"params": None, "converged": False, "status": None, "message": "per-start time limit reached",
                   "nfev": None, "njev": None, "cost": None, "timed_out": True}
        out["wall_s"] = time.perf_counter() - self._t0
        out["cpu_s"] = time.process_time() - c0
        out["n_simulations"] = self.nsim
        return out


# ---------------------------------------------------------------------------------------------- part (i)
def duffsym_command() -> list[str]:
    """The installed ``duffsym`` console script (what a user runs), not the pyenv shim."""
    script = Path(sysconfig.get_path("scripts")) / "duffsym"
    return [str(script)] if script.is_file() else [sys.executable, "-c", "import sys; from duffsym.cli import main; "
                                                   "sys.exit(main())"]


def run_cli(csv: Path, extra=()) -> tuple[float, dict, int, str]:
    cmd = [*duffsym_command(), "fit", str(csv), "--json", "--quiet", *extra]
    t0, c0 = time.perf_counter(), children_cpu()
    pr = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    try:
        out = json.loads(pr.stdout)
    except json.JSONDecodeError:
        out = {}
    out["_cpu_s"] = children_cpu() - c0
    return wall, out, pr.returncode, pr.stderr.strip()[-400:]


def children_cpu() -> float:
    """CPU seconds (user + system) used so far by finished child processes."""
    import resource

    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def part_main(args) -> dict:
    from duffsym.identify import Problem, fit, initial_guess

    tmp = Path(tempfile.mkdtemp(prefix="bench_fit_"))
    csv = tmp / "rec1600.csv"
    model, rec = write_record(N_MAIN, csv)
    from duffsym.data import read_csv

    rec = read_csv(csv)  # exactly the data the CLI sees
    A_f = float(np.max(np.abs(rec.y)))
    out: dict = {"record": {"n": N_MAIN, "dt": DT, "frequency_hz": FREQ, "amplitude": 1.0, "noise": NOISE,
                            "seed": SEED, "truth": make_record(N_MAIN)[1].metadata["truth"], "A_f": A_f}}
    # ---- duffsym CLI end to end (first run also warms the file cache / code cache; repeat)
    cli = []
    for _ in range(args.repeat):
        ld = load()
        wall, js, rc, err = run_cli(csv)
        cli.append({"wall_s": wall, "cpu_s": js.get("_cpu_s"), "returncode": rc, "load": ld,
                    "nrmse_reported": js.get("nrmse"),
                    "success": js.get("success"), "n_iter": js.get("n_iter"), "timings": js.get("timings"),
                    "params": js.get("params"), "x0": js.get("x0"), "stderr_tail": err})
        print(f"  duffsym fit CLI: {wall:.2f} s, CPU {js.get('_cpu_s'):.2f} s (rc {rc}, nrmse {js.get('nrmse')}, "
              f"load {ld})",
              flush=True)
    out["cli"] = cli
    # ---- in-process fit, build/solve split
    problem = Problem(model, rec)
    t0 = time.perf_counter()
    start = initial_guess(rec, model, fixed=problem.fixed)
    t_guess = time.perf_counter() - t0
    x0 = common_x0(model, rec, start)
    inproc = []
    for _ in range(args.repeat):
        ld = load()
        t0 = time.perf_counter()
        res = fit(Problem(model, rec), {k: start[k] for k in FREE})
        wall = time.perf_counter() - t0
        inproc.append({"wall_s": wall, "load": ld, "timings": dict(res.timings), "success": res.success,
                       "status": res.status, "n_iter": res.n_iter, "nrmse_reported": res.nrmse})
        print(f"  duffsym fit() in-process: {wall:.2f} s {dict((k, round(v, 3)) for k, v in res.timings.items())}",
              flush=True)
    out["in_process"] = inproc
    out["initial_guess_s"] = t_guess
    print(f"  initial_guess (the CLI's start, inside the CLI time): {t_guess:.2f} s", flush=True)
    out["start"] = {k: float(start[k]) for k in FREE}
    out["x0_common"] = [float(v) for v in x0]
    duff_params = dict(res.params)
    # ---- baseline from the same start
    ld = load()
    bl = Baseline(rec, A_f, x0, time_limit=args.baseline_limit)
    b = bl.fit(start)
    b["load"] = ld
    print(f"  baseline least_squares+LSODA: {b['wall_s']:.1f} s, nfev {b['nfev']}, sims {b['n_simulations']}, "
          f"{b['message']}", flush=True)
    bparams = {**model.defaults(), "A_f": A_f, "k3": 0.0, **(b["params"] or {})}
    out["baseline"] = b
    # the baseline tuned until it leaves its start (see TUNED)
    ld = load()
    bt = Baseline(rec, A_f, x0, time_limit=args.baseline_limit, **TUNED).fit(start)
    bt["load"], bt["tolerances"] = ld, TUNED
    print(f"  baseline, LSODA {TUNED}: {bt['wall_s']:.1f} s, nfev {bt['nfev']}, sims {bt['n_simulations']}, "
          f"{bt['message']}", flush=True)
    out["baseline_tuned"] = bt
    out["nrmse_baseline_tuned"] = (free_run_nrmse(model, rec, {**bparams, **bt["params"]}, x0)
                                   if bt["params"] else math.inf)
    out["ratio_cli_vs_baseline_tuned"] = bt["wall_s"] / min(c["wall_s"] for c in cli)
    out["ratio_inprocess_vs_baseline_tuned"] = bt["wall_s"] / min(c["wall_s"] for c in inproc)
    out["ratio_cli_vs_baseline_tuned_cpu"] = bt["cpu_s"] / min(c["cpu_s"] for c in cli)
    # ---- one solve_ivp simulation (for scale)
    t0 = time.perf_counter()
    for _ in range(5):
        bl.simulate([start[k] for k in FREE])
    out["baseline_one_simulation_s"] = (time.perf_counter() - t0) / 5
    # ---- scores computed the same way
    out["nrmse_duffsym"] = free_run_nrmse(model, rec, duff_params, x0)
    out["nrmse_baseline"] = free_run_nrmse(model, rec, bparams, x0) if b["params"] else math.inf
    out["nrmse_truth"] = free_run_nrmse(model, rec, out["record"]["truth"], x0)
    out["params_duffsym"] = {k: float(duff_params[k]) for k in FREE}
    cli_best = min(c["wall_s"] for c in cli)
    out["ratio_cli_vs_baseline"] = b["wall_s"] / cli_best
    out["ratio_inprocess_vs_baseline"] = b["wall_s"] / min(c["wall_s"] for c in inproc)
    out["load_end"] = load()
    return out


def random_starts(model, rec, n: int) -> list[dict]:
    from duffsym.derive.symmetry import normalize_af
    from duffsym.model.presets import table2_params

    A_f = float(np.max(np.abs(rec.y)))
    mapped = normalize_af(model, table2_params(0.4), A_f)
    rng = np.random.default_rng(SEED + 1)
    starts = []
    for _ in range(n):
        f = np.exp(rng.uniform(-math.log(10), math.log(10), len(FREE)))
        starts.append({k: float(mapped[k] * fk) for k, fk in zip(FREE, f)})
    return starts, {k: float(mapped[k]) for k in model.param_names}


def part_starts(args) -> dict:
    from duffsym.identify import Problem, fit

    model, rec = make_record(N_MAIN)
    tmp = Path(tempfile.mkdtemp(prefix="bench_fit_"))
    from duffsym.data import read_csv, write_csv

    write_csv(rec, tmp / "r.csv")
    rec = read_csv(tmp / "r.csv")
    A_f = float(np.max(np.abs(rec.y)))
    starts, mapped = random_starts(model, rec, args.n_starts)
    x0 = common_x0(model, rec, mapped)
    out = {"n_starts": args.n_starts, "seed": SEED + 1, "truth_mapped": mapped, "starts": starts,
           "x0_common": [float(v) for v in x0], "duffsym": [], "baseline": [],
           "baseline_cap": {"max_nfev": args.max_nfev, "time_limit_s": args.baseline_limit,
                            "n_starts_run": min(args.n_starts, args.baseline_starts),
                            "n_starts_run_tuned": min(args.n_starts, args.tuned_starts)},
           "tuned": TUNED}
    for i, st in enumerate(starts):
        ld = load()
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = fit(Problem(model, rec), st, compute_stderr=False)
        wall = time.perf_counter() - t0
        nr = free_run_nrmse(model, rec, dict(res.params), x0)
        out["duffsym"].append({"converged": bool(res.success), "status": res.status, "n_iter": res.n_iter,
                               "wall_s": wall, "nrmse": nr, "load": ld,
                               "params": {k: float(res.params[k]) for k in FREE}})
        print(f"  duffsym start {i:2d}: {res.status:>22s} nrmse {nr:.5f} {wall:.2f} s", flush=True)
    variants = (("baseline", {}, args.baseline_starts), ("baseline_tuned", TUNED, args.tuned_starts))
    for key, opts, k in variants:
        out[key] = []
        for i, st in enumerate(starts[:k]):
            ld = load()
            b = Baseline(rec, A_f, x0, max_nfev=args.max_nfev, time_limit=args.baseline_limit, **opts).fit(st)
            b["load"] = ld
            b["nrmse"] = (free_run_nrmse(model, rec, {**mapped, "k3": 0.0, "A_f": A_f, **b["params"]}, x0)
                          if b["params"] else math.inf)
            out[key].append(b)
            print(f"  {key} start {i:2d}: conv {b['converged']} nrmse {b['nrmse']:.5f} nfev {b['nfev']} "
                  f"{b['wall_s']:.1f} s {b['message'][:60]}", flush=True)
    best = min([r["nrmse"] for r in out["duffsym"] + out["baseline"] + out["baseline_tuned"]])
    for key in ("duffsym", "baseline", "baseline_tuned"):
        runs = out[key]
        ok = [r["converged"] and r["nrmse"] <= 1.05 * best for r in runs]
        for r, s in zip(runs, ok):
            r["success"] = bool(s)
        out[f"success_{key}"] = f"{sum(ok)}/{len(runs)}"
        out[f"success_rate_{key}"] = sum(ok) / len(runs) if runs else math.nan
    out["best_nrmse"] = best
    out["load_end"] = load()
    return out


# ---------------------------------------------------------------------------------------------- part (ii)
_WRAP = r"""
import json, resource, subprocess, sys, time
t0 = time.perf_counter()
pr = subprocess.run(sys.argv[1:], capture_output=True, text=True, timeout=float({timeout}))
wall = time.perf_counter() - t0
ru = resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({{"wall_s": wall, "cpu_s": ru.ru_utime + ru.ru_stime, "maxrss_kb": ru.ru_maxrss, "returncode": pr.returncode,
                  "stdout": pr.stdout, "stderr": pr.stderr[-400:]}}))
"""


def part_sweep(args) -> dict:
    tmp = Path(tempfile.mkdtemp(prefix="bench_fit_"))
    rows = []
    note = ""
    for n in args.sizes:
        if rows and rows[-1].get("wall_s"):
            prev = rows[-1]
            grow = n / prev["n"]
            pred_t, pred_gb = prev["wall_s"] * grow, prev["peak_rss_gb"] * grow
            if pred_t > MAX_SECONDS * 1.5 or pred_gb > MAX_RSS_GB:
                note = (f"stopped before n = {n}: linear extrapolation from n = {prev['n']} predicts "
                        f"{pred_t:.0f} s and {pred_gb:.1f} GB")
                print("  " + note, flush=True)
                break
        csv = tmp / f"rec{n}.csv"
        write_record(n, csv)
        ld = load()
        cmd = [sys.executable, "-c", _WRAP.format(timeout=args.sweep_timeout), *duffsym_command(),
               "fit", str(csv), "--json", "--quiet"]
        try:
            pr = subprocess.run(cmd, capture_output=True, text=True, timeout=args.sweep_timeout + 60)
            w = json.loads(pr.stdout)
        except (subprocess.TimeoutExpired, json.JSONDecodeError) as exc:
            rows.append({"n": n, "error": f"{type(exc).__name__}: timed out or failed", "load": ld})
            note = f"n = {n} did not finish within {args.sweep_timeout} s"
            print("  " + note, flush=True)
            break
        try:
            js = json.loads(w["stdout"])
        except json.JSONDecodeError:
            js = {}
        row = {"n": n, "wall_s": w["wall_s"], "cpu_s": w.get("cpu_s"), "peak_rss_gb": w["maxrss_kb"] / 1024**2, "returncode": w["returncode"],
               "load": ld, "load_after": load(), "success": js.get("success"), "status": js.get("status"),
               "n_iter": js.get("n_iter"), "nrmse": js.get("nrmse"), "timings": js.get("timings"),
               "stderr_tail": w["stderr"]}
        rows.append(row)
        tm = row["timings"] or {}
        print(f"  n = {n:6d}: {row['wall_s']:7.2f} s (CPU {row['cpu_s']:.2f} s), peak RSS {row['peak_rss_gb']:.2f} GB, build "
              f"{tm.get('build', float('nan')):.2f} s, solve {tm.get('solve', float('nan')):.2f} s, "
              f"iter {row['n_iter']}, nrmse {row['nrmse']}, load {ld}", flush=True)
    return {"rows": rows, "note": note, "growth": growth(rows), "limits": {"seconds": MAX_SECONDS, "rss_gb": MAX_RSS_GB}}


def growth(rows: list[dict]) -> dict:
    """Local growth exponents between consecutive sizes: log(q_b / q_a) / log(n_b / n_a) (1 = linear)."""
    ok = [r for r in rows if r.get("wall_s")]
    out = {}
    for key in ("wall_s", "cpu_s", "build", "solve", "peak_rss_gb"):
        vals = []
        for a, b in zip(ok[:-1], ok[1:]):
            qa = a.get(key, (a.get("timings") or {}).get(key))
            qb = b.get(key, (b.get("timings") or {}).get(key))
            if qa and qb:
                vals.append(round(math.log(qb / qa) / math.log(b["n"] / a["n"]), 3))
        out[key] = vals
    out["pairs"] = [f"{a['n']}->{b['n']}" for a, b in zip(ok[:-1], ok[1:])]
    return out


# ---------------------------------------------------------------------------------------------- report
def merge() -> dict:
    out = {"benchmark": "bench_fit", "machine": machine(), "load_at_merge": load()}
    for part in ("main", "starts", "sweep", "sweep_100k", "main_load4", "starts_rerun"):  # optional re-runs
        p = RESULTS / f"fit_{part}.json"
        if p.is_file():
            out[part] = json.loads(p.read_text())
    if "sweep" in out:
        out["sweep"]["growth"] = growth(out["sweep"]["rows"])
    (RESULTS / "fit.json").write_text(json.dumps(out, indent=1, default=float) + "\n")
    print_table(out)
    return out


def print_table(out: dict) -> None:
    m = out.get("main")
    if m:
        cli = min(c["wall_s"] for c in m["cli"])
        ip = min(m["in_process"], key=lambda c: c["wall_s"])
        b = m["baseline"]
        print(f"\n(i) {m['record']['n']}-sample record, Table 2 0.4 V, 2 % noise  (nproc {out['machine']['nproc']})")
        print(f"  {'method':44s} {'wall s':>8s} {'free-run NRMSE':>15s}")
        cli_cpu = [c.get("cpu_s") for c in m["cli"] if c.get("cpu_s") is not None]
        print(f"  {'duffsym fit (CLI, end to end, best of %d)' % len(m['cli']):44s} {cli:8.2f} "
              f"{m['nrmse_duffsym']:15.5f}" + (f"   (CPU {min(cli_cpu):.2f} s)" if cli_cpu else ""))
        print(f"  {'duffsym fit() in process: build / solve':44s} {ip['wall_s']:8.2f}   "
              f"({ip['timings']['build']:.2f} / {ip['timings']['solve']:.2f})")
        print(f"  {'scipy least_squares + solve_ivp LSODA':44s} {b['wall_s']:8.2f} {m['nrmse_baseline']:15.5f}"
              f"   (nfev {b['nfev']}, {b['n_simulations']} simulations)")
        bt = m.get("baseline_tuned")
        if bt:
            print(f"  {'  same, LSODA rtol 1e-6 atol 1e-9, diff_step 1e-3':44s} {bt['wall_s']:8.2f} {m['nrmse_baseline_tuned']:15.5f}"
                  f"   (nfev {bt['nfev']}, {bt['n_simulations']} simulations"
                  + (f", CPU {bt['cpu_s']:.2f} s)" if "cpu_s" in bt else ")"))
        print(f"  {'truth (free run)':44s} {'':8s} {m['nrmse_truth']:15.5f}")
        ip_best = min(c["wall_s"] for c in m["in_process"])
        if bt:
            print(f"  speed-up at equal NRMSE (tuned baseline): CLI end to end {bt['wall_s'] / cli:.1f}x, "
                  f"in-process fit() {bt['wall_s'] / ip_best:.1f}x  (target >= 20x)")
            if cli_cpu and "cpu_s" in bt:
                print(f"  same in CPU time (less sensitive to the machine's load): CLI {bt['cpu_s'] / min(cli_cpu):.1f}x")
        print(f"  vs the default baseline (stops at its start, NRMSE {m['nrmse_baseline']:.4f}): CLI "
              f"{m['ratio_cli_vs_baseline']:.2f}x, in-process {m['ratio_inprocess_vs_baseline']:.2f}x")
        print(f"  load average during (i): {m['cli'][0]['load']} ... {m['load_end']}")
    s = out.get("starts")
    if s:
        cap = s["baseline_cap"]
        print(f"\n  random starts (factor 10 around the mapped truth, seed {s['seed']}; success = converged and "
              f"NRMSE <= 1.05 x best {s['best_nrmse']:.5f}):")
        print(f"    duffsym {s['success_duffsym']}, baseline {s['success_baseline']}, tuned baseline "
              f"{s['success_baseline_tuned']} (baselines capped at max_nfev {cap['max_nfev']} and "
              f"{cap['time_limit_s']:g} s per start)")
        rr = out.get("starts_rerun")
        if rr:
            walls = sorted(r["wall_s"] for r in rr["duffsym"])
            print(f"    re-run of the duffsym starts with the current code: {rr['success_duffsym']} (success judged "
                  f"against its own best NRMSE {rr['best_nrmse']:.5f}), {walls[0]:.2f}-{walls[-1]:.2f} s each, "
                  f"load {rr['duffsym'][0]['load']}")
    w = out.get("sweep")
    if w:
        print("\n(ii) duffsym fit (CLI, fresh process) vs record length")
        print(f"  {'N':>7s} {'wall s':>8s} {'CPU s':>8s} {'build s':>8s} {'solve s':>8s} {'iter':>5s} {'peak GB':>8s} {'load':>16s}")
        for r in w["rows"]:
            if not r.get("wall_s"):
                print(f"  {r['n']:7d} {r.get('error')}")
                continue
            tm = r["timings"] or {}
            print(f"  {r['n']:7d} {r['wall_s']:8.2f} {r.get('cpu_s') or math.nan:8.2f} {tm.get('build', math.nan):8.2f} {tm.get('solve', math.nan):8.2f} "
                  f"{r['n_iter'] or 0:5d} {r['peak_rss_gb']:8.2f} {str(r['load']):>16s}")
        if w["note"]:
            print("  " + w["note"])
        for r in (out.get("sweep_100k") or {}).get("rows", []):
            if r.get("wall_s"):
                print(f"  re-run of n = {r['n']} alone: {r['wall_s']:.2f} s (build {r['timings']['build']:.2f}, solve "
                      f"{r['timings']['solve']:.2f}), peak {r['peak_rss_gb']:.2f} GB, load {r['load']}")
        g = growth(w["rows"])
        w["growth"] = g
        print(f"  growth exponents between consecutive sizes ({', '.join(g['pairs'])}; 1 = linear):")
        for key in ("wall_s", "cpu_s", "build", "solve", "peak_rss_gb"):
            print(f"    {key:12s} " + "  ".join(f"{v:5.2f}" for v in g[key]))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--part", choices=("all", "main", "starts", "sweep", "merge"), default="all")
    ap.add_argument("--repeat", type=int, default=3, help="repeats of the duffsym timings (best reported)")
    ap.add_argument("--n-starts", type=int, default=20)
    ap.add_argument("--baseline-starts", type=int, default=20, help="run the baseline on the first K starts only")
    ap.add_argument("--tuned-starts", type=int, default=8, help="run the tuned baseline on the first K starts only")
    ap.add_argument("--max-nfev", type=int, default=200, help="baseline cap on residual evaluations per start")
    ap.add_argument("--baseline-limit", type=float, default=120.0, help="baseline wall-time cap per start, s")
    ap.add_argument("--sizes", type=lambda s: [int(v) for v in s.split(",")], default=list(SIZES))
    ap.add_argument("--sweep-timeout", type=float, default=400.0)
    ap.add_argument("--tag", default="", help="write results/fit_<part>_<tag>.json (a partial re-run, kept beside "
                    "the full part; merge reads the tag 'rerun')")
    args = ap.parse_args(argv)
    RESULTS.mkdir(exist_ok=True)
    parts = ("main", "starts", "sweep") if args.part == "all" else (() if args.part == "merge" else (args.part,))
    for part in parts:
        print(f"[{part}] load {load()}", flush=True)
        res = {"main": part_main, "starts": part_starts, "sweep": part_sweep}[part](args)
        res["machine"] = machine()
        name = f"fit_{part}_{args.tag}.json" if args.tag else f"fit_{part}.json"
        (RESULTS / name).write_text(json.dumps(stamp(res, args), indent=1, default=float) + "\n")
    merge()
    return 0


if __name__ == "__main__":
    sys.exit(main())
