"""Benchmark: the speed of ``diagnose`` and ``ladder`` (issue 16, item 6), this version against a previous one.

Each case runs in its own subprocess with ``sys.path`` starting at the ``src`` folder of the version
under test, so the previous version (e.g. ``git worktree add --detach /tmp/prev <commit>``) and this
one are timed in the same run on the same machine, and their verdicts compared side by side.

Cases (``--cases``):

- ``synth1600``: the MR damper (Table 2, 0.5 V row) with Coulomb friction (20) and a load-cell offset
  (0.2) hidden, 2 Hz unit sine, dt = 0.005 s, 8 s = 1600 samples, 1 % noise, A_f fixed at the truth
  (study s07's synthetic case, longer). Made by ``duffsym.effects``: a timing case; its verdict is a
  consistency check between the versions, not evidence for the diagnosis.
- ``synth1600clean``: the same without hidden effects (false positives).
- ``synth1600play``: the same with an exact play of half-width 0.1 on the piston path
  (``synthetic_record(backlash=0.1)``: the exact play operator, not the catalogue's smooth one) — the slow
  candidate that screening must not lose.
- ``synth4k``, ``synth4kplay``: ``synth1600`` and ``synth1600play`` sampled at 1 kHz for 4 s (4000 samples), where
  the decimation applies; run with ``--opts '{"decimate": false}' --variant nodecimate`` beside the default to
  see what decimation alone changes.
- ``real1A``: the UTFSM MR damper, 10 mm 1 Hz 1 A, full rate (11 854 samples at 1 kHz), velocity derived.
- ``real0A``: UTFSM 25 mm 0.25 Hz 0 A, full rate (4486 samples at 200 Hz).
- ``s07_1A``, ``s07_0A``: the two real tests as study s07 feeds them (decimated to ~200 samples per period
  by plain subsampling of the authors' smoothed data).

Kinds (``--kinds``): ``diagnose`` (full catalogue, default options) and ``ladder`` (default options).
``--opts '{"workers": 2}'`` fits a diagnosis's candidates on ``duffsym.engine``'s local workers (the
engine's start and stop are inside the timed wall and CPU seconds).

    nice -n 10 python benchmarks/bench_diagnose_speed.py --prev /tmp/prev/src --cases synth1600 real1A
    python benchmarks/bench_diagnose_speed.py --table        # print the table of results/diagnose_speed.json

Each finished run is appended to ``benchmarks/results/diagnose_speed.json`` at once (wall time, CPU time of
the subprocess, load average before and after, verdict, needed effects, held-out NRMSE, candidates).
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

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
OUT = RESULTS / "diagnose_speed.json"
THIS_SRC = HERE.parent / "src"
UTFSM = "mr_damper_utfsm_quiroz2022/sinusoidal_preprocessed"


# ---------------------------------------------------------------------------------------------- worker
def _record(case: str):
    import numpy as np

    if case.startswith("synth"):
        from duffsym.data import synthetic_record
        from duffsym.effects import CATALOGUE, apply_effects
        from duffsym.excitation import Sine
        from duffsym.model.library import mr_damper
        from duffsym.model.presets import table2_params

        truth = table2_params(0.5)
        model = mr_damper()
        if case in ("synth1600", "synth4k"):
            truth.update(fric_mu=20.0, off_y0=0.2)
            model = apply_effects(model, [CATALOGUE["coulomb-friction"], CATALOGUE["force-offset"]])
        play = 0.1 if case.endswith("play") else 0.0
        fine = case.startswith("synth4k")  # 1 kHz, 4 s: a finely sampled record that decimation applies to
        rec = synthetic_record(model, truth, Sine(1.0, 2.0), dt=0.001 if fine else 0.005,
                               duration=4.0 if fine else 8.0, noise=0.01, rng=7, backlash=play, name=case)
        return rec, {"A_f": truth["A_f"]}
    from duffsym.data import load_mr_damper_utfsm
    from duffsym.data.loaders import external_data_dir

    name = {"real1A": "10mm1Hz1A", "real0A": "25mm0x25Hz0A", "s07_1A": "10mm1Hz1A", "s07_0A": "25mm0x25Hz0A"}[case]
    rec = load_mr_damper_utfsm(external_data_dir() / UTFSM / f"{name}.txt", velocity="derive")
    if case.startswith("s07"):  # as studies/s06_real_mr_damper.load_test: ~200 samples per period
        f = rec.metadata["frequency_hz"]
        q = max(1, int(math.floor(1.0 / (rec.dt * f * 200))))
        v = np.asarray(rec.velocity())
        rec = rec.replace(t=rec.t[::q], d=rec.d[::q], y=rec.y[::q], d_dot=v[::q])
    return rec, None


def _cands(dg) -> list:
    return [dict(effect=c.effect, nrmse_after=c.nrmse_after, delta_bic=c.delta_bic, explained=c.explained,
                 success=c.success, supported=c.supported, needed=c.needed, seconds=c.seconds,
                 message=c.message[:120], params=c.params) for c in dg.candidates]


def worker(case: str, kind: str) -> dict:
    import duffsym
    from duffsym.diagnose import diagnose, ladder

    rec, fixed = _record(case)
    opts = json.loads(os.environ.get("BENCH_DIAGNOSE_OPTS") or "{}")
    workers = int(opts.pop("workers", 0) or 0)  # candidates on duffsym.engine's local workers (diagnose only)
    t0 = time.perf_counter()
    if kind == "diagnose" and workers:
        from duffsym.engine import Engine

        with Engine(workers) as engine:
            dg = diagnose(rec, fixed=fixed, engine=engine, **opts)
    if kind == "diagnose":
        dg = dg if workers else diagnose(rec, fixed=fixed, **opts)
        out = dict(verdict=dg.verdict, needed=list(dg.needed), nrmse_heldout=dg.nrmse_heldout,
                   best=dg.best.effect if dg.best else None, candidates=_cands(dg), noise=dg.noise,
                   timings=dg.timings, base_params=dict(dg.base_fit.params), base_n_iter=dg.base_fit.n_iter,
                   prepare=dg.to_dict().get("prepare"))
    else:
        lad = ladder(rec, fixed=fixed, **opts)
        out = dict(effects=list(lad.effects), stopped=lad.stopped,
                   steps=[dict(effects=list(s.effects), nrmse_heldout=s.nrmse_heldout, needed=list(s.diagnosis.needed),
                               verdict=s.diagnosis.verdict, candidates=_cands(s.diagnosis),
                               prepare=s.diagnosis.to_dict().get("prepare")) for s in lad.steps],
                   final_nrmse=lad.final_fit.nrmse, final_status=lad.final_fit.status)
    out.update(seconds=time.perf_counter() - t0, n=rec.n_times, duffsym_file=duffsym.__file__)
    return out


# ---------------------------------------------------------------------------------------------- driver
def run_case(src: str, label: str, case: str, kind: str, timeout: float, opts: str = "") -> dict:
    env = dict(os.environ, PYTHONPATH=src, BENCH_DIAGNOSE_OPTS=opts)
    # one code cache for every version (the generated code is keyed by the model and the codegen version),
    # filled by earlier runs: the times compare the diagnosis, not numba's first compilation of a model
    env.setdefault("DUFFSYM_CACHE", str(Path(tempfile.gettempdir()) / "duffsym_bench_cache_prev"))
    load0 = os.getloadavg()
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    try:
        p = subprocess.run([sys.executable, __file__, "--worker", case, kind], env=env, capture_output=True,
                           text=True, timeout=timeout)
        ok, text = p.returncode == 0, p.stdout.strip().splitlines()
        res = json.loads(text[-1]) if ok and text else {"error": p.stderr[-2000:]}
    except subprocess.TimeoutExpired:
        res = {"error": f"timeout after {timeout:.0f} s"}
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    res.update(label=label, src=src, case=case, kind=kind, wall=wall, opts=opts,
               cpu=(r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime), load_before=load0,
               load_after=os.getloadavg(), finished=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()))
    return res


def _git(src: str) -> str:
    try:
        return subprocess.run(["git", "-C", src, "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              check=True).stdout.strip()
    except (subprocess.CalledProcessError, OSError):
        return "?"


def _append(row: dict) -> None:
    RESULTS.mkdir(exist_ok=True)
    data = json.loads(OUT.read_text()) if OUT.exists() else {"machine": {}, "runs": []}
    data["machine"] = dict(platform=platform.platform(), cpus=os.cpu_count(), python=sys.version.split()[0])
    data["runs"].append(row)
    tmp = OUT.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1, default=str))
    tmp.replace(OUT)


def table(path: Path = OUT) -> str:
    """One line per (case, kind, variant of this version): wall and CPU seconds of the previous version and
    of this one, their ratios (previous / this), and the verdicts (latest run of each)."""
    runs = json.loads(path.read_text())["runs"]
    latest: dict = {}
    for r in runs:
        latest[(r["case"], r["kind"], r["label"])] = r
    keys = sorted({(c, k, lab) for c, k, lab in latest if lab != "prev"})
    lines = [f"{'case':<15} {'kind':<9} {'version':<20} {'n':>6} {'prev wall':>9} {'this wall':>9} {'ratio':>6} "
             f"{'prev CPU':>9} {'this CPU':>9} {'ratio':>6}  prev -> this"]
    for c, k, lab in keys:
        p, t = latest.get((c, k, "prev")), latest[(c, k, lab)]
        w = [x["wall"] if x and "error" not in x else math.nan for x in (p, t)]
        u = [x["cpu"] if x and "error" not in x else math.nan for x in (p, t)]
        n = next((x.get("n") for x in (p, t) if x and x.get("n")), "")
        lines.append(f"{c:<15} {k:<9} {lab:<20} {n!s:>6} {w[0]:9.1f} {w[1]:9.1f} {w[0] / w[1]:6.2f} {u[0]:9.1f} "
                     f"{u[1]:9.1f} {u[0] / u[1]:6.2f}  {_brief(p)} -> {_brief(t)}")
    return "\n".join(lines)


def _brief(r) -> str:
    if not r:
        return "-"
    if "error" in r:
        return "error"
    if r["kind"] == "diagnose":
        return f"needed {r['needed'] or 'none'}, held-out {r['nrmse_heldout']:.4g}, best {r['best']}"
    path = " -> ".join(f"{s['nrmse_heldout']:.3g}" for s in r["steps"])
    return f"{' + '.join(['base'] + r['effects'])} ({path})"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--worker", nargs=2, metavar=("CASE", "KIND"), help=argparse.SUPPRESS)
    ap.add_argument("--prev", help="src folder of the previous version (omit to time this version only)")
    ap.add_argument("--cases", nargs="+", default=["synth1600", "real1A"])
    ap.add_argument("--kinds", nargs="+", default=["diagnose"], choices=("diagnose", "ladder"))
    ap.add_argument("--only", choices=("prev", "this"), help="run one version only")
    ap.add_argument("--timeout", type=float, default=3600.0)
    ap.add_argument("--opts", default="", help="JSON keyword arguments of diagnose/ladder for this version, e.g. "
                    '\'{"decimate": false}\'; the runs are labelled this:VARIANT')
    ap.add_argument("--variant", default="", help="label suffix of this version's runs with --opts")
    ap.add_argument("--table", action="store_true")
    args = ap.parse_args(argv)
    if args.worker:
        print(json.dumps(worker(*args.worker), default=str))
        return 0
    if args.table:
        print(table())
        return 0
    this = "this" + (f":{args.variant}" if args.variant else "")
    versions = [(this, str(THIS_SRC))] + ([("prev", args.prev)] if args.prev else [])
    versions = [v for v in versions if args.only in (None, v[0].split(":")[0])]
    for case in args.cases:
        for kind in args.kinds:
            for label, src in versions:  # the same case back to back: the same load for both
                row = run_case(src, label, case, kind, args.timeout, args.opts if label != "prev" else "")
                row["commit"] = _git(src)
                _append(row)
                print(f"{label:<4} {case:<15} {kind:<9} {row['wall']:7.1f} s  {_brief(row)}", flush=True)
    print(table())
    return 0


if __name__ == "__main__":
    sys.exit(main())
