"""IPOPT iteration times of `fit` on shipped and shared records, the main branch's code against this one,
in the same run (issue 24).

Each (code, case) runs in its own process (``--worker``) under a wall-clock limit; IPOPT's intermediate
callback is wrapped to write the time of every iteration to a file as it happens, so a run the limit
kills still reports its iterations. The summary gives, per case and code: the wall time, how the fit
ended, the number of iterations, their median / 90th percentile / max time and how many took > 2 s.

    python benchmarks/bench_ipopt_iterations.py --before /work/main --limit 240

``--before`` is a checkout of the older code with its own ``.venv`` (used read-only). Records: the shipped
``data/synthetic_sine.csv`` (mr-damper); 3000 Silverbox samples (multisine rows 40650-43650 of
SNLS80mV.csv) in V and s, and the same in mV and ms (duffing + input-shift); a 6 s slice of the Dyke
record at 500 Hz (decimation 6, mr-damper-current); one UTFSM sine test (mr-damper).
Results: ``benchmarks/results/bench_ipopt_iterations.json``.
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
from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)

ROOT = Path(__file__).resolve().parents[1]
CASES = ("shipped-sine", "silverbox-3000-V-s", "silverbox-3000-mV-ms", "dyke-6s-500Hz", "utfsm-sine")


def _external() -> Path:
    return Path(os.environ.get("DUFFSYM_EXTERNAL_DATA", ROOT.parent / "shared" / "data" / "external"))


def _silverbox(mv_ms: bool):
    from duffsym.data.record import Record

    a = np.genfromtxt(_external() / "silverbox" / "SNLS80mV.csv", delimiter=",", skip_header=1)[40650:43650, :2]
    k = 1e3 if mv_ms else 1.0
    t = np.arange(a.shape[0]) / (1e7 / 2**14) * k
    return Record(t=t, d=a[:, 0] * k, y=a[:, 1] * k, name="silverbox3000")


def _case(name):
    """``(record, model, fixed)`` of a case."""
    from duffsym.data import read_csv
    from duffsym.model import get_model

    if name == "shipped-sine":
        return read_csv(ROOT / "data" / "synthetic_sine.csv"), get_model("mr-damper"), {}
    if name.startswith("silverbox"):
        from duffsym.effects import CATALOGUE, apply_effects

        return _silverbox(name.endswith("mV-ms")), apply_effects(get_model("duffing"), [CATALOGUE["input-shift"]]), {}
    if name == "dyke-6s-500Hz":
        r = read_csv(_external() / "mr_damper_dyke_nees1996" / "ranran_50_converted.csv",
                     columns={"time": "t", "input": "D", "output": "F", "velocity": "V", "voltage": "Y"})
        q, n = 6, int(6.0 * 3004.8)
        r = r.replace(t=r.t[:n:q], d=r.d[:n:q], y=r.y[:n:q], d_dot=r.d_dot[:n:q], command=r.command[:n:q])
        return r, get_model("mr-damper-current"), {}
    if name == "utfsm-sine":
        from duffsym.data import load_mr_damper_utfsm, utfsm_sine_files

        path = utfsm_sine_files()[0]
        r = load_mr_damper_utfsm(path)
        q = max(1, r.n_times // 1500)
        return r.replace(t=r.t[::q], d=r.d[::q], y=r.y[::q], d_dot=r.d_dot[::q]), get_model("mr-damper"), {}
    raise SystemExit(f"unknown case {name}")


def worker(case: str, log: Path) -> None:
    """Fit ``case`` with the default settings, writing each IPOPT iteration's time to ``log``."""
    from duffsym.identify import Problem, fit, nlp

    record, model, fixed = _case(case)
    base = nlp._make_hook_class()
    out = open(log, "a", buffering=1)

    class Timed(base):
        def eval(self, arg):
            now = time.perf_counter()
            prev = self.t0 if self.iterations == 0 else self._prev  # a new solve (a restart) starts at t0
            out.write(f"it {now - prev:.6f}\n")
            self._prev = now
            return base.eval(self, arg)

    def fresh_hook(*args):  # the hook's arguments changed with the ridge check (n_w, n_slots)
        return Timed(*args)

    nlp._iteration_hook = fresh_hook
    tic = time.perf_counter()
    res = fit(Problem(model, record, fixed=fixed))
    out.write("end " + json.dumps({"status": res.status, "success": bool(res.success), "nrmse": res.nrmse,
                                   "n_iter": res.n_iter, "seconds": time.perf_counter() - tic,
                                   "bound_restart": (res.settings.get("bound_restart") or {}).get("kept"),
                                   "restart_stopped": (res.settings.get("bound_restart") or {}).get("stopped")})
              + "\n")


def run(code_root: Path, case: str, limit: float) -> dict:
    py = code_root / ".venv" / "bin" / "python"
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "iterations.txt"
        env = {**os.environ, "PYTHONPATH": str(code_root / "src"), "OMP_NUM_THREADS": "1",
               "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
               "DUFFSYM_CACHE": os.environ.get("DUFFSYM_CACHE", str(Path(tmp) / "cache"))}
        tic = time.perf_counter()
        try:
            proc = subprocess.run([str(py), __file__, "--worker", case, "--log", str(log)], env=env,
                                  capture_output=True, text=True, timeout=limit)
            ended = "ok" if proc.returncode == 0 else f"exit {proc.returncode}: {proc.stderr.strip()[-300:]}"
        except subprocess.TimeoutExpired:
            ended = f"killed at the {limit:g} s limit"
        wall = time.perf_counter() - tic
        lines = log.read_text().splitlines() if log.exists() else []
    its = np.array([float(x.split()[1]) for x in lines if x.startswith("it ")])
    end = next((json.loads(x[4:]) for x in lines if x.startswith("end ")), None)
    return {"case": case, "code": str(code_root), "wall_s": wall, "ended": ended, "fit": end,
            "iterations": int(its.size), "median_s": float(np.median(its)) if its.size else None,
            "p90_s": float(np.percentile(its, 90)) if its.size else None,
            "max_s": float(its.max()) if its.size else None, "over_2s": int(np.sum(its > 2.0)),
            "times": its.round(4).tolist()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", type=Path, default=Path("/work/main"))
    ap.add_argument("--limit", type=float, default=240.0)
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--worker")
    ap.add_argument("--log", type=Path)
    a = ap.parse_args(argv)
    if a.worker:
        worker(a.worker, a.log)
        return 0
    rows = []
    for case in a.cases.split(","):
        for code in (a.before, ROOT):
            r = run(code, case, a.limit)
            rows.append(r)
            f = r["fit"] or {}
            print(f"{case:22s} {'before' if code == a.before else 'after ':6s} wall {r['wall_s']:6.1f} s  "
                  f"{f.get('status', r['ended'])[:28]:28s} nrmse {f.get('nrmse', float('nan')):.4g}  "
                  f"iters {r['iterations']:4d}  median {r['median_s'] or 0:.3f} s  p90 {r['p90_s'] or 0:.3f} s  "
                  f"max {r['max_s'] or 0:.2f} s  >2 s: {r['over_2s']}  restart {f.get('bound_restart')}"
                  f"{' (' + str(f.get('restart_stopped')) + ')' if f.get('restart_stopped') else ''}", flush=True)
    out = ROOT / "benchmarks" / "results" / "bench_ipopt_iterations.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps(stamp({"load": os.getloadavg(), "limit_s": a.limit, "rows": rows}, a), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
