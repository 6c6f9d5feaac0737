"""Study s14 — the paper's claim, measured: the Duffing-like model against the classical hysteresis models, on the
same real data with the same machinery (``duffsym.compare``, :mod:`duffsym.diagnose.compare`).

Part A — the **published Spencer parameters** re-simulated with duffsym's ``spencer`` model: (1) the UTFSM
authors' fit (design.md, "Facts measured after the second wave": alpha quadratic and c0, c1 linear in the current,
gamma = beta = p7 exp(p8 i), A = 300, n = 2), evaluated at each test's current and simulated from rest on the
full-rate record; their quoted NRMSEs are 0.079 (5 mm 3 Hz 1 A), 0.118 (10 mm 1 Hz 0.5 A), 0.169 (2 mm 5 Hz
0 A), 0.247 (25 mm 0.1 Hz 0 A). An independent check of the implementation. (2) Spencer et al.'s own Table 1
(the model's defaults, N/cm/V) on the Dyke record, the damper family they were identified on.

Part B — the **UTFSM campaign** (``Config.tests`` x ``Config.currents``, each record its first
``Config.max_cycles`` periods at ``Config.samples_per_period``): held out **by excitation** — the tests in
``Config.heldout_tests`` (at every current) are never used in training; the models are fitted on the others
(``eta`` held at ``Config.eta``: the records are at constant currents, so the field rate is not identifiable;
``spencer`` starts from the UTFSM authors' fit made linear in the current, :func:`utfsm_spencer_start`; the
others from duffsym's own starts) and scored by ``duffsym.identify.validate`` on the held-out tests.

Part C — the **Dyke record** (NEES 1996, voltage-driven, decimated by ``Config.dyke_decimation``): fitted on
``Config.dyke_fit_seconds`` s from the start, scored on ``Config.dyke_val_seconds`` s from the middle of the record.

Per data set: the held-out NRMSE of the best Duffing-like model and of the best classical model side by side,
the fraction of random starts reaching the best optimum, the fit time and the simulation cost per sample
(ratios measured in the same run). The Bouc–Wen benchmark and Silverbox are force-driven oscillators (input force,
output displacement): the classical damper laws here are driven by the displacement, and duffsym's structure
composition takes a two-state mechanical element, which the one-state Bouc–Wen law is not; they are not part of
this comparison (s13 scores the benchmark's own Bouc–Wen law as a reference element).

Default and long runs. The whole comparison (``Config.long()``: Spencer's model too, three starts per model) takes
10-45 minutes on 2 cores, mostly Spencer's UTFSM fit, which ends at IPOPT's iteration limit;
``benchmarks/bench_s14_model_comparison.py`` runs it and stores ``benchmarks/results/s14_model_comparison.json``
(:data:`STORED_NAME`). The default run (``duffsym reproduce``) compares the other three models from one start
and prints the stored long run's tables beside its own, and the summary figure marks them, naming the file,
date and commit, when the stored run was made with the same data settings.

Files: ``data/derived/s14_model_comparison.{npz,json}``; figures ``paper/figures/s14_model_comparison_utfsm.png``,
``..._dyke.png`` (the compare figure of each data set) and ``..._summary.png`` (best Duffing-like against best
classical); numbers ``paper/output/s14_*.tex``.
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as C  # noqa: E402

STUDY = "s14_model_comparison"
UTFSM = "mr_damper_utfsm_quiroz2022"
DYKE = "mr_damper_dyke_nees1996"
DYKE_COLUMNS = dict(time="t", input="D", output="F", velocity="V", voltage="Y")
#: The UTFSM authors' Spencer fit (design.md): p1..p12.
UTFSM_P = (1.50e-4, 1.239, 2.31e-3, -38.15, 41.51, 15.22, 1.894, -3.656, 7.626, 0.925, 78.34, 9.867)
UTFSM_QUOTED = (("5mm3Hz", 1.0, 0.079), ("10mm1Hz", 0.5, 0.118), ("2mm5Hz", 0.0, 0.169), ("25mm0x1Hz", 0.0, 0.247))
#: the long run's results, written by ``benchmarks/bench_s14_model_comparison.py`` (``Config.long()``)
STORED_NAME = "benchmarks/results/s14_model_comparison.json"
#: the data settings the stored run must share with this one to be shown beside it
SAME_SETTINGS = ("tests", "currents", "heldout_tests", "samples_per_period", "max_cycles", "eta", "dyke_decimation",
                 "dyke_fit_seconds", "dyke_val_seconds")
DUFFING_LIKE = ("mr-damper", "mr-damper-current", "mr-damper-current-quadratic", "mr-damper-current-saturating",
                "mr-damper-current-path-viscous", "duffing-like")


@dataclass(frozen=True)
class Config:
    """Settings of study s14 (see the module docstring)."""

    tests: tuple[str, ...] = ("2mm5Hz", "5mm3Hz", "10mm1Hz", "25mm0x25Hz")
    currents: tuple[float, ...] = (0.0, 0.5, 1.0)
    heldout_tests: tuple[str, ...] = ("5mm3Hz",)
    samples_per_period: int = 50
    max_cycles: float = 2.0
    eta: float = 100.0
    models: tuple[str, ...] = ("mr-damper-current", "bouc-wen-current", "bingham-current")
    n_starts: int = 1
    dyke: bool = True
    dyke_compare: bool = True
    dyke_decimation: int = 6
    dyke_fit_seconds: float = 1.5
    dyke_val_seconds: float = 2.0
    dyke_models: tuple[str, ...] = ("mr-damper-current", "bouc-wen-current", "bingham-current")
    stored: bool = True  # read the long run (STORED_NAME) when present and made with the same data settings

    @classmethod
    def long(cls) -> "Config":
        """The whole comparison: Spencer's model too, three starts per model
        (``benchmarks/bench_s14_model_comparison.py`` runs it)."""
        both = ("mr-damper-current", "spencer", "bouc-wen-current", "bingham-current")
        return cls(models=both, n_starts=3, dyke_models=both, stored=False)

    @classmethod
    def smoke(cls) -> "Config":
        """The published-parameter checks; two tests at two currents (one test held out) with the two fastest
        classical fits (static Bingham per current, constant Bouc-Wen), one start; no Dyke fit."""
        return cls(tests=("2mm5Hz", "5mm3Hz"), currents=(0.0, 1.0), heldout_tests=("5mm3Hz",), samples_per_period=25,
                   max_cycles=1.5, models=("bingham-current", "bouc-wen"), n_starts=1, dyke_compare=False,
                   stored=False)

    def summary(self) -> str:
        return (f"s14 config: UTFSM {len(self.tests)} tests x {len(self.currents)} currents (held out: "
                f"{', '.join(self.heldout_tests)}), {self.samples_per_period} samples/period, models "
                f"{', '.join(self.models)}, {self.n_starts} starts; Dyke fit {self.dyke_fit_seconds:g} s")


# ------------------------------------------------------------------------------------------- data
def _folder(name: str) -> Path | None:
    return C.external_folder(name)


def _test_file(test: str, current: float) -> Path:
    return _folder(UTFSM) / "sinusoidal_preprocessed" / f"{test}{f'{current:g}'.replace('.', 'x')}A.txt"


def utfsm_record(test: str, current: float, cfg: Config):
    """One test, decimated to ~``samples_per_period`` and cut to its first ``max_cycles`` periods."""
    from duffsym.data import Record, load_mr_damper_utfsm

    rec = load_mr_damper_utfsm(_test_file(test, current), velocity="derive")
    f = rec.metadata["frequency_hz"]
    q = max(1, int(math.floor(1.0 / (rec.dt * f * cfg.samples_per_period))))
    n = min(rec.n_times, int(round(cfg.max_cycles / (f * rec.dt))))
    v = np.asarray(rec.velocity())
    return Record(t=np.asarray(rec.t)[:n:q], d=np.asarray(rec.d)[:n:q], y=np.asarray(rec.y)[:n:q], d_dot=v[:n:q],
                  current=current, units=dict(rec.units), name=f"{test} {current:g}A")


def dyke_record(q: int):
    from duffsym.data import read_csv

    r = read_csv(_folder(DYKE) / "ranran_50_converted.csv", columns=DYKE_COLUMNS,
                 units={"time": "s", "input": "cm", "output": "N", "velocity": "cm/s", "voltage": "V"})
    return r.replace(t=r.t[::q], d=r.d[::q], y=r.y[::q], d_dot=r.d_dot[::q], command=r.command[::q],
                     name=f"dyke_q{q}")


# ------------------------------------------------------------------------------------------- part A
def utfsm_params(i: float) -> dict:
    """The UTFSM authors' coefficients at current i as ``spencer`` parameters (field slopes 0)."""
    p1, p2, p3, p4, p5, p6, p7, p8, p9, p10, p11, p12 = UTFSM_P
    g = p7 * math.exp(p8 * i)
    return dict(alpha=p4 * i * i + p5 * i + p6, alpha_u=0.0, c0=p9 * i + p10, c0_u=0.0, c1=p11 * i + p12, c1_u=0.0,
                k0=p1, k1=p2, x0=p3, gamma=g, beta=g, A=300.0, eta=190.0)


