"""Benchmark: the diagnosis on data with a hidden effect — confusion matrix, recovery, error fall.

Default source (issue 16): records made by the *independent generator* ``tests/independent_sim.py``
(numpy only, no duffsym code: the paper's Eq. 12 integrated by RK4 at 20 substeps per sample, each
effect placed where the physics acts — exact play on the actuator path, seal friction on the piston
velocity, accumulator on the piston displacement, lag on the load cell, ...; Table 2 rows perturbed
by +-10 %, sine / multisine / random inputs, 1 % noise; optionally pre-filtered). Each record is
diagnosed as a user would: ``diagnose(record)`` with the defaults (``A_f = max|y|``, the whole
catalogue, 30 % held out; the SINDy cross-check off, it never decides). Two-effect records
(``--pairs``, and a triple: offset, inertia and seal friction) go through ``ladder``: does it find every
one, and does it end within 2x the noise?

    python benchmarks/bench_diagnose.py --seeds 3 --workers 2                 # independent, single effects
    python benchmarks/bench_diagnose.py --seeds 3 --pairs --workers 2         # two-effect ladders
    python benchmarks/bench_diagnose.py --source scenarios --seeds 10         # the old, secondary table

Cost: one record is one full-catalogue diagnosis (13 candidates, a screening fit each, second starts and
continuations; ~5 s CPU on an idle core for the 801-sample records). The records run on
``duffsym.engine`` (``--workers 2``: a dask LocalCluster, one record per worker), seed by seed, and every
finished record is saved at once, so a run cut short still holds whole seeds; run it niced
(``nice -n 10``) on a shared machine. ``--first-seed``/``--seeds`` split a long run into parts that
``--summarize`` of a merged file reports together. On an idle 2-core machine 26 records took 119 s
with 2 workers; the 10-seed table (130 records) took about 90 minutes on the shared machine at a load
average of 15-23 (benchmarks/README.md).

The old source (``--source scenarios``, issue 4) is kept only as a secondary table: its records are
made by ``duffsym.effects`` itself, the code under test, so it cannot see an effect placed elsewhere.

Issue 4, "Done when": for every catalogued effect, synthetic data with that effect hidden (sine,
multisine and band-limited random inputs; Table 2 rows cycling with the seed; 1 % white output
noise; 800 samples at dt = 0.005 s) must be diagnosed with the right effect first, its parameter
recovered and the held-out NRMSE at least halved; clean data must give no false positive; data
with an effect outside the catalogue (damping drifting over the record) must not get a confident
wrong verdict. Targets: top-1 >= 90 %, false positives on clean data <= 10 %.

Every record is diagnosed exactly as ``duffsym diagnose`` does (the whole catalogue tried, 30 %
held out), with one difference: ``A_f`` is fixed at its true value instead of ``max|y|``, so the
effects acting on the internal velocity (friction, asymmetry) are recovered in the truth's units
and can be compared with it (the scaling symmetry makes A_f a free choice; the verdicts do not
depend on it).

    python benchmarks/bench_diagnose.py --seeds 10 --workers 2      # the full matrix
    python benchmarks/bench_diagnose.py --seeds 1 --only backlash   # one scenario

Writes ``benchmarks/results/diagnose.json`` (every run's verdict, candidates and timings) and
prints the confusion matrix.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from pathlib import Path
from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
OUT_OF_CATALOGUE = "drift"


#: generator effect -> the parameter of the catalogue effect it should be recovered as (same units)
RECOVER = {"force-offset": ("off_y0", "offset"), "gas-accumulator": ("gas_k", "gas_stiffness"),
           "inertia": ("inertia_m", "inertia"), "seal-friction": ("seal_F", "seal_friction"),
           "asymmetry": ("asym_a", "asymmetry"), "output-lag": ("lag_tau", "lag"),
           "input-delay": ("delay_tau", "delay"), "backlash": ("bl_h", "backlash")}
PAIRS = (("seal-friction", "backlash"), ("force-offset", "output-lag"), ("gas-accumulator", "asymmetry"),
         ("force-offset", "inertia", "seal-friction"))  # and a triple: three catalogued effects at once
PREFILTERED = ("clean-movavg", "seal-friction-lowpass")


def independent_record(label: str, seed: int):
    """A generator record for ``label`` (an effect, "clean", "drift", a pair "a+b", or a pre-filtered
    variant "clean-movavg" / "seal-friction-lowpass") and the generator's truth."""
    sys.path.insert(0, str(HERE.parent / "tests"))
    import independent_sim as gen

    from duffsym.data.record import Record

    kw = {}
    effects = label
    if label.endswith("-movavg"):
        effects, kw = label[: -len("-movavg")], dict(filter_kind="movavg", filter_width=5)
    elif label.endswith("-lowpass"):
        effects, kw = label[: -len("-lowpass")], dict(filter_kind="lowpass", filter_width=15.0)
    g = gen.scenario(tuple(effects.split("+")), seed, **kw)
    rec = Record(t=g.t, d=g.d, y=g.y, name=f"{label}-{g.truth['kind']}-s{seed}", source="independent_sim")
    return rec, g


