"""Benchmark: ``duffsym batch`` on 2 local workers vs the same fits as separate ``duffsym fit`` calls.

Issue 13, "Done when": the 30 UTFSM sinusoid tests (Quiroz 2022; ``mr_damper_utfsm_quiroz2022`` in
the external data folder, read by :func:`duffsym.data.load_mr_damper_utfsm`) fitted

- one after the other as 30 separate ``duffsym fit FILE --json --quiet`` processes (what a user's
  shell loop does: every call pays Python start-up, imports and code-cache loading), and
- by ``duffsym batch --manifest M --command fit --workers 2`` (one process; a Dask LocalCluster of
  2 worker processes, each paying the start-up once), cluster start-up included,

in the same run, on the same CSV files; both wall times and their ratio, and whether every
record's parameters and NRMSE are identical (bit for bit) between the two.

The records: each test read with its velocity derived (centred Savitzky-Golay, as study s06) and
decimated as s06 does, every q-th sample with q = max(1, floor(fs / (f * samples_per_period)))
(``--samples-per-period``, default 100), written as CSV (time, displacement, velocity, force,
current) with a manifest carrying current, amplitude and frequency. Fits: the ``fit`` defaults
(``mr-damper``, n = 5, one start, k3 = 0, A_f = max|y|).

Run from the repository root (the machine is shared: run it niced)::

    nice -n 10 python benchmarks/bench_batch.py                 # the 30 tests
    nice -n 10 python benchmarks/bench_batch.py --records 6     # every 5th test

It writes ``benchmarks/results/batch[_N].json``.

``--diagnose TEST`` instead times ``duffsym diagnose`` of one test (e.g. ``2mm5Hz1A``, prepared as
above) with its candidates fitted one after the other (the default) and on ``--workers`` local
processes (``diagnose --workers 2``), and checks that both give the same candidates, numbers and
verdict; it writes ``benchmarks/results/batch_diagnose.json``.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)

ROOT = Path(__file__).resolve().parents[1]
#: the installed ``duffsym`` command beside this Python (what a user's shell loop calls)
DUFFSYM = [str(Path(sys.executable).with_name("duffsym"))] if Path(sys.executable).with_name("duffsym").is_file() \
    else [sys.executable, "-m", "duffsym.cli"]


def prepare(folder: Path, samples_per_period: int, n_records: int | None) -> Path:
    """CSV files of the decimated tests and their manifest; returns the manifest's path."""
    from duffsym.data import Record, load_mr_damper_utfsm, utfsm_sine_files, write_csv

    files = utfsm_sine_files()
    if n_records is not None:
        files = files[:: max(1, len(files) // n_records)][:n_records]
    lines = ["file,name,current,amplitude,frequency"]
    for f in files:
        rec = load_mr_damper_utfsm(f, velocity="derive")
        fr = rec.metadata["frequency_hz"]
        q = max(1, int(math.floor(1.0 / (rec.dt * fr * samples_per_period))))
        v = np.asarray(rec.velocity())
        dec = Record(t=np.asarray(rec.t)[::q], d=np.asarray(rec.d)[::q], y=np.asarray(rec.y)[::q], d_dot=v[::q],
                     current=rec.current, units=dict(rec.units), name=f.stem)
        write_csv(dec, folder / f"{f.stem}.csv")
        lines.append(f"{f.stem}.csv,{f.stem},{rec.current:g},{rec.metadata['amplitude_mm']:g},{fr:g}")
    manifest = folder / "manifest.csv"
    manifest.write_text("\n".join(lines) + "\n")
    return manifest


def _cpu() -> float:
    """CPU seconds (user + system) of the finished child processes and their waited-for descendants."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run_serial(folder: Path, names: list[str]) -> tuple[float, float, dict, dict]:
    """Each record as its own ``duffsym fit`` process."""
    out, walls = {}, {}
    t0, c0 = time.perf_counter(), _cpu()
    for name in names:
        t1 = time.perf_counter()
        p = subprocess.run([*DUFFSYM, "fit", str(folder / f"{name}.csv"), "--json",
                            "--quiet"], capture_output=True, text=True)
        walls[name] = time.perf_counter() - t1
        out[name] = json.loads(p.stdout) if p.stdout.strip() else {"error": p.stderr.strip()[-300:]}
    return time.perf_counter() - t0, _cpu() - c0, out, walls


def run_batch(manifest: Path, results: Path, workers: int) -> tuple[float, float, dict, dict]:
    t0, c0 = time.perf_counter(), _cpu()
    p = subprocess.run([*DUFFSYM, "batch", "--manifest", str(manifest), "--command", "fit",
                        "--out", str(results), "--workers", str(workers), "--json", "--quiet"],
                       capture_output=True, text=True)
    wall, cpu = time.perf_counter() - t0, _cpu() - c0
    if not p.stdout.strip():
        raise SystemExit(f"batch failed: {p.stderr[-2000:]}")
    summary = json.loads(p.stdout)
    docs = {r["record"]: json.loads(Path(r["result"]).read_text()) for r in summary["records"]}
    return wall, cpu, summary, docs


def compare(serial: dict, docs: dict) -> dict:
    same, diffs = [], {}
    for name, s in serial.items():
        b = {k: v for k, v in docs[name].items() if k != "batch"}
        keys = ("params", "nrmse", "stderr", "status", "success", "n_iter")
        if all(s.get(k) == b.get(k) for k in keys):
            same.append(name)
        else:
            diffs[name] = {k: [s.get(k), b.get(k)] for k in keys if s.get(k) != b.get(k)}
    return {"identical": len(same), "n": len(serial), "differences": diffs}


def run_diagnose(folder: Path, name: str, workers: int) -> dict:
    """``duffsym diagnose`` of one record, serial and on ``workers`` processes (same run, same file)."""
    out = {}
    for label, extra in (("serial", []), (f"workers_{workers}", ["--workers", str(workers)])):
        t0, c0 = time.perf_counter(), _cpu()
        p = subprocess.run([*DUFFSYM, "diagnose", str(folder / f"{name}.csv"), "--json", "--quiet", "--no-sindy",
                            *extra], capture_output=True, text=True)
        wall, cpu = time.perf_counter() - t0, _cpu() - c0
        if not p.stdout.strip():
            raise SystemExit(f"diagnose failed: {p.stderr[-2000:]}")
        out[label] = {"seconds": wall, "cpu_seconds": cpu, "doc": json.loads(p.stdout)}
        print(f"  diagnose {label}: {wall:.1f} s (CPU {cpu:.1f} s)", flush=True)
    a, b = (out[k]["doc"] for k in out)
    keys = ("effect", "nrmse_after", "delta_bic", "all_params", "success")
    same = [[c.get(k) for k in keys] for c in a["candidates"]] == [[c.get(k) for k in keys] for c in b["candidates"]]
    return {"record": name, "workers": workers, "serial_seconds": out["serial"]["seconds"],
            "parallel_seconds": out[f"workers_{workers}"]["seconds"],
            "ratio": out["serial"]["seconds"] / out[f"workers_{workers}"]["seconds"],
            "cpu_seconds": {k: v["cpu_seconds"] for k, v in out.items()},
            "candidates_identical": same, "verdict_identical": a["verdict"] == b["verdict"],
            "n_candidates": len(a["candidates"]), "needed": a["needed"], "nrmse": a["nrmse"],
            "note": "candidate_cpu_time budget (30 CPU s per candidate) applies in both runs; --no-sindy"}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", type=int, default=None, help="a subset: every k-th test (default: all 30)")
    ap.add_argument("--samples-per-period", type=int, default=100)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--keep", help="keep the CSV files and results in this folder")
    ap.add_argument("--diagnose", metavar="TEST", help="time duffsym diagnose of this test, serial vs --workers")
    args = ap.parse_args(argv)
    import duffsym

    if args.diagnose:
        with tempfile.TemporaryDirectory(prefix="bench-batch-") as tmp:
            prepare(Path(tmp), args.samples_per_period, None)
            res = run_diagnose(Path(tmp), args.diagnose, args.workers)
        res["machine"] = {"cpus": os.cpu_count(), "loadavg_at_end": os.getloadavg(),
                          "note": "2 cores shared with other jobs; niced"}
        out = ROOT / "benchmarks" / "results" / "batch_diagnose.json"
        out.write_text(json.dumps(stamp(res, args), indent=2) + "\n")
        print(f"diagnose {args.diagnose}: serial {res['serial_seconds']:.1f} s, {args.workers} workers "
              f"{res['parallel_seconds']:.1f} s, ratio {res['ratio']:.2f}; candidates identical "
              f"{res['candidates_identical']}, verdict identical {res['verdict_identical']}; wrote {out}")
        return 0

    with tempfile.TemporaryDirectory(prefix="bench-batch-") as tmp:
        folder = Path(args.keep) if args.keep else Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        manifest = prepare(folder, args.samples_per_period, args.records)
        names = [ln.split(",")[1] for ln in manifest.read_text().splitlines()[1:]]
        print(f"{len(names)} records in {folder}; serial: {len(names)} duffsym fit processes", flush=True)
        t_serial, c_serial, serial, walls = run_serial(folder, names)
        print(f"  serial {t_serial:.1f} s (CPU {c_serial:.1f} s); batch on {args.workers} workers", flush=True)
        t_batch, c_batch, summary, docs = run_batch(manifest, folder / "results", args.workers)
        print(f"  batch {t_batch:.1f} s (CPU {c_batch:.1f} s); batch in one process (--workers 0)", flush=True)
        t_one, c_one, summary_one, docs_one = run_batch(manifest, folder / "results_one", 0)
        print(f"  batch --workers 0 {t_one:.1f} s (CPU {c_one:.1f} s)", flush=True)
        cmp_ = compare(serial, docs)
        cmp_one = compare(serial, docs_one)
        per_record = {n: {"serial_cli_seconds": walls[n], "seconds_in_worker": docs[n]["batch"]["seconds"],
                          "seconds_in_one_process": docs_one[n]["batch"]["seconds"], "nrmse": docs[n].get("nrmse"),
                          "status": docs[n]["batch"]["status"]} for n in names}
    load = os.getloadavg()
    result = {
        "benchmark": "bench_batch", "n_records": len(names), "workers": args.workers,
        "samples_per_period": args.samples_per_period,
        "serial_cli_seconds": t_serial, "batch_seconds": t_batch, "ratio": t_serial / t_batch,
        "batch_one_process_seconds": t_one, "ratio_one_process": t_serial / t_one,
        "cpu_seconds": {"serial_cli": c_serial, "batch": c_batch, "batch_one_process": c_one},
        "batch_summary_seconds": summary["seconds"], "counts": summary["counts"], "comparison": cmp_,
        "comparison_one_process": cmp_one,
        "sum_of_worker_seconds": sum(r["seconds_in_worker"] or 0 for r in per_record.values()),
        "per_record": per_record,
        "machine": {"cpus": os.cpu_count(), "loadavg_at_end": load, "platform": platform.platform(),
                    "python": platform.python_version(), "note": "2 cores shared with other jobs; niced"},
        "duffsym": duffsym.__version__,
    }
    name = "batch.json" if args.records is None else f"batch_{len(names)}.json"
    out = ROOT / "benchmarks" / "results" / name
    out.write_text(json.dumps(stamp(result, args), indent=2) + "\n")
    print(f"serial CLI {t_serial:.1f} s, batch {t_batch:.1f} s on {args.workers} workers: ratio "
          f"{t_serial / t_batch:.2f} (CPU {c_serial:.1f} s vs {c_batch:.1f} s); batch in one process {t_one:.1f} s "
          f"(ratio {t_serial / t_one:.2f}); identical results {cmp_['identical']}/{cmp_['n']} and "
          f"{cmp_one['identical']}/{cmp_one['n']}; "
          f"load average {load[0]:.1f}; wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