def published_checks(cfg: Config) -> dict:
    from duffsym.data import load_mr_damper_utfsm
    from duffsym.identify.result import nrmse
    from duffsym.model import get_model
    from duffsym.simulate import simulate

    model = get_model("spencer")
    out = {"utfsm": []}
    if _folder(UTFSM) is not None:
        for test, cur, quoted in UTFSM_QUOTED:
            rec = load_mr_damper_utfsm(_test_file(test, cur), velocity="derive")
            U = rec.inputs_for(model)
            row = {"test": test, "current": cur, "quoted": quoted}
            for how in ("linear", "hold"):
                tr = simulate(model, utfsm_params(cur), rec.t, U, x0=np.array([0.0, 0.0, cur]), reconstruction=how)
                row[f"nrmse_{how}"] = nrmse(rec.y, tr.y)
            out["utfsm"].append(row)
    if cfg.dyke and _folder(DYKE) is not None:
        rec = dyke_record(cfg.dyke_decimation)
        x0 = np.array([0.0, 0.0, float(rec.command[0])])
        tr = simulate(model, model.defaults(), rec.t, rec.inputs_for(model), x0=x0, on_failure="return")
        out["dyke_table1_nrmse"] = nrmse(rec.y, tr.y) if tr.success else math.inf
    return out


