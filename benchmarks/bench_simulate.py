"""Benchmark: duffsym's compiled simulator vs scipy's solve_ivp on the paper's Table 2 trajectory.

Run from the repository root::

    python benchmarks/bench_simulate.py            # all Table 2 rows (about 2 minutes)
    python benchmarks/bench_simulate.py --quick    # 0.4 V and two other rows, fewer repeats

It prints a table and writes ``benchmarks/results/simulate.json``. See ``benchmarks/README.md``.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import duffsym
from duffsym.excitation import Sine
from duffsym.model.library import mr_damper
from duffsym.model.presets import TABLE2, TABLE2_DT, TABLE2_FREQUENCY_HZ, TABLE2_N, table2_params
from duffsym.simulate import H_LAMBDA, input_matrix, simulate, simulate_batch

HERE = Path(__file__).resolve().parent
N_SAMPLES = 400
AMPLITUDE = 1.0
REFERENCE_TOL = dict(rtol=1e-10, atol=1e-12)
TARGET_ERROR = 1e-3


def max_rel_error(y, ref) -> float:
    """max |y - y_ref| / max |y_ref| over the trajectory."""
    return float(np.max(np.abs(np.asarray(y) - ref)) / np.max(np.abs(ref)))


def per_call(fn, *, number, repeat) -> float:
    """Median wall time of one call, s (after one warm-up call)."""
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        times.append((time.perf_counter() - t0) / number)
    return statistics.median(times)


def scipy_user_solver(params, t, U, method, rtol, atol):
    """What a user writes with scipy: a Python rhs of Eq. 12 (n = 5) interpolating the sampled input."""
    from scipy.integrate import solve_ivp

    c1, c2, c3, k1, k2, k3, A_f = (params[k] for k in ("c1", "c2", "c3", "k1", "k2", "k3", "A_f"))
    d, d_dot = U[:, 0], U[:, 1]

    def rhs(tt, x):
        dd = np.interp(tt, t, d)
        vd = np.interp(tt, t, d_dot)
        return [x[1], k1 * (dd - x[0]) + c1 * (vd - x[1]) - c2 * x[1] - k2 * x[0] - k3 * x[0] ** 5 - c3 * x[1] ** 5]

    def run():
        with np.errstate(over="ignore", invalid="ignore"):  # loose tolerances may overflow on the way
            sol = solve_ivp(rhs, (t[0], t[-1]), [0.0, 0.0], method=method, t_eval=t, rtol=rtol, atol=atol)
        if not sol.success or sol.y.shape[1] != t.size:
            return np.full(t.size, np.nan), sol.nfev
        return A_f * sol.y[1], sol.nfev

    return run


def first_call_times() -> dict:
    """Time of the first simulate() in a fresh process: with an empty code cache (generate +
    compile) and again with the cache filled (load)."""
    code = (
        "import time, numpy as np; t0 = time.perf_counter();"
        "from duffsym.model.library import mr_damper; from duffsym.simulate import simulate;"
        "from duffsym.excitation import Sine; m = mr_damper(5); t1 = time.perf_counter();"
        "simulate(m, m.defaults(), np.arange(400) * 0.005, Sine(1.0, 2.0)); t2 = time.perf_counter();"
        "print(t1 - t0, t2 - t1)"
    )
    out = {}
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "DUFFSYM_CACHE": cache}
        for label in ("empty cache (generate + compile)", "filled cache (load)"):
            res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
            imp, first = map(float, res.stdout.split())
            out[label] = {"import_s": imp, "first_simulate_s": first}
    return out


def tune_tolerance(make, ref, target) -> tuple[float, float]:
    """Loosest rtol (atol = rtol / 100) on a decade-and-a-half grid whose error is <= target."""
    for rtol in (1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 3e-7, 1e-7, 3e-8, 1e-8):
        y, _ = make(rtol, rtol / 100)()
        if np.all(np.isfinite(y)) and max_rel_error(y, ref) <= target:
            return rtol, rtol / 100
    raise RuntimeError("no tolerance on the grid reached the target error")


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="three Table 2 rows and fewer repeats")
    ap.add_argument("--out", type=Path, default=HERE / "results" / "simulate.json")
    args = ap.parse_args(argv)
    # 0.4 V first: scipy's tolerances are tuned on it and then used for every row
    rows = (0.4, 0.0, 0.8) if args.quick else (0.4,) + tuple(sorted(set(TABLE2) - {0.4}))
    number, repeat, scipy_repeat = (100, 5, 3) if args.quick else (300, 7, 5)

    model = mr_damper(TABLE2_N)
    t = np.arange(N_SAMPLES) * TABLE2_DT
    exc = Sine(AMPLITUDE, TABLE2_FREQUENCY_HZ)
    U = input_matrix(model, t, exc)

    print("first-call times (fresh processes) ...", flush=True)
    first = first_call_times()

    results = []
    tuned = {}
    for v in rows:
        params = table2_params(v)
        p = model.param_vector(params)
        t0 = time.perf_counter()
        ref = simulate(model, params, t, exc, method="radau", **REFERENCE_TOL).y
        radau_s = time.perf_counter() - t0
        row = {"voltage": v, "radau_reference_s": radau_s, "methods": {}}

        def record(name, fn, y, extra=None, number=number, repeat=repeat):
            sec = per_call(fn, number=number, repeat=repeat)
            row["methods"][name] = {"time_s": sec, "max_rel_error": max_rel_error(y, ref), **(extra or {})}

        for label, sub in (("simulate auto", "auto"), ("simulate substeps=2", 2), ("simulate substeps=4", 4)):
            tr = simulate(model, params, t, exc, substeps=sub)
            record(label, lambda sub=sub: simulate(model, params, t, exc, substeps=sub), tr.y,
                   {"total_substeps": int(tr.substeps.sum())})
        # the compiled integrator alone (no input sampling, checks or result object)
        from duffsym.codegen.compiled import compiled_module

        mod = compiled_module(model)
        X, Y, M = np.empty((t.size, 2)), np.empty(t.size), np.zeros(t.size - 1, dtype=np.int64)
        x0 = np.zeros(2)
        raw = lambda: mod.integrate(t, U, x0, p, 0, H_LAMBDA, 5000, False, 1e8, X, Y, M)  # noqa: E731
        raw()
        record("compiled integrate auto (no wrapper)", raw, Y.copy())

        for method in ("RK45", "LSODA"):
            make = lambda rtol, atol, method=method: scipy_user_solver(params, t, U, method, rtol, atol)  # noqa: E731
            run = make(1e-3, 1e-6)
            y, nfev = run()
            record(f"solve_ivp {method} default tol", run, y, {"rtol": 1e-3, "atol": 1e-6, "nfev": int(nfev)},
                   number=1, repeat=scipy_repeat)
            if method not in tuned:
                # tolerances tuned on the 0.4 V row to reach the error of simulate auto
                target = row["methods"]["simulate auto"]["max_rel_error"]
                tuned[method] = tune_tolerance(make, ref, target)
            rtol, atol = tuned[method]
            run = make(rtol, atol)
            y, nfev = run()
            record(f"solve_ivp {method} tuned tol", run, y, {"rtol": rtol, "atol": atol, "nfev": int(nfev)},
                   number=1, repeat=scipy_repeat)
        results.append(row)
        auto = row["methods"]["simulate auto"]
        print(f"{v:.1f} V: simulate auto {auto['time_s'] * 1e6:.0f} us, err {auto['max_rel_error']:.1e}; "
              f"LSODA tuned {row['methods']['solve_ivp LSODA tuned tol']['time_s'] * 1e3:.1f} ms", flush=True)

    # batch: 1000 parameter sets around the 0.4 V row (+-10 %), vs a loop of simulate()
    rng = np.random.default_rng(0)
    P = model.param_vector(table2_params(0.4)) * rng.uniform(0.9, 1.1, (1000, model.n_params))
    batch = simulate_batch(model, P, t, exc)
    batch_s = per_call(lambda: simulate_batch(model, P, t, exc), number=1, repeat=repeat)
    loop_s = per_call(lambda: [simulate(model, q, t, exc) for q in P[:200]], number=1, repeat=3) * 5
    batch_info = {"n_sets": 1000, "time_s": batch_s, "per_set_s": batch_s / 1000, "loop_of_simulate_s": loop_s,
                  "n_ok": int(batch.success.sum()), "total_substeps_mean": float(batch.total_substeps.mean()),
                  "threads": _numba_threads()}

    summary = _summarize(results, batch_info, first)
    info = {
        "benchmark": "Table 2 trajectory: mr-damper n=5, 400 samples, dt 0.005 s, 2 Hz sine of unit amplitude, "
                     "from rest; error = max|y - y_ref| / max|y_ref| vs Radau (rtol 1e-10, atol 1e-12) with the "
                     "same linear input reconstruction; times = median of repeats after a warm-up call",
        "machine": {"platform": platform.platform(), "processor": platform.processor(), "cpu_count": os.cpu_count(),
                    "python": platform.python_version()},
        "versions": _versions(),
        "git": _git_sha(),
        "first_call": first,
        "rows": results,
        "batch": batch_info,
        "summary": summary,
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(info, indent=2))
    _print_table(results, batch_info, first, summary)
    print(f"\nwrote {args.out}")
    return info


def _summarize(results, batch_info, first):
    def med(name, key="time_s"):
        return statistics.median(r["methods"][name][key] for r in results)

    def worst(name):
        return max(r["methods"][name]["max_rel_error"] for r in results)

    auto = med("simulate auto")
    out = {"median_time_s": {}, "worst_error": {}, "speedup_of_simulate_auto": {}}
    for name in results[0]["methods"]:
        out["median_time_s"][name] = med(name)
        out["worst_error"][name] = worst(name)
        out["speedup_of_simulate_auto"][name] = med(name) / auto
    out["meets_target"] = bool(worst("simulate auto") <= TARGET_ERROR
                               and out["speedup_of_simulate_auto"]["solve_ivp LSODA tuned tol"] >= 100)
    return out


def _print_table(results, batch_info, first, summary):
    names = list(results[0]["methods"])
    volts = ", ".join(f"{r['voltage']:g} V" for r in results)
    print(f"\nTable 2 trajectory (400 samples, 2 Hz, unit amplitude, from rest); rows: {volts}")
    print(f"{'method':42s} {'median time':>12s} {'worst err':>10s} {'x slower than auto':>19s}")
    for name in names:
        sec = summary["median_time_s"][name]
        tstr = f"{sec * 1e6:.0f} us" if sec < 1e-3 else f"{sec * 1e3:.1f} ms"
        print(f"{name:42s} {tstr:>12s} {summary['worst_error'][name]:10.1e} "
              f"{summary['speedup_of_simulate_auto'][name]:19.1f}")
    tuned = results[0]["methods"]
    print(f"tuned tolerances: RK45 rtol {tuned['solve_ivp RK45 tuned tol']['rtol']:g}, "
          f"LSODA rtol {tuned['solve_ivp LSODA tuned tol']['rtol']:g} (atol = rtol/100)")
    print(f"simulate_batch, {batch_info['n_sets']} sets (+-10 % around 0.4 V, {batch_info['threads']} threads): "
          f"{batch_info['time_s'] * 1e3:.1f} ms ({batch_info['per_set_s'] * 1e6:.0f} us/set); "
          f"loop of simulate(): {batch_info['loop_of_simulate_s'] * 1e3:.0f} ms; ok {batch_info['n_ok']}")
    for label, v in first.items():
        print(f"first simulate() in a new process, {label}: {v['first_simulate_s']:.2f} s "
              f"(import {v['import_s']:.2f} s)")
    print(f"target (>= 100x faster than tuned LSODA at <= 1e-3 error): "
          f"{'met' if summary['meets_target'] else 'NOT met'}")


def _numba_threads():
    import numba

    return int(numba.get_num_threads())


def _versions():
    import numba
    import scipy

    return {"duffsym": getattr(duffsym, "__version__", "?"), "numpy": np.__version__, "scipy": scipy.__version__,
            "numba": numba.__version__}


def _git_sha():
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              cwd=HERE, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


if __name__ == "__main__":
    main()
