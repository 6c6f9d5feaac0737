"""Benchmark: the stiff free-run path (compiled implicit ROS2, the fallback of ``method="auto"``) against
the explicit RK4 path and scipy's Radau, on a non-stiff record and on the real Dyke record.

Run from the repository root (the Dyke part needs the external data, ``DUFFSYM_EXTERNAL_DATA``)::

    python benchmarks/bench_stiff.py            # 5-10 minutes (Radau on 15 000 samples dominates)
    python benchmarks/bench_stiff.py --quick    # Dyke on its first 3 000 samples

It prints a table and writes ``benchmarks/results/stiff.json``. Times are medians of repeated calls after
a warm-up, all taken in the same process, so the ratios are comparable even on a busy machine.
"""
from __future__ import annotations

import argparse
import csv
import json
import statistics
import time
from pathlib import Path

import numpy as np

from duffsym.data import external_data_dir, read_csv
from duffsym.model.library import mr_damper
from duffsym.simulate import IMPLICIT_ATOL, IMPLICIT_RTOL, simulate
from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
FS = 3004.8
# the fit of the base model to Dyke samples 30 000-45 000 (displacement only) whose free run main
# reported "too stiff ... probably diverging" at sample 0 (tests/test_simulate_stiff.py)
DYKE_PARAMS = {"c1": 105.54754844447353, "c2": 516.0838990034977, "c3": 57301.30922766054,
               "k1": 76.61471716713335, "k2": 46.642636473388485, "k3": 0.0, "A_f": 1863.1959}
DYKE_X0 = [0.42873573695978767, -0.24877170783700148]
SYNTH_PARAMS = {"A_f": 1.6, "c1": 10.0, "c2": 10.0, "c3": 320.0, "k1": 34.0, "k2": 480.0, "k3": 0.0}


def _timed(fn, repeats: int) -> float:
    fn()
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return statistics.median(out)


def _dyke(folder: Path):
    """Dyke samples 30 000-45 000 as the fit saw them (velocity derived from the displacement)."""
    src = external_data_dir() / "mr_damper_dyke_nees1996" / "ranran_50_converted.csv"
    rows = [r for r in csv.reader(open(src)) if r][1:][30_000:45_000]
    p = folder / "dyke_30000.csv"
    p.write_text("time,displacement,force\n" + "".join(f"{(30_000 + k) / FS!r},{r[2]},{r[6]}\n"
                                                      for k, r in enumerate(rows)))
    return read_csv(p)


def compare(name, model, params, rec, x0, repeats, n=None):
    n = rec.n_times if n is None else n
    U = rec.input_matrix(model)[:n]
    t = np.asarray(rec.t)[:n]
    rec = rec.slice(0, n)
    t0 = time.perf_counter()
    ref = simulate(model, params, t, U, x0=x0, method="radau", rtol=1e-10, atol=1e-12)
    radau_s = time.perf_counter() - t0
    scale = float(np.std(rec.y))
    rows = {"radau": {"seconds": radau_s, "err": 0.0}}
    for m in ("auto", "rk4", "rosenbrock"):
        tr = simulate(model, params, t, U, x0=x0, method=m, on_failure="return")
        sec = _timed(lambda: simulate(model, params, t, U, x0=x0, method=m, on_failure="return"), repeats)
        rows[m] = {"seconds": sec, "ran": tr.method, "status": tr.status,
                   "err": float(np.max(np.abs(tr.y - ref.y)) / scale) if tr.success else None,
                   "steps": int(tr.substeps.sum())}
    base = rows["rk4"]["seconds"]
    print(f"\n{name}: {rec.n_times} samples; error = max|y - y_Radau| / std(y)")
    print(f"{'method':<12}{'ran':<12}{'status':<10}{'time':>12}{'x RK4':>9}{'error':>10}{'steps':>10}")
    for m, r in rows.items():
        err = "-" if r["err"] is None else f"{r['err']:.1e}"
        print(f"{m:<12}{r.get('ran', 'radau'):<12}{r.get('status', 'ok'):<10}{r['seconds'] * 1e3:>10.2f}ms"
              f"{r['seconds'] / base:>9.1f}{err:>10}{r.get('steps', 0):>10}")
    return {"record": name, "n_samples": rec.n_times, "methods": rows,
            "rosenbrock_over_rk4": rows["rosenbrock"]["seconds"] / base}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    import tempfile

    model = mr_damper(5)
    out = {"implicit_rtol": IMPLICIT_RTOL, "implicit_atol": IMPLICIT_ATOL,
           "note": "2-core machine shared with other work; ratios are from the same run"}
    synth = read_csv(ROOT / "data" / "synthetic_random.csv")
    out["nonstiff"] = compare("synthetic_random (Table 2 0.4 V, band-limited random, dt 5 ms)", model,
                              SYNTH_PARAMS, synth, None, 50)
    try:
        with tempfile.TemporaryDirectory() as d:
            rec = _dyke(Path(d))
            out["dyke"] = compare("Dyke samples 30000.. (fit of the base model)", model, DYKE_PARAMS, rec, DYKE_X0,
                                  3 if args.quick else 5, n=3000 if args.quick else 15_000)
    except Exception as exc:  # noqa: BLE001 - the external record is optional here
        print(f"Dyke record skipped: {exc}")
    (HERE / "results").mkdir(exist_ok=True)
    (HERE / "results" / "stiff.json").write_text(json.dumps(stamp(out, args), indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