def run_independent(label: str, seed: int, screen=4) -> dict:
    import numpy as np

    from duffsym.diagnose import diagnose

    rec, g = independent_record(label, seed)
    t0 = time.perf_counter()
    dg = diagnose(rec, screen=screen, sindy=False)
    seconds = time.perf_counter() - t0
    k = dg.split["n_fit"]
    y = np.asarray(rec.y)
    noise_held = g.noise_std / float(np.std(y[k:]))
    best = dg.best
    hidden = label.split("-movavg")[0].split("-lowpass")[0]
    ok = [c for c in dg.candidates if c.success]
    row = dict(hidden=label, seed=seed, record=rec.name, kind=g.truth["kind"], voltage=g.truth["voltage"],
               seconds=seconds, top1=best.effect if best else None, needed=list(dg.needed), verdict=dg.verdict,
               nrmse_heldout_base=dg.nrmse_heldout, noise_nrmse_heldout=noise_held, noise_estimate=dg.noise,
               noise_true=g.noise_std,
               rank_of_truth=next((i + 1 for i, c in enumerate(ok) if c.effect == hidden), None),
               candidates=[dict(effect=c.effect, nrmse_after=c.nrmse_after, delta_bic=c.delta_bic,
                                explained=c.explained, params=c.params, stderr=c.stderr, success=c.success,
                                needed=c.needed, supported=c.supported, seconds=c.seconds, message=c.message,
                                start=getattr(c, "start", 1), stable=getattr(c, "stable", None),
                                diverged=getattr(c, "diverged", False))
                           for c in dg.candidates],
               noise_method=getattr(dg, "noise_method", ""), base_check=dg.base_check.to_dict() if dg.base_check else {})
    if hidden in RECOVER or hidden == "coulomb-friction":
        mine = next((c for c in dg.candidates if c.effect == hidden and c.success), None)
        row["heldout_ratio"] = mine.nrmse_after / dg.nrmse_heldout if mine else math.nan
        row["recovered"] = None
        if mine is not None and hidden in RECOVER:
            pname, gname = RECOVER[hidden]
            row["recovered"] = {pname: dict(true=g.truth["physics"][gname], fitted=mine.params.get(pname, math.nan),
                                            stderr=mine.stderr.get(pname, math.nan))}
        row["correct_top1"] = bool(best is not None and best.effect == hidden and hidden in dg.needed)
    else:
        row["false_positive"] = bool(dg.needed)
    return row


def run_pair(label: str, seed: int, screen=4) -> dict:
    import numpy as np

    from duffsym.diagnose import ladder

    rec, g = independent_record(label, seed)
    t0 = time.perf_counter()
    lad = ladder(rec, screen=screen, sindy=False)
    seconds = time.perf_counter() - t0
    want = set(label.split("+"))
    last = lad.steps[-1]
    k = last.diagnosis.split["n_fit"]
    noise_held = g.noise_std / float(np.std(np.asarray(rec.y)[k:]))
    return dict(hidden=label, seed=seed, record=rec.name, kind=g.truth["kind"], seconds=seconds,
                effects=list(lad.effects), found_both=want <= set(lad.effects),
                steps=[dict(effects=list(s.effects), nrmse_heldout=s.nrmse_heldout) for s in lad.steps],
                nrmse_heldout_end=last.nrmse_heldout, noise_nrmse_heldout=noise_held,
                within_2x_noise=bool(last.nrmse_heldout <= 2 * noise_held), stopped=lad.stopped)