# ------------------------------------------------------------------------------------------- parts B, C
def _run_compare(label, train, held, models, cfg, fixed, arrays, starts=None) -> dict:
    from duffsym.diagnose.compare import compare, plot_comparison

    t0 = time.perf_counter()
    res = compare(train, list(models), validate=held, n_starts=cfg.n_starts, fixed=fixed, starts=starts,
                  progress=lambda m: print(f"[{label}] {m}", flush=True))
    for name, preds in res.predictions.items():
        for rec_name, y in preds.items():
            arrays[f"{label}|{name}|{rec_name}"] = np.asarray(y)
    for r in held:
        arrays[f"{label}|measured|{r.name}"] = np.asarray(r.y)
    import paths

    paths.figures_dir().mkdir(parents=True, exist_ok=True)
    plot_comparison(res, paths.figures_dir() / f"{STUDY}_{label}.png")
    return {**res.to_dict(), "seconds": time.perf_counter() - t0, "side_by_side": side_by_side(res)}


def side_by_side(res) -> dict:
    """Best Duffing-like and best classical model: held-out NRMSE, starts at the optimum, cost ratios."""
    ok = [s for s in res.scores if s.success and math.isfinite(s.heldout_nrmse)]
    duff = [s for s in ok if s.model in DUFFING_LIKE]
    cls_ = [s for s in ok if s.model not in DUFFING_LIKE]
    if not duff or not cls_:
        return {}
    a, b = min(duff, key=lambda s: s.heldout_nrmse), min(cls_, key=lambda s: s.heldout_nrmse)
    return {"duffing_like": a.model, "classical": b.model, "nrmse_duffing_like": a.heldout_nrmse,
            "nrmse_classical": b.heldout_nrmse, "starts_duffing_like": f"{a.starts_at_best}/{a.starts}",
            "starts_classical": f"{b.starts_at_best}/{b.starts}",
            "fit_time_ratio_classical_over_duffing": b.fit_seconds / max(a.fit_seconds, 1e-9),
            "sim_cost_ratio_classical_over_duffing": b.sim_seconds_per_sample / max(a.sim_seconds_per_sample, 1e-12),
            "substeps_duffing_like": a.substeps_max, "substeps_classical": b.substeps_max}


