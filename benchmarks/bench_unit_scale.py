"""The same record in other units: `fit` (library and CLI) at input/output scales 1e-12 ... 1e6, the main
branch's code against this one, in one run (issue 24).

The record comes from the independent simulator (tests/independent_sim.py, no duffsym import): the paper's
Table 2 damper at 0.4 V under a 6-line multisine (0.5-4 Hz), 401 samples at 100 Hz, 1 % noise. Each scale
multiplies the input, the output or both; the fit is the default one (``fit(Problem(mr-damper, record))``:
A_f = max|y|, k3 = 0). Two factors that are not powers of 1000 (25.4: mm -> inch; 1e-5) show what the
normalisation by powers of 1000 leaves. The CLI (``python -m duffsym.cli fit --json``) runs on three of them.
When the shared data is there, ``duffing-gain`` (output = the state: the states scale with the output) is fitted to
1500 Silverbox samples at four scales too (api "fit silverbox duffing-gain").

    python benchmarks/bench_unit_scale.py                 # before = `git archive main` in a temporary folder
    python benchmarks/bench_unit_scale.py --before /path/to/checkout

Writes benchmarks/results/unit_scale.json (NRMSE, success, status, iterations, seconds per case and code).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)

ROOT = Path(__file__).resolve().parents[1]
FACTORS = (1e-12, 1e-6, 1.0, 1e3, 1e6)
CASES = (
    [("both", f, f) for f in FACTORS]
    + [("input", f, 1.0) for f in FACTORS if f != 1.0]
    + [("output", 1.0, f) for f in FACTORS if f != 1.0]
    + [("both", 25.4, 25.4), ("both", 1e-5, 1e-5)]
)
SILVERBOX_CASES = [("both", 1.0, 1.0), ("both", 1e-6, 1e-6), ("input", 1e6, 1.0), ("output", 1.0, 1e-6)]
CLI_CASES = [("both", 1.0, 1.0), ("both", 1e-12, 1e-12), ("input", 1e6, 1.0)]


def _generated():
    from independent_sim import Physics, generate, make_input, table2

    inp = make_input("multisine", np.random.default_rng(3))
    return generate(table2(0.4), Physics(), inp, dt=0.01, duration=4.0, noise=0.01, rng=1)


def worker(out: Path, tmp: Path) -> None:
    """Every case fitted with the code on PYTHONPATH; one JSON line per case to ``out``."""
    from duffsym.data.record import Record
    from duffsym.identify import Problem, fit
    from duffsym.model.library import get_model

    g = _generated()
    model = get_model("mr-damper", 5)
    fit(Problem(model, Record(t=g.t, d=g.d, y=g.y)))  # the compile, out of the timings
    rows = []
    for which, a, b in CASES:
        rec = Record(t=g.t, d=g.d * a, y=g.y * b, name="scaled")
        tic = time.perf_counter()
        try:
            r = fit(Problem(model, rec))
            row = {"nrmse": r.nrmse, "success": bool(r.success), "status": str(r.status), "n_iter": r.n_iter}
        except (ValueError, ArithmeticError) as e:  # an error is a result here (duffsym's errors are ValueErrors)
            row = {"nrmse": None, "success": False, "status": f"error: {type(e).__name__}: {e}"[:200], "n_iter": 0}
        rows.append({"api": "fit", "scaled": which, "a": a, "b": b, "seconds": time.perf_counter() - tic, **row})
    rows += _silverbox_rows()
    for which, a, b in CLI_CASES:
        path = tmp / f"rec_{which}_{a:g}_{b:g}.csv"
        np.savetxt(path, np.c_[g.t, g.d * a, g.y * b], delimiter=",", header="time,displacement,force", comments="",
                   fmt="%.17g")
        tic = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "duffsym.cli", "fit", str(path), "--json", "--quiet"],
                              capture_output=True, text=True)
        try:
            d = json.loads(proc.stdout)
            row = {"nrmse": d["nrmse"], "success": d["success"], "status": d["status"], "n_iter": d.get("n_iter")}
        except (ValueError, KeyError):
            row = {"nrmse": None, "success": False, "status": f"exit {proc.returncode}: {proc.stderr[-200:]}",
                   "n_iter": 0}
        rows.append({"api": "cli", "scaled": which, "a": a, "b": b, "seconds": time.perf_counter() - tic, **row})
    out.write_text("\n".join(json.dumps(r) for r in rows))


def _silverbox_rows() -> list[dict]:
    """duffing-gain on 1500 samples of the Silverbox (SNLS80mV.csv from sample 40000) at a few scales, if present."""
    from duffsym.data.loaders import external_data_dir, load_silverbox
    from duffsym.errors import DataError
    from duffsym.identify import Problem, fit
    from duffsym.model.library import get_model

    try:
        rec0 = load_silverbox(external_data_dir() / "silverbox" / "SNLS80mV.csv")
    except (DataError, OSError):
        return []
    sl = slice(40000, 41500)
    rows = []
    for which, a, b in SILVERBOX_CASES:
        rec = rec0.replace(t=np.asarray(rec0.t)[sl], d=np.asarray(rec0.d)[sl] * a, y=np.asarray(rec0.y)[sl] * b,
                           d_dot=None)
        tic = time.perf_counter()
        r = fit(Problem(get_model("duffing-gain"), rec))
        rows.append({"api": "fit silverbox duffing-gain", "scaled": which, "a": a, "b": b, "nrmse": r.nrmse,
                     "success": bool(r.success), "status": str(r.status), "n_iter": r.n_iter,
                     "seconds": time.perf_counter() - tic})
    return rows


def run(code_src: Path) -> list[dict]:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "rows.jsonl"
        env = {**os.environ, "PYTHONPATH": f"{code_src}{os.pathsep}{ROOT / 'tests'}", "OMP_NUM_THREADS": "1",
               "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
        proc = subprocess.run([sys.executable, __file__, "--worker", str(out), "--tmp", tmp], env=env,
                              capture_output=True, text=True)
        if proc.returncode != 0:
            raise SystemExit(f"worker with {code_src} failed: {proc.stderr[-2000:]}")
        return [json.loads(x) for x in out.read_text().splitlines()]


def _main_export(tmp: Path) -> Path:
    """The main branch's code, exported (no checkout or worktree is touched)."""
    dest = tmp / "main"
    dest.mkdir()
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", "main"], capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    return dest


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", type=Path, help="a checkout of the code before (default: git archive main)")
    ap.add_argument("--worker", type=Path)
    ap.add_argument("--tmp", type=Path)
    a = ap.parse_args(argv)
    if a.worker:
        worker(a.worker, a.tmp)
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        before = a.before or _main_export(Path(tmp))
        main_commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "main"], capture_output=True,
                                     text=True).stdout.strip()
        results = {"before": run(before / "src"), "after": run(ROOT / "src")}
    print(f"{'api':4s} {'scaled':6s} {'a':>8s} {'b':>8s} | {'before: nrmse':>14s} {'ok':>5s} {'s':>5s} | "
          f"{'after: nrmse':>13s} {'ok':>5s} {'s':>5s} {'|after/unit - 1|':>16s}")
    unit = {r["api"]: r["nrmse"] for r in results["after"] if r["a"] == r["b"] == 1.0}
    for old, new in zip(results["before"], results["after"]):
        nan = float("nan")
        dev = abs(new["nrmse"] / unit[new["api"]] - 1) if new["nrmse"] is not None else nan
        label = {"fit": "fit", "cli": "cli"}.get(old["api"], "sbx")  # sbx: Silverbox, duffing-gain
        print(f"{label:4s} {old['scaled']:6s} {old['a']:8.2g} {old['b']:8.2g} | "
              f"{old['nrmse'] if old['nrmse'] is not None else nan:14.6f} {old['success']!s:>5s} "
              f"{old['seconds']:5.1f} | {new['nrmse'] if new['nrmse'] is not None else nan:13.6f} "
              f"{new['success']!s:>5s} {new['seconds']:5.1f} {dev:16.1e}")
    out = ROOT / "benchmarks" / "results" / "unit_scale.json"
    out.parent.mkdir(exist_ok=True)
    doc = {"load": os.getloadavg(), "before_code": str(a.before or f"git archive main ({main_commit})"),
           "record": "independent_sim Table 2 0.4 V, multisine, 401 samples at 100 Hz, 1 % noise", **results}
    out.write_text(json.dumps(stamp(doc, a), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