def run_one(hidden: str, seed: int, screen=4) -> dict:
    import numpy as np

    from duffsym.diagnose import diagnose
    from duffsym.diagnose.scenarios import HIDDEN, hidden_effect_record, noise_nrmse

    rec = hidden_effect_record(hidden, seed)
    truth = rec.metadata["truth"]
    t0 = time.perf_counter()
    dg = diagnose(rec, fixed={"A_f": truth["A_f"]}, screen=screen)
    seconds = time.perf_counter() - t0
    k = dg.split["n_fit"]
    best = dg.best
    row = dict(hidden=hidden, seed=seed, record=rec.name, scenario=rec.metadata["scenario"], seconds=seconds,
               top1=best.effect if best else None, needed=list(dg.needed), verdict=dg.verdict,
               nrmse_heldout_base=dg.nrmse_heldout, noise_nrmse_heldout=noise_nrmse(rec, slice(k, None)),
               candidates=[dict(effect=c.effect, nrmse_after=c.nrmse_after, delta_bic=c.delta_bic,
                                explained=c.explained, params=c.params, stderr=c.stderr, success=c.success,
                                needed=c.needed, supported=c.supported, seconds=c.seconds) for c in dg.candidates])
    if hidden in HIDDEN:
        mine = next((c for c in dg.candidates if c.effect == hidden), None)
        if mine is not None and mine.success:
            row["recovered"] = {p: dict(true=v, fitted=mine.params.get(p, math.nan), stderr=mine.stderr.get(p, math.nan))
                                for p, v in HIDDEN[hidden].items()}
            row["heldout_ratio"] = mine.nrmse_after / dg.nrmse_heldout
        else:
            row["recovered"] = None
            row["heldout_ratio"] = math.nan
        row["correct_top1"] = bool(best is not None and best.effect == hidden and hidden in dg.needed)
    else:
        row["false_positive"] = bool(dg.needed)
    del np
    return row


def _tied(r: dict) -> bool:
    """The hidden effect is needed and indistinguishable from the called one on this record
    (held-out NRMSE within 5 % and dBIC within 2)."""
    best = next((c for c in r["candidates"] if c["success"]), None)
    mine = next((c for c in r["candidates"] if c["effect"] == r["hidden"] and c["success"]), None)
    return bool(best and mine and mine["needed"] and mine["nrmse_after"] <= 1.05 * best["nrmse_after"]
                and abs(mine["delta_bic"] - best["delta_bic"]) <= 2.0)


def _undetectable(r: dict) -> bool:
    """The base model already fits the held-out data to the noise (the hidden effect is absorbed
    by the base parameters on this input): nothing is there to find."""
    return r["nrmse_heldout_base"] <= 1.1 * r["noise_nrmse_heldout"]


def _effects(source: str) -> list[str]:
    if source == "scenarios":
        from duffsym.diagnose.scenarios import HIDDEN

        return list(HIDDEN)
    sys.path.insert(0, str(HERE.parent / "tests"))
    import independent_sim as gen

    return list(gen.EFFECTS) + ["seal-friction-lowpass"]


def _others(source: str) -> list[str]:
    return ["clean", OUT_OF_CATALOGUE] + (["clean-movavg"] if source == "independent" else [])