def utfsm_spencer_start() -> dict:
    """The UTFSM authors' fit as a start of ``spencer`` (linear in the current: alpha and gamma = beta through
    their values at 0 and 1 A, gamma at 0.5 A)."""
    lo, hi, mid = utfsm_params(0.0), utfsm_params(1.0), utfsm_params(0.5)
    out = {k: lo[k] for k in ("alpha", "c0", "c1", "k0", "k1", "x0")}
    out.update({f"{k}_u": hi[k] - lo[k] for k in ("alpha", "c0", "c1")}, gamma=mid["gamma"], beta=mid["beta"])
    return out


def published_on(held) -> dict:
    """The UTFSM authors' published Spencer fit on the same held-out (decimated) records, from rest: per record
    and pooled NRMSE (their parameters saw every test, so for them these records are not held out)."""
    from duffsym.identify.result import nrmse
    from duffsym.model import get_model
    from duffsym.simulate import simulate

    model, ys, yh, per = get_model("spencer"), [], [], {}
    for r in held:
        tr = simulate(model, utfsm_params(r.current), r.t, r.inputs_for(model), x0=np.array([0.0, 0.0, r.current]),
                      on_failure="return")
        per[r.name] = nrmse(r.y, tr.y)
        ys.append(np.asarray(r.y))
        yh.append(np.asarray(tr.y))
    y, y_hat = np.concatenate(ys), np.concatenate(yh)
    return {"records": per, "pooled": float(np.sqrt(np.mean((y - y_hat) ** 2)) / np.std(y))}


def compute_utfsm(cfg: Config, arrays: dict) -> dict:
    recs = {(t, c): utfsm_record(t, c, cfg) for t in cfg.tests for c in cfg.currents}
    train = [r for (t, _), r in recs.items() if t not in cfg.heldout_tests]
    held = [r for (t, _), r in recs.items() if t in cfg.heldout_tests]
    out = _run_compare("utfsm", train, held, cfg.models, cfg, {"eta": cfg.eta}, arrays,
                       starts={"spencer": utfsm_spencer_start()})
    out["published_spencer_on_heldout"] = published_on(held)
    return out


def compute_dyke(cfg: Config, arrays: dict) -> dict:
    rec = dyke_record(cfg.dyke_decimation)
    n_fit = int(round(cfg.dyke_fit_seconds / rec.dt))
    mid = rec.n_times // 2
    train = rec.slice(0, n_fit).replace(name="dyke fit")
    held = rec.slice(mid, mid + int(round(cfg.dyke_val_seconds / rec.dt))).replace(name="dyke validation")
    return _run_compare("dyke", [train], [held], cfg.dyke_models, cfg, {}, arrays)


