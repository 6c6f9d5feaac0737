"""Fit times of device-sized records: today's main against this checkout, in the same run (issue 23).

Two cases, each run by a worker process in each checkout's own venv (``--main`` points at the other
checkout; its ``.venv/bin/python`` runs the worker with that checkout's ``src`` first on the path):

- ``dyke``: ``mr-damper-current`` fitted to the whole shared Dyke record (74 068 samples at 3004.8 Hz,
  24.6 s, random displacement and voltage) through the Python API. *main*: the record as read (what
  ``duffsym fit`` did). *branch*: the record as ``duffsym fit`` now prepares it
  (:func:`duffsym.identify.fitdata.prepare_fit_data`: sanity check, then the variance-rule decimation).
  Both report the free-run NRMSE on the full-rate record (``validate``), so the rate's cost in accuracy is
  visible beside its gain in time.
- ``fold``: s11's hold-out fold "25 mm 0.1 Hz" (the other 25 tests fitted at s11's ~25 samples per period,
  the five held-out tests run free): the fit that crawled to IPOPT's iteration limit before the ridge stop
  (compare two checkouts with ``--prep branch``; in-sample and held-out NRMSE beside the times).
- ``campaign``: the 30 UTFSM sinusoid tests fitted at once as s11 does it (``mr-damper-current``, eta held at
  100 /s, k1 + k2 >= 0 at 0 and 1 A). *main*: s11's hand decimation (about 25 samples per period, plain
  subsampling, velocity derived at the full rate). *branch*: each record prepared by ``prepare_fit_data``.
  Both report the in-sample NRMSE on the full-rate records (median and worst over the 30).

Times: each worker reports the wall time and the CPU time (``time.process_time``) of its fit; the workers
run single-threaded (OMP/BLAS threads 1), so on a machine shared by many processes the CPU time is the
better estimate of the wall time on an idle core, and the ratio of the two checkouts is the measurement. A
worker that exceeds ``--cpu-limit`` CPU seconds (RLIMIT_CPU) or ``--timeout`` wall seconds is stopped and
reported as such (a lower bound on its time).

Usage: ``python benchmarks/bench_device_fit.py [--main /work/main] [--cases dyke,campaign] [--cpu-limit 900]``
(writes ``benchmarks/results/bench_device_fit.json``).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

WORKER = r'''
import json, math, sys, time, glob
import numpy as np
sys.path.insert(0, sys.argv[1] + "/src")
case, mode, ext = sys.argv[2], sys.argv[3], sys.argv[4]
from duffsym.data import read_csv, load_mr_damper_utfsm, Record
from duffsym.identify import Problem, fit, validate
from duffsym.model import get_model

def prepared(rec):
    if mode == "main":
        return rec, None, {"factor": 1}
    from duffsym.identify.fitdata import prepare_fit_data
    d = prepare_fit_data(rec)
    return d.record, d.mask, {"factor": 1 if d.prep is None else d.prep.factor,
                              "notes": d.notes(), "full": d.full}

def s11_decimate(rec):
    f = rec.metadata["frequency_hz"]
    q = max(1, int(math.floor(1.0 / (rec.dt * f * 25))))
    v = np.asarray(rec.velocity())
    return Record(t=np.asarray(rec.t)[::q], d=np.asarray(rec.d)[::q], y=np.asarray(rec.y)[::q], d_dot=v[::q],
                  current=rec.current, units=dict(rec.units), name=rec.name)

model = get_model("mr-damper-current")
out = {"case": case, "mode": mode}
if case == "dyke":
    full = read_csv(ext + "/mr_damper_dyke_nees1996/ranran_50_converted.csv",
                    columns=dict(time="t", input="D", output="F", velocity="V", voltage="Y"))
    t0, c0 = time.perf_counter(), time.process_time()
    rec, mask, info = prepared(full)
    t_prep = time.perf_counter() - t0
    res = fit(Problem(model, rec, mask=mask))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    v = validate(res, info.get("full", full), model)
    out.update(n_samples=rec.n_times, factor=info["factor"], prep_s=t_prep, fit_s=wall, cpu_s=cpu, status=res.status,
               success=bool(res.success), n_iter=int(res.n_iter), nrmse_fitted=res.nrmse,
               nrmse_full_rate=v.nrmse, rmse_full_rate=v.rmse, notes=info.get("notes", []))
elif case == "fold":
    sys.path.insert(0, sys.argv[1] + "/studies")
    import s11_current_driven as s11
    cfg = s11.Config()
    recs = s11.campaign_records(cfg)
    train = [r for r in recs if not r.name.startswith("25mm0x1Hz")]
    held = [r for r in recs if r.name.startswith("25mm0x1Hz")]
    t0, c0 = time.perf_counter(), time.process_time()
    res = s11.campaign_fit(model, train, cfg)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    ins = [s11.free_run(res, r, model)[1] for r in train]
    ho = [s11.free_run(res, r, model)[1] for r in held]
    out.update(n_samples=int(sum(r.n_times for r in train)), fit_s=wall, cpu_s=cpu, status=res.status,
               success=bool(res.success), n_iter=int(res.n_iter), nrmse_median=float(np.median(ins)),
               nrmse_worst=float(np.max(ins)), heldout_median=float(np.median(ho)), heldout_worst=float(np.max(ho)),
               flags=[f["flag"] for f in res.flags])
else:
    files = sorted(glob.glob(ext + "/mr_damper_utfsm_quiroz2022/sinusoidal_preprocessed/*.txt"))
    fulls = [load_mr_damper_utfsm(f, velocity="derive") for f in files]
    t0, c0 = time.perf_counter(), time.process_time()
    if mode == "main":
        recs, masks, factors = [s11_decimate(r) for r in fulls], None, None
    else:
        preps = [prepared(r) for r in fulls]
        recs = [p[0] for p in preps]
        masks = [np.zeros(r.n_times, bool) if p[1] is None else p[1] for r, p in zip(recs, preps)]
        factors = [p[2]["factor"] for p in preps]
    t_prep = time.perf_counter() - t0
    cons = [({"k1": 1.0, "k2": 1.0}, 0.0, math.inf), ({"k1": 1.0, "k2": 1.0, "k1_u": 1.0, "k2_u": 1.0}, 0.0, math.inf)]
    res = fit(Problem(model, recs, fixed={"eta": 100.0}, constraints=cons, mask=masks))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    errs = [validate(res, r, model).nrmse for r in fulls]
    out.update(n_samples=int(sum(r.n_times for r in recs)), factors=factors, prep_s=t_prep, fit_s=wall, cpu_s=cpu,
               status=res.status, success=bool(res.success), n_iter=int(res.n_iter),
               nrmse_median=float(np.median(errs)), nrmse_worst=float(np.max(errs)),
               nrmse_records={f.rsplit("/", 1)[-1]: e for f, e in zip(files, errs)})
print("RESULT " + json.dumps(out, default=str), flush=True)
'''


def _cpu_limit(seconds: float):
    def set_limit():
        import resource

        resource.setrlimit(resource.RLIMIT_CPU, (int(seconds), int(seconds) + 5))
    return set_limit


def run_worker(checkout: Path, case: str, mode: str, timeout: float, cpu_limit: float) -> dict:
    python = checkout / ".venv" / "bin" / "python"
    ext = os.environ.get("DUFFSYM_EXTERNAL_DATA", str(ROOT.parent / "shared" / "data" / "external"))
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
           "DUFFSYM_EXTERNAL_DATA": ext, "PYTHONPATH": str(checkout / "src")}
    t0 = time.perf_counter()
    try:
        p = subprocess.run([str(python), "-c", WORKER, str(checkout), case, mode, ext], capture_output=True,
                           text=True, timeout=timeout, env=env, preexec_fn=_cpu_limit(cpu_limit))
    except subprocess.TimeoutExpired:
        return {"case": case, "mode": mode, "timeout": True, "fit_s": None,
                "message": f"stopped after {timeout:.0f} s wall"}
    lines = [ln for ln in p.stdout.splitlines() if ln.startswith("RESULT ")]
    if not lines and p.returncode in (-24, -9, 152, 137):  # SIGXCPU / SIGKILL from RLIMIT_CPU
        return {"case": case, "mode": mode, "timeout": True, "fit_s": None,
                "message": f"stopped at the CPU limit of {cpu_limit:.0f} CPU s (after {time.perf_counter() - t0:.0f} s wall)"}
    if p.returncode or not lines:
        return {"case": case, "mode": mode, "error": (p.stderr or p.stdout)[-800:], "wall_s": time.perf_counter() - t0}
    return json.loads(lines[-1][len("RESULT "):])


def _line(r: dict) -> str:
    if r.get("timeout"):
        return f"  {r.get('code', r['mode']):6s}: {r['message']} (no result)"
    if r.get("error"):
        return f"  {r.get('code', r['mode']):6s}: error: {r['error'][-300:]}"
    acc = (f"full-rate NRMSE {r['nrmse_full_rate']:.4f} (RMSE {r['rmse_full_rate']:.1f})" if r["case"] == "dyke"
           else f"in-sample NRMSE median {r['nrmse_median']:.4f}, worst {r['nrmse_worst']:.4f}")
    return (f"  {r.get('code', r['mode']):6s}: {r['n_samples']} samples, fit {r['cpu_s']:.0f} CPU s, {r['fit_s']:.0f} s wall "
            f"({r['n_iter']} iterations, "
            f"{r['status']}), {acc}"
            + (f", held out median {r['heldout_median']:.4f}, worst {r['heldout_worst']:.4f}" if "heldout_median" in r
               else ""))


def _write(out: Path, results: list, args) -> None:
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp")
    doc = {"results": results, "timeout_s": args.timeout, "cpu_limit_s": args.cpu_limit}
    tmp.write_text(json.dumps(stamp(doc, args), indent=2, default=str))
    tmp.replace(out)


def main(argv=None) -> int:
    from concurrent.futures import ThreadPoolExecutor

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--main", default="/work/main", help="the checkout to compare with (with its .venv)")
    ap.add_argument("--cases", default="dyke,campaign")
    ap.add_argument("--modes", default="branch,main")
    ap.add_argument("--timeout", type=float, default=7200.0, help="wall seconds before a worker is stopped")
    ap.add_argument("--cpu-limit", type=float, default=900.0, help="CPU seconds before a worker is stopped")
    ap.add_argument("--prep", choices=("by-mode", "branch"), default="by-mode",
                    help="by-mode: main fits the records as read (or s11's hand decimation), branch prepares them; "
                    "branch: both checkouts prepare them as the branch does (to compare code, not preparation)")
    ap.add_argument("--parallel", type=int, default=1, help="workers run at once (CPU times stay comparable)")
    ap.add_argument("--out", default=str(HERE / "results" / "bench_device_fit.json"))
    args = ap.parse_args(argv)
    checkouts = {"main": Path(args.main), "branch": ROOT}
    jobs = [(case, mode) for case in args.cases.split(",") for mode in args.modes.split(",")]
    print(f"{len(jobs)} workers, {args.parallel} at once; load average {os.getloadavg()[0]:.1f} at the start", flush=True)
    results: list = []

    def one(job):
        case, mode = job
        r = run_worker(checkouts[mode], case, "branch" if args.prep == "branch" else mode, args.timeout, args.cpu_limit)
        r["code"] = mode
        r["load_average"] = os.getloadavg()[0]
        results.append(r)
        print(f"{case}:" + _line(r), flush=True)
        _write(Path(args.out), results, args)
        return r

    with ThreadPoolExecutor(max_workers=max(1, args.parallel)) as pool:
        list(pool.map(one, jobs))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