def summarise(rows: list[dict], source: str = "scenarios") -> dict:
    HIDDEN = _effects(source)
    rows = [r for r in rows if "+" not in r["hidden"]]
    labels = list(HIDDEN) + _others(source)
    out = {}
    for h in labels:
        rs = [r for r in rows if r["hidden"] == h]
        if not rs:
            continue
        calls: dict[str, int] = {}
        for r in rs:
            key = r["needed"][0] if r["needed"] else "(none needed)"
            calls[key] = calls.get(key, 0) + 1
        s = dict(n=len(rs), calls=calls, median_seconds=sorted(r["seconds"] for r in rs)[len(rs) // 2])
        if h in HIDDEN:
            s["top1_rate"] = sum(r["correct_top1"] for r in rs) / len(rs)
            s["top1_or_tied_rate"] = sum(r["correct_top1"] or _tied(r) for r in rs) / len(rs)
            s["undetectable"] = sum(_undetectable(r) for r in rs)
            det = [r for r in rs if not _undetectable(r)]
            s["top1_or_tied_detectable_rate"] = (sum(r["correct_top1"] or _tied(r) for r in det) / len(det)
                                                 if det else math.nan)
            ratios = [r["heldout_ratio"] for r in rs if r.get("heldout_ratio") is not None
                      and math.isfinite(r["heldout_ratio"])]
            s["halved_rate"] = sum(q <= 0.5 for q in ratios) / len(rs)
            ranks = [r.get("rank_of_truth") for r in rs if "rank_of_truth" in r]
            if ranks:
                s["truth_ranked_below_another"] = sum(q is None or q > 1 for q in ranks)
            s["median_heldout_ratio"] = sorted(ratios)[len(ratios) // 2] if ratios else math.nan
            rel = []
            for r in rs:
                for p, v in (r.get("recovered") or {}).items():
                    rel.append(abs(v["fitted"] - v["true"]) / abs(v["true"]))
            s["median_param_rel_error"] = sorted(rel)[len(rel) // 2] if rel else math.nan
        else:
            s["needed_rate"] = sum(bool(r["needed"]) for r in rs) / len(rs)
        out[h] = s
    effects = [h for h in HIDDEN if h in out]
    if effects:
        n_all = sum(out[h]["n"] for h in effects)
        out["overall_top1"] = sum(out[h]["top1_rate"] * out[h]["n"] for h in effects) / n_all
        out["overall_top1_or_tied"] = sum(out[h]["top1_or_tied_rate"] * out[h]["n"] for h in effects) / n_all
        det = [r for r in rows if r["hidden"] in HIDDEN and not _undetectable(r)]
        out["overall_top1_or_tied_detectable"] = (sum(r["correct_top1"] or _tied(r) for r in det) / len(det)
                                                  if det else math.nan)
        out["n_undetectable"] = len(rows) - len(det) - sum(1 for r in rows if r["hidden"] not in HIDDEN)
    return out


def summarise_pairs(rows: list[dict]) -> dict:
    out = {}
    for label in sorted({r["hidden"] for r in rows if "+" in r["hidden"]}):
        rs = [r for r in rows if r["hidden"] == label]
        want = set(label.split("+"))
        # gas-accumulator's preload is the force-offset parameter itself (one term on one record)
        cover = [set(r["effects"]) | ({"force-offset"} if "gas-accumulator" in r["effects"] else set()) for r in rs]
        out[label] = dict(n=len(rs), found_both=sum(r["found_both"] for r in rs),
                          found_both_counting_gas_as_offset=sum(want <= c for c in cover),
                          within_2x_noise=sum(r["within_2x_noise"] for r in rs),
                          ended_with=[r["effects"] for r in rs],
                          end_over_noise=[r["nrmse_heldout_end"] / r["noise_nrmse_heldout"] for r in rs])
    return out


def print_pairs(pairs: dict) -> None:
    for label, s in pairs.items():
        ratios = ", ".join(f"{q:.1f}" for q in s["end_over_noise"])
        print(f"{label:<34} found both {s['found_both']}/{s['n']} "
              f"({s.get('found_both_counting_gas_as_offset', s['found_both'])} counting gas-accumulator as the offset)  within 2x noise {s['within_2x_noise']}/{s['n']}  "
              f"end/noise: {ratios}  ended with {s['ended_with']}")


def print_matrix(summary: dict, source: str = "scenarios") -> None:
    HIDDEN = _effects(source)
    called = {c for h, v in summary.items() if isinstance(v, dict) for c in v.get("calls", {})}
    base = [h for h in HIDDEN if not h.endswith(("-lowpass", "-movavg"))]
    cols = base + sorted(called - set(base) - {"(none needed)"}) + ["(none needed)"]
    print("hidden \\ called".ljust(18) + "".join(c[:9].rjust(10) for c in cols) + "   top1  +tied  halved  undet.")
    for h in list(HIDDEN) + _others(source):
        if h not in summary:
            continue
        s = summary[h]
        cells = "".join(str(s["calls"].get(c, 0)).rjust(10) for c in cols)
        extra = (f"  {s['top1_rate']:5.0%}  {s['top1_or_tied_rate']:5.0%}  {s['halved_rate']:5.0%}  "
                 f"{s['undetectable']:5d}") if "top1_rate" in s else \
            f"  needed in {s['needed_rate']:.0%}"
        print(h[:17].ljust(18) + cells + extra)
    if "overall_top1" in summary:
        print(f"overall top-1: {summary['overall_top1']:.0%}; top-1 or tied: {summary['overall_top1_or_tied']:.0%}; "
              f"top-1 or tied where detectable: {summary['overall_top1_or_tied_detectable']:.0%} "
              f"({summary['n_undetectable']} records where the base model already fits to the noise)")


class _Job:
    """One (hidden effect, seed) record through ``runner``: picklable, for the engine's workers."""

    def __init__(self, runner, screen):
        self.runner, self.screen = runner, screen

    def __call__(self, job):
        hidden, seed = job
        return self.runner(hidden, seed, self.screen)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--scheduler", default=None, help="address of a running Dask scheduler (overrides --workers)")
    ap.add_argument("--screen", default="4", help="candidates continued after the screening budget, or 'all'")
    ap.add_argument("--only", help="comma-separated scenarios (effects, clean, drift)")
    ap.add_argument("--source", choices=("independent", "scenarios"), default="independent",
                    help="independent generator (default) or duffsym.diagnose.scenarios (the old, circular table)")
    ap.add_argument("--pairs", action="store_true", help="two-effect records through the ladder")
    ap.add_argument("--out", default=None)
    ap.add_argument("--summarize", action="store_true", help="recompute the summary of an existing --out file")
    args = ap.parse_args(argv)
    if args.out is None:
        name = "diagnose.json" if args.source == "scenarios" else (
            "diagnose_independent_pairs.json" if args.pairs else "diagnose_independent.json")
        args.out = str(RESULTS / name)
    if args.summarize:
        doc = json.loads(Path(args.out).read_text())
        src = doc.get("source", "scenarios")
        doc["summary"] = summarise(doc["runs"], src)
        doc["pairs"] = summarise_pairs(doc["runs"])
        Path(args.out).write_text(json.dumps(doc, indent=1, default=float, allow_nan=True))
        print_matrix(doc["summary"], src)
        print_pairs(doc["pairs"])
        return 0
    screen = None if args.screen == "all" else int(args.screen)
    labels = _effects(args.source) + _others(args.source)
    if args.pairs:
        labels = ["+".join(p) for p in PAIRS]
    if args.only:
        labels = [s.strip() for s in args.only.split(",")]
    jobs = [(h, s) for s in range(args.first_seed, args.first_seed + args.seeds) for h in labels]
    rows = []
    t0 = time.perf_counter()
    out_path = Path(args.out)
    out_path.parent.mkdir(parents=True, exist_ok=True)

    def save():
        summary = summarise(rows, args.source)
        doc = dict(benchmark="diagnose", source=args.source, date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                   pairs=summarise_pairs(rows), screen=args.screen, python=sys.version.split()[0], machine=platform.machine(),
                   cpus=os.cpu_count(), workers=args.workers, wall_seconds=time.perf_counter() - t0,
                   summary=summary, runs=rows)
        out_path.write_text(json.dumps(stamp(doc, args), indent=1, default=float, allow_nan=True))
        return summary

    runner = run_one if args.source == "scenarios" else (run_pair if args.pairs else run_independent)

    def report(r):
        if "found_both" in r:
            print(f"{r['hidden']:>30} seed {r['seed']:2d}: ladder {r['effects']} end/noise "
                  f"{r['nrmse_heldout_end'] / r['noise_nrmse_heldout']:.1f} ({r['seconds']:.0f} s)", flush=True)
        else:
            print(f"{r['hidden']:>22} seed {r['seed']:2d}: called {r['needed'] or '-'} top {r['top1']} "
                  f"({r['seconds']:.0f} s)", flush=True)

    # the package's engine (dask.distributed LocalCluster with --workers N >= 2, or a running cluster
    # with --scheduler); serial in this process otherwise
    from duffsym.engine import Engine

    workers = args.workers if args.workers > 1 else None
    with Engine(workers, scheduler=args.scheduler) as engine:
        for outcome in engine.as_completed(_Job(runner, screen), jobs):
            if not outcome.ok:
                raise outcome.error
            rows.append(outcome.value)
            report(rows[-1])
            save()
    summary = save()
    print_matrix(summary, args.source)
    print_pairs(summarise_pairs(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