def compute(cfg: Config) -> dict:
    meta, arrays = {"provenance": C.provenance(cfg)}, {}
    if _folder(UTFSM) is None and _folder(DYKE) is None:
        print("s14: the external MR damper data are absent (DUFFSYM_EXTERNAL_DATA); nothing to compare")
    meta["published"] = published_checks(cfg)
    if _folder(UTFSM) is not None:
        meta["utfsm"] = compute_utfsm(cfg, arrays)
    if cfg.dyke and cfg.dyke_compare and _folder(DYKE) is not None:
        meta["dyke"] = compute_dyke(cfg, arrays)
    if cfg.stored:
        meta["stored"] = stored_long(cfg)
    arrays.setdefault("empty", np.zeros(0))
    C.write_derived(STUDY, arrays, meta)
    return meta


def stored_long(cfg: Config) -> dict:
    """The long run's comparison (Spencer's model, three starts) from :data:`STORED_NAME`, when it was made with
    this run's data settings (:data:`SAME_SETTINGS`); else ``{"file": ..., "absent": reason}``. Reads both the
    benchmark's stamped file and the study's own derived JSON (``provenance.config``)."""
    import json

    import paths

    path = paths.repo_root() / STORED_NAME
    if not path.is_file():
        return {"file": STORED_NAME, "absent": f"{STORED_NAME} is absent (python benchmarks/bench_s14_model_comparison.py)"}
    doc = json.loads(path.read_text())
    prov = doc.get("provenance", {})
    theirs = prov.get("settings") or prov.get("config") or {}
    differ = [k for k in SAME_SETTINGS if theirs.get(k) != (list(v) if isinstance(v := getattr(cfg, k), tuple) else v)]
    if differ:
        return {"file": STORED_NAME, "absent": f"{STORED_NAME} was made with other settings ({', '.join(differ)})"}
    out = {"file": STORED_NAME, "commit": prov.get("commit") or prov.get("git_sha"), "date": prov.get("date"),
           "load": prov.get("load"), "models": theirs.get("models"), "n_starts": theirs.get("n_starts")}
    for k in ("utfsm", "dyke"):
        if k in doc:
            out[k] = {key: doc[k].get(key) for key in ("split", "table", "seconds", "side_by_side", "best")}
    return out


def stored_source(st: dict) -> str:
    when = f"run of {st['date']}, " if st.get("date") else ""
    return f"{st['file']} ({when}commit {(st.get('commit') or '?')[:7]}; {st.get('n_starts')} starts)"


def read() -> tuple[dict, dict]:
    return C.read_derived(STUDY)


# ------------------------------------------------------------------------------------------- outputs
def plot(results: dict | None = None) -> list:
    import paths

    _, meta = read()
    rows = [(k, meta[k]["side_by_side"]) for k in ("utfsm", "dyke") if meta.get(k, {}).get("side_by_side")]
    files = [paths.figures_dir() / f"{STUDY}_{k}.png" for k in ("utfsm", "dyke") if k in meta]
    if not rows:
        return files
    st = meta.get("stored") or {}
    with C.style() as plt:
        fig, ax = plt.subplots(figsize=(6.4, 3.8))
        x = np.arange(len(rows))
        n = meta["provenance"]["config"]["n_starts"]
        ax.bar(x - 0.18, [r["nrmse_duffing_like"] for _, r in rows], 0.36, label=f"best Duffing-like, this run "
               f"({n} start{'s' if n > 1 else ''})", color="0.3")
        ax.bar(x + 0.18, [r["nrmse_classical"] for _, r in rows], 0.36, label="best classical, this run", color="0.7")
        labels = [f"{k}\n{r['duffing_like']} | {r['classical']}" for k, r in rows]
        title = "held-out error: best Duffing-like vs best classical model (same fit, same data)"
        long = [(j, st[k]["side_by_side"]) for j, (k, _) in enumerate(rows) if (st.get(k) or {}).get("side_by_side")]
        if long:
            for j, r in long:
                ax.plot([j - 0.18, j + 0.18], [r["nrmse_duffing_like"], r["nrmse_classical"]], "D", color="tab:red",
                        ms=6, mfc="none", label="stored long run" if j == long[0][0] else None)
                labels[j] += f"\nlong run: {r['duffing_like']} | {r['classical']}"
            title += f"\nlong run (Spencer included): {stored_source(st)}"
        ax.set_xticks(x, labels, fontsize="x-small")
        ax.set_ylabel("held-out NRMSE")
        ax.set_title(title, fontsize="x-small")
        ax.legend(fontsize="x-small")
        files.append(C.save(fig, STUDY, "summary"))
    return files


