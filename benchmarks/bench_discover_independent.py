"""Benchmark that can fail: physics outside the catalogue, through ``ladder`` with its defaults (issue 22).

Records come from the independent generator ``tests/independent_sim.py`` (numpy only, no duffsym code),
with effects that have no catalogue form, each where it acts: seal friction whose level grows toward the
stroke ends, Stribeck friction (a static peak decaying with the piston speed), heating (the dissipated
energy warms the fluid: c2, c3 fall), a turbulent orifice force ``C p'|p'|`` and a polytropic gas spring
(1 % noise; ``-lowpass``/``-movavg``: the force pre-filtered as in published data sets; a ladder that judged a
low-pass filtered force in a band is scored against the generator's noise in that band). Also clean
records (false positives) and ``seal-friction@removed``: a catalogued effect (seal friction) hidden
while ``seal-friction`` and ``coulomb-friction`` are taken out of the catalogue — does discovery find
its form, ``tanh(d'/ε)``?

Each record goes through ``ladder(record)`` as a user runs it (discovery on by default, the SINDy
cross-check off: it never decides). Per record: does the ladder end within 2x the noise on the held-out
tail, and is a discovered term (or drifting parameter) named in words? Clean: is anything added?

    nice -n 10 python benchmarks/bench_discover_independent.py --seeds 10 --workers 2
    python benchmarks/bench_discover_independent.py --summarize

Writes ``benchmarks/results/discover_independent.json`` after every record (commit, settings, rows,
summary) and prints the per-case table and the confusion matrix (case x what the ladder ended with).
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

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
OUTSIDE = ("stroke-friction", "stribeck-friction", "heating", "orifice", "gas-spring")
LABELS = OUTSIDE + ("clean", "seal-friction@removed", "stribeck-friction-lowpass", "heating-movavg", "clean-lowpass",
                    "clean-movavg")
CLEAN = ("clean", "clean-lowpass", "clean-movavg")
REMOVED = ("seal-friction", "coulomb-friction")


def record(label: str, seed: int):
    sys.path.insert(0, str(HERE.parent / "tests"))
    import independent_sim as gen

    from duffsym.data.record import Record

    effects, kw = label.split("@")[0], {}
    if effects.endswith("-movavg"):
        effects, kw = effects[: -len("-movavg")], dict(filter_kind="movavg", filter_width=5)
    elif effects.endswith("-lowpass"):
        effects, kw = effects[: -len("-lowpass")], dict(filter_kind="lowpass", filter_width=15.0)
    g = gen.scenario(tuple(effects.split("+")), seed, **kw)
    return Record(t=g.t, d=g.d, y=g.y, name=f"{label}-{g.truth['kind']}-s{seed}", source="independent_sim"), g


def run(label: str, seed: int, screen=4) -> dict:
    import numpy as np

    from duffsym.diagnose import ladder
    from duffsym.effects import CATALOGUE

    rec, g = record(label, seed)
    cands = [c for c in CATALOGUE if c not in REMOVED] if label.endswith("@removed") else None
    t0 = time.perf_counter()
    lad = ladder(rec, candidates=cands, sindy=False, screen=screen)
    seconds = time.perf_counter() - t0
    last = lad.steps[-1]
    k = last.diagnosis.split["n_fit"]
    noise_held = g.noise_std / float(np.std(np.asarray(rec.y)[k:]))
    band = getattr(last.diagnosis.noise_estimate, "band", None)
    if band is not None:  # the ladder judged in a band (a low-pass filtered force): the noise in that band
        from scipy.signal import butter, filtfilt

        ba = butter(4, 2 * band)
        noise_held = float(np.std(filtfilt(*ba, g.y - g.y_clean)[k:]) / np.std(filtfilt(*ba, g.y)[k:]))
    found = [s.discovered for s in lad.steps if s.discovered]
    return dict(case=label, seed=seed, record=rec.name, kind=g.truth["kind"], seconds=seconds,
                effects=list(lad.effects), steps=[dict(effects=list(s.effects), nrmse_heldout=s.nrmse_heldout)
                                                  for s in lad.steps],
                nrmse_heldout_start=lad.steps[0].nrmse_heldout, nrmse_heldout_end=last.nrmse_heldout,
                noise_nrmse_heldout=noise_held, judging_band_hz=None if band is None else band / rec.dt, within_2x_noise=bool(last.nrmse_heldout <= 2 * noise_held),
                discovered=[dict(effect=f["effect"], words=f["words"], resembles=f["resembles"],
                                 params=f["params"], stderr=f["stderr"]) for f in found],
                named=bool(found and all(f["words"] for f in found)), stopped=lad.stopped,
                verdict=last.diagnosis.verdict, truth=g.truth["physics"])


def outcome(r: dict) -> str:
    """What the ladder ended with, for the confusion matrix."""
    if not r["effects"]:
        return "nothing"
    drift = any(e.startswith("drift:") for e in r["effects"])
    disc = any(e.startswith("discovered:") for e in r["effects"])
    cat = [e for e in r["effects"] if not e.startswith(("drift:", "discovered:"))]
    parts = (["drift"] if drift else []) + (["term"] if disc else []) + (["catalogue"] if cat else [])
    return "+".join(parts)


def success(r: dict) -> bool:
    if r["case"] in CLEAN:
        return not r["effects"]
    if r["case"].endswith("@removed"):
        return r["within_2x_noise"] and any("tanh(d'/" in d["effect"] for d in r["discovered"])
    return r["within_2x_noise"] and r["named"]


def summarise(rows: list[dict]) -> dict:
    out = {}
    for case in LABELS:
        rs = [r for r in rows if r["case"] == case]
        if not rs:
            continue
        ends = {}
        for r in rs:
            ends[outcome(r)] = ends.get(outcome(r), 0) + 1
        out[case] = dict(n=len(rs), success=sum(map(success, rs)), within_2x_noise=sum(r["within_2x_noise"] for r in rs),
                         named=sum(r["named"] for r in rs), ended_with=ends,
                         end_over_noise=[round(r["nrmse_heldout_end"] / r["noise_nrmse_heldout"], 2) for r in rs],
                         median_seconds=sorted(r["seconds"] for r in rs)[len(rs) // 2])
    outside = [r for r in rows if r["case"].split("-lowpass")[0].split("-movavg")[0] in OUTSIDE]
    if outside:
        out["outside_success_rate"] = sum(map(success, outside)) / len(outside)
    clean = [r for r in rows if r["case"] == "clean"]
    if clean:
        out["clean_false_positive_rate"] = sum(not success(r) for r in clean) / len(clean)
    for case, key in (("clean-lowpass", "clean_lowpass"), ("clean-movavg", "clean_movavg")):
        filtered = [r for r in rows if r["case"] == case]
        if filtered:
            out[f"{key}_false_positive_rate"] = sum(not success(r) for r in filtered) / len(filtered)
    return out


def print_table(summary: dict) -> None:
    cols = ["nothing", "catalogue", "term", "term+catalogue", "drift", "drift+catalogue", "drift+term+catalogue"]
    print(f"{'case':<28}{'ok':>6}{'<=2x':>6}{'named':>6}  " + "".join(c[:14].rjust(15) for c in cols) + "   end/noise")
    for case in LABELS:
        s = summary.get(case)
        if not s:
            continue
        cells = "".join(str(s["ended_with"].get(c, 0)).rjust(15) for c in cols)
        print(f"{case:<28}{s['success']:>3}/{s['n']:<2}{s['within_2x_noise']:>6}{s['named']:>6}  {cells}   "
              f"{', '.join(f'{q:.1f}' for q in s['end_over_noise'])}")
    for key in ("outside_success_rate", "clean_false_positive_rate"):
        if key in summary:
            print(f"{key}: {summary[key]:.0%}")


class _Job:
    def __init__(self, screen):
        self.screen = screen

    def __call__(self, job):
        return run(job[0], job[1], self.screen)


def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "HEAD"], cwd=HERE, capture_output=True, text=True).stdout.strip()
    except OSError:
        return ""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--screen", type=int, default=4)
    ap.add_argument("--only", help="comma-separated cases")
    ap.add_argument("--out", default=str(RESULTS / "discover_independent.json"))
    ap.add_argument("--summarize", action="store_true")
    args = ap.parse_args(argv)
    out_path = Path(args.out)
    if args.summarize:
        doc = json.loads(out_path.read_text())
        doc["summary"] = summarise(doc["runs"])
        out_path.write_text(json.dumps(doc, indent=1, default=float))
        print_table(doc["summary"])
        return 0
    labels = [s.strip() for s in args.only.split(",")] if args.only else list(LABELS)
    jobs = [(h, s) for s in range(args.first_seed, args.first_seed + args.seeds) for h in labels]
    rows: list[dict] = []
    t0 = time.perf_counter()
    out_path.parent.mkdir(parents=True, exist_ok=True)
    commit = _commit()  # the code the run started with (a later save must not record a newer HEAD)
    settings = dict(seeds=args.seeds, first_seed=args.first_seed, workers=args.workers, screen=args.screen,
                    cases=labels, ladder="defaults (discovery on), sindy=False")

    def save():
        doc = dict(benchmark="discover_independent", commit=commit, settings=settings,
                   date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), python=sys.version.split()[0],
                   machine=platform.machine(), cpus=os.cpu_count(), load=os.getloadavg(),
                   wall_seconds=time.perf_counter() - t0, summary=summarise(rows), runs=rows)
        tmp = out_path.with_suffix(".tmp")
        tmp.write_text(json.dumps(doc, indent=1, default=float))
        tmp.replace(out_path)
        return doc["summary"]

    from duffsym.engine import Engine

    with Engine(args.workers if args.workers > 1 else None) as engine:
        for res in engine.as_completed(_Job(args.screen), jobs):
            if not res.ok:
                print(f"failed: {res.error}", flush=True)
                continue
            rows.append(res.value)
            r = rows[-1]
            print(f"{r['case']:>28} seed {r['seed']:2d}: {r['effects']} end/noise "
                  f"{r['nrmse_heldout_end'] / r['noise_nrmse_heldout']:.1f} ok={success(r)} ({r['seconds']:.0f} s)",
                  flush=True)
            save()
    print_table(save())
    return 0


if __name__ == "__main__":
    sys.exit(main())