def write_numbers(meta: dict) -> list:
    files = []
    for k in ("utfsm", "dyke"):
        sbs = meta.get(k, {}).get("side_by_side")
        if sbs:
            files.append(C.write_number(STUDY, f"{k}_duffing", f"{sbs['nrmse_duffing_like']:.3f}"))
            files.append(C.write_number(STUDY, f"{k}_classical", f"{sbs['nrmse_classical']:.3f}"))
    for row in meta.get("published", {}).get("utfsm", []):
        files.append(C.write_number(STUDY, f"published_{row['test']}", f"{row['nrmse_linear']:.3f}"))
    return files


def summarize(meta: dict) -> str:
    lines = ["s14: the UTFSM authors' Spencer parameters re-simulated (quoted / linear input / held input):"]
    for r in meta.get("published", {}).get("utfsm", []):
        lines.append(f"  {r['test']} {r['current']:g} A: {r['quoted']:.3f} / {r['nrmse_linear']:.3f} / "
                     f"{r['nrmse_hold']:.3f}")
    if "dyke_table1_nrmse" in meta.get("published", {}):
        lines.append(f"  Spencer et al.'s Table 1 on the Dyke record: NRMSE {meta['published']['dyke_table1_nrmse']:.3f}")
    for k in ("utfsm", "dyke"):
        if k in meta:
            lines.append(f"{k}: {meta[k]['split']}  ({meta[k]['seconds']:.0f} s)")
            lines += ["  " + ln for ln in meta[k]["table"].splitlines()[1:]]
            pub = meta[k].get("published_spencer_on_heldout")
            if pub:
                lines.append(f"  the UTFSM authors' published Spencer fit on the same records (from rest): pooled "
                             f"{pub['pooled']:.4f}; " + ", ".join(f"{n} {v:.4f}" for n, v in pub["records"].items()))
            sbs = meta[k].get("side_by_side")
            if sbs:
                lines.append(f"  best Duffing-like {sbs['duffing_like']} {sbs['nrmse_duffing_like']:.4f} vs best "
                             f"classical {sbs['classical']} {sbs['nrmse_classical']:.4f}; starts at the optimum "
                             f"{sbs['starts_duffing_like']} vs {sbs['starts_classical']}; classical/Duffing-like fit "
                             f"time x{sbs['fit_time_ratio_classical_over_duffing']:.2f}, simulation cost per sample "
                             f"x{sbs['sim_cost_ratio_classical_over_duffing']:.2f}")
    st = meta.get("stored") or {}
    if st.get("absent"):
        lines.append(f"the long run (Spencer's model, three starts) was not read: {st['absent']}")
    for k in ("utfsm", "dyke"):
        if st.get(k):
            lines.append(f"{k}, stored long run, read from {stored_source(st)}, not computed here "
                         f"(python benchmarks/bench_s14_model_comparison.py reruns it; {st[k]['seconds']:.0f} s):")
            lines += ["  " + ln for ln in (st[k]["table"] or "").splitlines()[1:]]
    return "\n".join(lines)


def main(argv=None) -> int:
    return C.run_study(argv, doc=__doc__, label="s14", config=Config, compute=compute, plot=plot,
                       write_numbers=write_numbers, summarize=summarize, read=read, announce=True)


if __name__ == "__main__":
    sys.exit(main())
