"""Study s11 — one model of the MR damper driven by its command (issue 17): the coil current or voltage as
a model input (``mr-damper-current``), one parameter set for a whole test campaign, and the random-voltage
Dyke record.

Model. Eq. 12 whose coefficients c1, c2, c3, k1, k2 are ``theta + theta_u g(u)`` and whose force scale is
``A_f (1 + A_f_u g(u))``, with a field u following the command i through u' = -eta (u - i) (Spencer et
al. 1997); g(u) = u (``linear``), u_sat tanh(u/u_sat) (``saturating``), or u plus a u^2 term
(``quadratic``). A_f = max|y| (the scaling symmetry), k3 = 0.

Part A — UTFSM campaign (Quiroz 2022; ``external_data_dir()/mr_damper_utfsm_quiroz2022``): the 30 sinusoid
tests (six amplitude/frequency pairs x 0, 0.25, 0.5, 0.75, 1 A), decimated as in s06 to about
``Config.samples_per_period`` samples per period (velocity derived at the full rate; 25 keeps each
all-test fit under about a minute on an idle 2-core machine, 8300 samples). Each field form is
fitted to all 30 tests at once (one parameter set; each test its own initial state; eta held at
``Config.campaign_eta``: a constant current does not show the field's lag), with the total stiffness
k1(u) + k2(u) >= 0 at u = 0 and 1 A. The form is chosen by BIC of that fit. Held-out error: for the chosen
form, ``Config.holdout`` = ``"excitation"`` refits without all five tests of one amplitude/frequency pair
and predicts them in free run (six folds: each test predicted by a model that never saw its excitation at
any current; a stricter split than leaving one test out, which keeps its excitation at the other four
currents), or ``"test"`` (30 folds, one test left out). The earthquake-type record (at 0.2, 0.4, 0.6, 0.8,
1 A; 0.2-0.8 A are currents the campaign never saw) is predicted by the all-30 model.

Part B — Dyke (NEES 1996; ``external_data_dir()/mr_damper_dyke_nees1996``): 74 068 samples at 3004.8 Hz of
random displacement and random command voltage (0 / 2.25 V switching). Decimated by
``Config.dyke_decimation`` (500 Hz; the data were anti-alias filtered at 100 Hz, and 1 kHz gave the same
validation error, 0.2207 vs 0.2192, at 40x the fit time), fitted on the first ``Config.dyke_fit_seconds`` s
and validated in free run on the second half of the record (never seen). Models in order: the base
``mr-damper-current``, then Eq. 12 with n = 3 and the effects that lowered the validation error when
added one after another (force offset: the load cell's zero; field asymmetry: the field rises about ten
times faster than it decays; input shift: a ~1.4 ms offset between the displacement and force channels).
Free runs are ``duffsym.identify.validate``'s (compiled RK4, with its reported fallback to the compiled
implicit ROS2 integrator when the stiff c3 x'^n term stops it); should both fail, the study re-simulates
with scipy's LSODA (rtol 1e-6) and says so in the output.
Reference: a windowed LSTM reached 49.5 N validation RMSE on this record (informal, see SOURCE.md).

Default and long runs. The whole study (``Config.long()``) takes about half an hour on 2 cores, mostly the six
hold-out refits; ``benchmarks/bench_s11_current_driven.py`` runs it and stores the result in
``benchmarks/results/s11_current_driven.json`` (:data:`STORED_NAME`). The default run (``duffsym reproduce``)
fits the linear form to all 30 tests, predicts the earthquake record and fits the Dyke sequence; the form
comparison, the hold-out and the slowest pair alone it reads from the stored file when that was made with the
same campaign settings, and says so (file, date, commit) in its output, the campaign figure's title and the
paper's text, with the largest difference between its own all-test fit and the stored one.

Files: ``data/derived/s11_current_driven.{npz,json}``; figures ``paper/figures/s11_current_driven_campaign.png``
(held-out NRMSE per test, with s06's per-test and per-current fits when s06's derived file exists) and
``..._dyke.png`` (measured and predicted force on the validation half); numbers ``paper/output/s11_*.tex``.
Without the external data the study prints how to get it and exits 0.
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

STUDY = "s11_current_driven"
DYKE = "mr_damper_dyke_nees1996"
DYKE_COLUMNS = dict(time="t", input="D", output="F", velocity="V", voltage="Y")
LSTM_RMSE_N = 49.46
GOAL_MEDIAN, GOAL_WORST = 0.10, 0.20
#: the long parts' results, written by ``benchmarks/bench_s11_current_driven.py`` (``Config.long()``)
STORED_NAME = "benchmarks/results/s11_current_driven.json"
#: the settings the stored results must share with this run to be used
SAME_SETTINGS = ("tests", "currents", "samples_per_period", "campaign_eta")


@dataclass(frozen=True)
class Config:
    """Settings of study s11 (see the module docstring).

    forms : field forms compared on the campaign (model names). holdout : "excitation" (6 folds) or "test"
    (30 folds) or "none". campaign_eta : the field rate held in the campaign fits (1/s).
    dyke_forms : models fitted to the Dyke record, in order ("NAME [n=N] [+EFFECT,...]", as
    ``duffsym fit --model NAME --n N --add EFFECT,...``): the base, then the effects that lowered the
    validation error (the last one is the figure's).
    """

    tests: tuple[str, ...] = ("2mm5Hz", "5mm3Hz", "10mm1Hz", "25mm0x5Hz", "25mm0x25Hz", "25mm0x1Hz")
    currents: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0)
    samples_per_period: int = 25
    forms: tuple[str, ...] = ("mr-damper-current",)
    holdout: str = "none"
    campaign_eta: float = 100.0
    earthquake: bool = True
    alone: bool = False            # also fit the slowest excitation's tests alone (is one parameter set the limit?)
    stored: bool = True            # read the long parts from the benchmark's results file (STORED) when present
    dyke: bool = True
    dyke_decimation: int = 6
    dyke_fit_seconds: float = 6.0
    dyke_forms: tuple[str, ...] = ("mr-damper-current",
                                   "mr-damper-current n=3 +force-offset,field-asymmetry,input-shift")
    dyke_val_seconds: float | None = None

    @classmethod
    def long(cls) -> "Config":
        """The whole study: both field forms, the six hold-out refits, the slowest pair alone, the earthquake
        record and the Dyke sequence (``benchmarks/bench_s11_current_driven.py`` runs it)."""
        return cls(forms=("mr-damper-current", "mr-damper-current-saturating"), holdout="excitation",
                   earthquake=True, alone=True, dyke=True, stored=False)

    @classmethod
    def smoke(cls) -> "Config":
        """Two tests at two currents, one form, no hold-out; a 1 s Dyke fit of the base model at 500 Hz."""
        return cls(tests=("2mm5Hz", "5mm3Hz"), currents=(0.0, 1.0), samples_per_period=25,
                   forms=("mr-damper-current",), holdout="none", earthquake=False, alone=False, dyke_decimation=6,
                   dyke_forms=("mr-damper-current",),
                   dyke_fit_seconds=1.0, dyke_val_seconds=1.0, stored=False)

    def summary(self) -> str:
        return (f"s11 config: campaign {len(self.tests)} tests x {len(self.currents)} currents at "
                f"~{self.samples_per_period} samples/period, forms {', '.join(self.forms)}, hold-out "
                f"{self.holdout}{'; the long parts read from ' + STORED_NAME if self.stored else ''}; "
                f"Dyke q={self.dyke_decimation}, fit {self.dyke_fit_seconds:g} s")


# ------------------------------------------------------------------------------------------- data
def _folder(name: str) -> Path | None:
    return C.external_folder(name)


def campaign_records(cfg: Config) -> list:
    """The decimated sinusoid tests (s06's loader), current as the record's constant command."""
    import s06_real_mr_damper as s06

    scfg = s06.Config(samples_per_period=cfg.samples_per_period)
    return [s06.load_test(t, c, scfg)[0] for t in cfg.tests for c in cfg.currents]


def dyke_record(q: int, *, full: bool = False):
    """The Dyke record, every ``q``-th sample (``full``: as read, at 3004.8 Hz)."""
    from duffsym.data import read_csv

    r = read_csv(_folder(DYKE) / "ranran_50_converted.csv", columns=DYKE_COLUMNS,
                 units={"time": "s", "input": "cm", "output": "N", "velocity": "cm/s", "voltage": "V"})
    if full:
        return r
    return r.replace(t=r.t[::q], d=r.d[::q], y=r.y[::q], d_dot=r.d_dot[::q], command=r.command[::q],
                     metadata={"decimation": q}, name=f"dyke_q{q}")


# ------------------------------------------------------------------------------------------- fits
def _constraints(model):
    """k1(u) + k2(u) >= 0 at u = 0, and at u = 1 for the linear form (a negative one has no equilibrium)."""
    cons = [({"k1": 1.0, "k2": 1.0}, 0.0, math.inf)]
    if model.name == "mr-damper-current":
        cons.append(({"k1": 1.0, "k2": 1.0, "k1_u": 1.0, "k2_u": 1.0}, 0.0, math.inf))
    return cons


def campaign_fit(model, recs, cfg: Config):
    from duffsym.identify import Problem, fit

    fixed = {"eta": cfg.campaign_eta}
    return fit(Problem(model, recs, fixed=fixed, constraints=_constraints(model)))


def bic(res) -> float:
    """n log(RSS/n) + k log n with RSS the fit's cost (squared output residuals of the collocation fit)."""
    n = res.n_samples
    return n * math.log(res.cost / n) + len(res.free) * math.log(n)


def free_run(res, rec, model):
    """Free-run prediction: ``duffsym.identify.validate`` (RK4, or ROS2 after a reported fallback); LSODA when
    both compiled integrators fail."""
    from duffsym.identify import validate
    from duffsym.identify.result import nrmse

    v = validate(res, rec, model)
    if v.success:
        ros = v.integrator.get("method") == "rosenbrock"
        return v.y_sim, v.nrmse, "compiled " + ("ROS2 (RK4 stopped)" if ros else "RK4")
    y = lsoda_free_run(model, model.param_vector(res.params), rec)
    return y, (nrmse(rec.y, y) if np.all(np.isfinite(y)) else math.inf), "LSODA (compiled run failed)"


def lsoda_free_run(model, p, rec) -> np.ndarray:
    """scipy LSODA over the whole record, inputs interpolated linearly, started from the data-based state."""
    from scipy.integrate import solve_ivp

    from duffsym.codegen.numpy_rhs import scalar_model
    from duffsym.identify import initial_states

    sm = scalar_model(model)
    t = np.asarray(rec.t)
    U = rec.input_matrix(model)
    dt = float(t[1] - t[0])

    def u_at(tt):
        k = min(max(int((tt - t[0]) / dt), 0), t.size - 2)
        w = (tt - t[k]) / (t[k + 1] - t[k])
        return U[k] + w * (U[k + 1] - U[k])

    x0 = initial_states(model, rec, p)[0]
    sol = solve_ivp(lambda tt, x: sm.rhs(x, u_at(tt), p), (t[0], t[-1]), x0, method="LSODA", t_eval=t,
                    rtol=1e-6, atol=1e-9, jac=lambda tt, x: sm.jac_states(x, u_at(tt), p))
    if not sol.success or sol.y.shape[1] != t.size:
        return np.full(t.size, np.nan)
    from duffsym.codegen.numpy_rhs import numpy_model

    return np.asarray(numpy_model(model).output(sol.y.T, U, p), dtype=float).reshape(-1)


# ------------------------------------------------------------------------------------------- compute
def compute_campaign(cfg: Config, arrays: dict) -> dict:
    recs = campaign_records(cfg)
    names = [r.name for r in recs]
    out: dict = {"records": names, "forms": {}}
    best, best_bic = None, math.inf
    for form in cfg.forms:
        model = model_of(form)
        t0 = time.perf_counter()
        res = campaign_fit(model, recs, cfg)
        wall = time.perf_counter() - t0
        b = bic(res)
        ins = [free_run(res, r, model) for r in recs]
        out["forms"][form] = dict(params=res.params, stderr=res.stderr, success=res.success, status=res.status,
                                  bic=b, n_samples=res.n_samples, n_free=len(res.free), wall_s=wall,
                                  nrmse_in_sample={n: e for n, (_, e, _) in zip(names, ins)},
                                  methods=sorted({m for _, _, m in ins}))
        print(f"  campaign {form}: {res.n_samples} samples, {len(res.free)} free, BIC {b:.1f}, in-sample NRMSE "
              f"median {np.median([e for _, e, _ in ins]):.3f} max {max(e for _, e, _ in ins):.3f}, {wall:.0f} s",
              flush=True)
        if b < best_bic:
            best, best_bic = (form, res, model), b
    form, res, model = best
    out["chosen"] = form
    out["heldout"], out["holdout_wall_s"] = holdout(cfg, recs, model, arrays)
    if cfg.earthquake:
        out["earthquake"] = earthquake(res, model, arrays)
    if cfg.alone:
        out["alone"] = fit_alone(cfg, recs, model, out["forms"][form]["nrmse_in_sample"])
    return out


def slowest(cfg: Config) -> str:
    """The test name of the lowest frequency (e.g. ``25mm0x1Hz``)."""
    return min(cfg.tests, key=lambda t: float(t.split("mm")[1].rstrip("Hz").replace("x", ".")))


def fit_alone(cfg: Config, recs, model, all_tests: dict) -> dict:
    """The slowest excitation's tests (all currents) fitted on their own, beside their in-sample error in the
    all-test fit: when they fit well alone but not with the others, one parameter set is what limits them."""
    name = slowest(cfg)
    sub = [r for r in recs if r.name.startswith(name)]
    res = campaign_fit(model, sub, cfg)
    out = {r.name: dict(alone=free_run(res, r, model)[1], all_tests=all_tests[r.name]) for r in sub}
    print(f"  {name} fitted alone: " + ", ".join(f"{k} {v['alone']:.3f} (all-test fit {v['all_tests']:.3f})"
                                                 for k, v in out.items()), flush=True)
    return {"test": name, "success": res.success, "records": out}


def _folds(cfg: Config, recs) -> list[list[int]]:
    if cfg.holdout == "excitation":
        return [[i for i, r in enumerate(recs) if r.name.startswith(t)] for t in cfg.tests]
    if cfg.holdout == "test":
        return [[i] for i in range(len(recs))]
    return []


def holdout(cfg: Config, recs, model, arrays) -> tuple[dict, float]:
    t0 = time.perf_counter()
    held = {}
    for fold in _folds(cfg, recs):
        train = [r for i, r in enumerate(recs) if i not in fold]
        res = campaign_fit(model, train, cfg)
        for i in fold:
            y, e, how = free_run(res, recs[i], model)
            held[recs[i].name] = dict(nrmse=e, method=how, fit_success=res.success)
            arrays[f"held_{recs[i].name}"] = np.asarray(y)
            print(f"    held out {recs[i].name}: NRMSE {e:.3f} ({how})", flush=True)
    return held, time.perf_counter() - t0


def stored_long(cfg: Config, camp: dict) -> dict:
    """The long parts (other field forms, hold-out refits, the slowest pair alone) from :data:`STORED_NAME`.

    Used only when the file was made with this run's campaign settings (:data:`SAME_SETTINGS`); ``same_fit`` is
    the largest difference between this run's in-sample NRMSE and the stored run's for the same form (0 when
    the package fits as it did then). Without a usable file: ``{"file": ..., "absent": reason}``.
    """
    import json

    import paths

    path = paths.repo_root() / STORED_NAME
    if not path.is_file():
        return {"file": STORED_NAME, "absent": f"{STORED_NAME} is absent (python benchmarks/bench_s11_current_driven.py)"}
    doc = json.loads(path.read_text())
    theirs = doc.get("config", {})
    differ = [k for k in SAME_SETTINGS if theirs.get(k) != (list(v) if isinstance(v := getattr(cfg, k), tuple) else v)]
    if differ:
        return {"file": STORED_NAME, "absent": f"{STORED_NAME} was made with other settings ({', '.join(differ)})"}
    them, prov = doc.get("campaign", {}), doc.get("provenance", {})
    mine = camp["forms"].get(them.get("chosen"), {}).get("nrmse_in_sample", {})
    stored_ins = them.get("forms", {}).get(them.get("chosen"), {}).get("nrmse_in_sample", {})
    same = max((abs(mine[k] - stored_ins[k]) for k in mine if k in stored_ins), default=None)
    return dict(file=STORED_NAME, commit=prov.get("commit"), date=prov.get("date"), load=prov.get("load"),
                holdout=theirs.get("holdout"), forms=them.get("forms", {}), chosen=them.get("chosen"),
                heldout=them.get("heldout", {}), holdout_wall_s=them.get("holdout_wall_s"), alone=them.get("alone"),
                total_s=doc.get("total_s"), same_fit=same)


def earthquake(res, model, arrays) -> dict:
    import s06_real_mr_damper as s06

    from duffsym.data import load_mr_damper_utfsm

    path = _folder(s06.DATASET) / "earthquake_validation" / "validacion.mat"
    out = {}
    if not path.is_file():
        return out
    for cur in (0.2, 0.4, 0.6, 0.8, 1.0):
        rec = s06._decimate(load_mr_damper_utfsm(path, current=cur), 5, f"validacion_{cur:g}A")
        y, e, how = free_run(res, rec, model)
        out[f"{cur:g}A"] = dict(nrmse=e, method=how)
        arrays[f"eq_{cur:g}A"] = np.asarray(y)
        print(f"    earthquake record at {cur:g} A: NRMSE {e:.3f} ({how})", flush=True)
    return out


def model_of(spec: str):
    """The model of a ``Config.forms`` or ``Config.dyke_forms`` entry: ``"NAME [n=N] [+EFFECT,...]"`` (effects of
    the catalogue or outside it, e.g. ``field-yield``)."""
    from duffsym.effects import ADDABLE, apply_effects
    from duffsym.model import get_model

    words = spec.split()
    n = next((int(w[2:]) for w in words[1:] if w.startswith("n=")), None)
    effects = next((w[1:].split(",") for w in words[1:] if w.startswith("+")), [])
    model = get_model(words[0], n)
    return apply_effects(model, [ADDABLE[e] for e in effects]) if effects else model


def compute_dyke(cfg: Config, arrays: dict) -> dict:
    from duffsym.identify import Problem, fit

    rec = dyke_record(cfg.dyke_decimation)
    n_fit = int(round(cfg.dyke_fit_seconds / rec.dt))
    n_val = None if cfg.dyke_val_seconds is None else rec.n_times // 2 + int(round(cfg.dyke_val_seconds / rec.dt))
    train, val = rec.slice(0, n_fit), rec.slice(rec.n_times // 2, n_val)
    from duffsym.data.sanity import check_record

    check = check_record(dyke_record(1, full=True))  # clipped or frozen stretches (issue 23): none in this file
    print(f"  {check.summary()}", flush=True)
    out = dict(n_fit=train.n_times, n_val=val.n_times, dt=rec.dt, val_start_s=float(val.t[0]),
               force_std_val=float(np.std(val.y)), data_check=check.to_dict(), forms={})
    arrays["dyke_t"], arrays["dyke_y"], arrays["dyke_cmd"] = (np.asarray(val.t), np.asarray(val.y),
                                                              np.asarray(val.command))
    for k, form in enumerate(cfg.dyke_forms):
        model = model_of(form)
        t0 = time.perf_counter()
        res = fit(Problem(model, train))
        wall = time.perf_counter() - t0
        y_fit, e_fit, how_fit = free_run(res, train, model)
        y, e, how = free_run(res, val, model)
        rmse = float(np.sqrt(np.mean((np.asarray(val.y) - y) ** 2)))
        out["forms"][form] = dict(params=res.params, stderr=res.stderr, status=res.status, fit_success=res.success,
                                  fit_message=res.message, wall_s=wall, nrmse_fit=e_fit, method_fit=how_fit,
                                  nrmse_val=e, rmse_val_N=rmse, method_val=how)
        arrays[f"dyke_pred_{k}"] = np.asarray(y)
        print(f"  Dyke {form}: fit {train.n_times} samples in {wall:.0f} s (status {res.status}); free run on the "
              f"fit part NRMSE {e_fit:.3f} ({how_fit}); validation NRMSE {e:.3f}, RMSE {rmse:.1f} N ({how})",
              flush=True)
    return out


def compute(cfg: Config) -> dict:
    t0 = time.perf_counter()
    arrays: dict[str, np.ndarray] = {}
    meta = dict(study=STUDY, **C.provenance(cfg))
    if _folder("mr_damper_utfsm_quiroz2022") is None and _folder(DYKE) is None:
        meta["missing"] = True
    if _folder("mr_damper_utfsm_quiroz2022") is not None:
        meta["campaign"] = compute_campaign(cfg, arrays)
        if cfg.stored:
            meta["campaign"]["stored"] = stored_long(cfg, meta["campaign"])
    if cfg.dyke and _folder(DYKE) is not None:
        meta["dyke"] = compute_dyke(cfg, arrays)
    meta["total_s"] = time.perf_counter() - t0
    files = C.write_derived(STUDY, arrays, meta)
    return dict(meta=meta, files=files)


def read() -> tuple[dict, dict]:
    return C.read_derived(STUDY)


# ------------------------------------------------------------------------------------------- outputs
def _s06_per_test() -> dict:
    """s06's per-test in-sample NRMSE and per-current leave-one-out, if its derived file exists."""
    try:
        _, meta = C.read_derived("s06_real_mr_damper")
    except (FileNotFoundError, OSError, ValueError):
        return {}
    return {"single": {k: f["nrmse"] for k, f in meta.get("fits", {}).items()},
            "loo": {k: f["nrmse"] for k, f in meta.get("loo", {}).items()}}


def plot(results: dict | None = None) -> list:
    _, meta = read()
    with C.style() as plt:
        return _plot_campaign(plt, meta) + _plot_dyke(plt, meta)


def long_parts(camp: dict) -> dict:
    """The form comparison, the hold-out and the slowest pair alone: this run's if it made them, else the stored
    benchmark run's (:func:`stored_long`); ``source`` is ``""`` for this run, else where they come from."""
    st = camp.get("stored") or {}
    if camp.get("heldout") or not st.get("heldout"):
        return dict(forms=camp["forms"], chosen=camp["chosen"], heldout=camp.get("heldout") or {},
                    alone=camp.get("alone"), holdout_wall_s=camp.get("holdout_wall_s"), source="")
    return dict(forms=st["forms"], chosen=st["chosen"], heldout=st["heldout"], alone=st.get("alone"),
                holdout_wall_s=st.get("holdout_wall_s"), source=stored_source(st))


def stored_source(st: dict) -> str:
    """``benchmarks/results/... (run of DATE, commit abcdef1)``."""
    return f"{st['file']} (run of {st.get('date') or '?'}, commit {(st.get('commit') or '?')[:7]})"


def _plot_campaign(plt, meta: dict) -> list:
    camp = meta.get("campaign")
    if not camp:
        return []
    long = long_parts(camp)
    names = camp["records"]
    held = [long["heldout"].get(n, {}).get("nrmse", math.nan) for n in names]
    ins = [camp["forms"][camp["chosen"]]["nrmse_in_sample"][n] for n in names]
    s06 = _s06_per_test()
    fig, ax = plt.subplots(figsize=(10, 4))
    x = np.arange(len(names))
    if long["heldout"]:
        where = " (stored benchmark run)" if long["source"] else ""
        ax.bar(x - 0.2, np.minimum(held, 1.0), 0.4, color="k", label=f"one model ({long['chosen']}), held out{where}")
    ax.plot(x + 0.2, ins, "s", color="0.5", ms=4, label="one model, in sample (this run)")
    if s06.get("single"):
        ax.plot(x, [s06["single"].get(n, math.nan) for n in names], "o", mfc="none", color="tab:blue", ms=5,
                label="s06: one fit per test (in sample)")
    ax.axhline(GOAL_MEDIAN, color="tab:green", ls="--", lw=0.8, label="goal: median 0.10")
    ax.axhline(GOAL_WORST, color="tab:red", ls=":", lw=0.8, label="goal: worst 0.20")
    ax.set_xticks(x, names, rotation=90, fontsize=7)
    ax.set_ylabel("free-run NRMSE")
    if long["heldout"]:
        title = (f"UTFSM campaign: one parameter set, each test predicted without its excitation "
                 f"(median {np.nanmedian(held):.3f}, worst {np.nanmax(held):.3f})")
        if long["source"]:
            title += f"\nheld out: {long['source']}; in sample: this run"
    else:
        title = (f"UTFSM campaign: one parameter set, in sample (median {np.median(ins):.3f}, worst "
                 f"{np.max(ins):.3f}); no hold-out in this run")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, ncol=2)
    return [C.save(fig, STUDY, "campaign")]


def _plot_dyke(plt, meta: dict) -> list:
    dyke = meta.get("dyke")
    if not (dyke and dyke.get("forms")):
        return []
    arrays, _ = read()
    forms = list(dyke["forms"])
    best, d = forms[-1], dyke["forms"][forms[-1]]
    t, y, cmd = arrays["dyke_t"], arrays["dyke_y"], arrays["dyke_cmd"]
    sl = np.flatnonzero(t <= t[0] + 1.0)  # the first second (or the whole part when shorter)
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 5), sharex=True, gridspec_kw=dict(height_ratios=(3, 1)))
    a1.plot(t[sl], y[sl], color="0.6", lw=1.6, label="measured")
    if len(forms) > 1:
        b = dyke["forms"][forms[0]]
        a1.plot(t[sl], arrays["dyke_pred_0"][sl], color="tab:blue", lw=0.7, ls="--",
                label=f"{forms[0]}: RMSE {b['rmse_val_N']:.0f} N")
    a1.plot(t[sl], arrays[f"dyke_pred_{len(forms) - 1}"][sl], color="k", lw=0.8,
            label=f"{best}: RMSE {d['rmse_val_N']:.0f} N ({d['method_val']})")
    a1.set_ylabel("force (N)")
    a1.legend(fontsize=7, loc="lower left")
    a1.set_title(f"Dyke record, validation half (never fitted), free run: NRMSE {d['nrmse_val']:.3f}, "
                 f"RMSE {d['rmse_val_N']:.0f} N (LSTM reference {LSTM_RMSE_N:g} N); "
                 f"first {t[sl][-1] - t[0]:.1f} s shown", fontsize=9)
    a2.plot(t[sl], cmd[sl], color="tab:orange", lw=0.8)
    a2.set_ylabel("command (V)")
    a2.set_xlabel("time (s)")
    return [C.save(fig, STUDY, "dyke")]


def _fmt(v) -> str:
    return "--" if v is None or not math.isfinite(v) else f"{v:.3f}"


def write_numbers(meta: dict) -> list:
    files = []
    camp = meta.get("campaign")
    if camp:
        long = long_parts(camp)
        ins = camp["forms"][camp["chosen"]]["nrmse_in_sample"]
        files += [C.write_number(STUDY, "insample_median", _fmt(float(np.median(list(ins.values()))))),
                  C.write_number(STUDY, "chosen_form", long["chosen"].replace("mr-damper-current", "linear")
                                 .replace("linear-", ""))]
        if long["heldout"]:
            held = [h["nrmse"] for h in long["heldout"].values()]
            files += [C.write_number(STUDY, "heldout_median", _fmt(float(np.median(held)))),
                      C.write_number(STUDY, "heldout_worst", _fmt(float(np.max(held))))]
        rows = [r"\begin{tabular}{lrr}\toprule test & one model, held out & one model, in sample\\\midrule"]
        for n in camp["records"]:
            rows.append(f"{n} & {_fmt(long['heldout'].get(n, {}).get('nrmse'))} & {_fmt(ins[n])}\\\\")
        rows.append(r"\bottomrule\end{tabular}")
        files.append(C.write_number(STUDY, "campaign_table", "\n".join(rows)))
    dyke = meta.get("dyke")
    if dyke and dyke.get("forms"):
        d = list(dyke["forms"].values())[-1]
        files += [C.write_number(STUDY, "dyke_nrmse", _fmt(d["nrmse_val"])),
                  C.write_number(STUDY, "dyke_rmse", f"{d['rmse_val_N']:.0f}")]
    files.append(C.write_number(STUDY, "campaign_text", campaign_text(meta)))
    files.append(C.write_number(STUDY, "dyke_text", dyke_text(meta)))
    return files


def _form(name: str) -> str:
    return name.replace("mr-damper-current", "linear").replace("linear-", "")


def _tex(text: str) -> str:
    return text.replace("_", "\\_")


def campaign_text(meta: dict) -> str:
    """The campaign's numbers as sentences for the paper (which run made each, said)."""
    camp = meta.get("campaign")
    if not camp:
        return "(The UTFSM data were absent when the study ran.)"
    long, st = long_parts(camp), camp.get("stored") or {}
    mine = camp["forms"]
    text = "This run fits " + "; ".join(
        f"the {_form(f)} form to all {len(camp['records'])} tests: in-sample free-run NRMSE median "
        f"{np.median(list(v['nrmse_in_sample'].values())):.3f}, worst {np.max(list(v['nrmse_in_sample'].values())):.3f} "
        f"(fit {v['wall_s']:.0f}\\,s)" for f, v in mine.items()) + "."
    if long["source"]:
        same, fit_name = st.get("same_fit"), _form(long["chosen"])
        if same is None:
            agree = ""
        elif same < 5e-4:
            agree = f"; its all-test {fit_name} fit gives this run's in-sample errors to within 5e-4"
        else:
            agree = f"; its all-test {fit_name} fit differs from this run's by up to {same:.2g} in a test's NRMSE"
        total = f", {st['total_s'] / 60:.0f}\\,min on the shared 2-core machine" if st.get("total_s") else ""
        text += (" The longer parts (the other field form, the six hold-out refits, the slowest pair fitted alone) "
                 "are the benchmark \\texttt{benchmarks/bench\\_s11\\_current\\_driven.py}; the numbers that follow are "
                 f"from its stored run, \\texttt{{{_tex(st['file'])}}} ({st.get('date')}, commit "
                 f"\\texttt{{{(st.get('commit') or '?')[:7]}}}{total}{agree}).")
    elif st.get("absent"):
        text += (f" The hold-out refits and the form comparison were not run: {_tex(st['absent'])}.")
    if len(long["forms"]) > 1:
        parts = [f"{_form(f)}: BIC {v['bic']:.0f}, in-sample NRMSE median "
                 f"{np.median(list(v['nrmse_in_sample'].values())):.3f}, worst "
                 f"{np.max(list(v['nrmse_in_sample'].values())):.3f}" for f, v in long["forms"].items()]
        text += " Field forms compared (" + "; ".join(parts) + f"); BIC chooses {long['chosen']}."
    if long["heldout"]:
        held = np.array([h["nrmse"] for h in long["heldout"].values()])
        text += (f" Held out (each amplitude/frequency pair left out at all five currents, six refits): median "
                 f"NRMSE {np.median(held):.3f} (goal 0.10), worst {held.max():.3f} (goal 0.20); "
                 f"{int(np.sum(held <= GOAL_MEDIAN))} of {held.size} tests at or below 0.10.")
    alone = long.get("alone")
    if alone:
        a = [v["alone"] for v in alone["records"].values()]
        b = [v["all_tests"] for v in alone["records"].values()]
        verdict = ("one parameter set for 0.1--5\\,Hz is what limits them (the element's rate dependence is not the "
                   "device's)" if np.median(b) > 1.5 * np.median(a) else "the all-test fit costs them little")
        text += (f" Fitted alone (all five currents), the {_pretty(alone['test'])} tests reach in-sample "
                 f"NRMSE {min(a):.3f}--{max(a):.3f}, against {min(b):.3f}--{max(b):.3f} in the all-test fit: {verdict}.")
    eq = camp.get("earthquake", {})
    if eq:
        text += (" The earthquake-type record, predicted by this run's all-test model: "
                 + ", ".join(f"{k} {v['nrmse']:.3f}" for k, v in eq.items())
                 + " (0.2--0.8\\,A are currents the campaign never saw).")
    return text


def _pretty(test: str) -> str:
    """``25mm0x1Hz`` -> ``25\\,mm 0.1\\,Hz``."""
    amp, freq = test.split("mm")
    return f"{amp}\\,mm {freq.rstrip('Hz').replace('x', '.')}\\,Hz"


def dyke_text(meta: dict) -> str:
    dyke = meta.get("dyke")
    if not dyke or not dyke.get("forms"):
        return "(The Dyke data were absent when the study ran.)"
    steps = "; ".join(f"\\texttt{{{f}}}: NRMSE {d['nrmse_val']:.3f}, RMSE {d['rmse_val_N']:.0f}\\,N (fit "
                      f"{d['wall_s']:.0f}\\,s{'' if d['fit_success'] else ', flagged: ' + d['status']})"
                      for f, d in dyke["forms"].items())
    d = list(dyke["forms"].values())[-1]
    return (f"The models are fitted to the first {dyke['n_fit']} samples ({dyke['n_fit'] * dyke['dt']:.1f}\\,s at "
            f"{1 / dyke['dt']:.0f}\\,Hz) and run free on the second half of the record, never fitted (force std "
            f"{dyke['force_std_val']:.0f}\\,N): {steps}. The reference is about {LSTM_RMSE_N:g}\\,N for a windowed "
            f"LSTM (informal). The free run of the last model on its fitted part gives NRMSE {d['nrmse_fit']:.3f}; "
            f"free runs by {d['method_val']}.")


def summarize(meta: dict) -> str:
    lines = [f"{STUDY}:"]
    camp = meta.get("campaign")
    if camp:
        long = long_parts(camp)
        for form, f in camp["forms"].items():
            e = list(f["nrmse_in_sample"].values())
            lines.append(f"  campaign {form} (this run): BIC {f['bic']:.1f}, in-sample NRMSE median {np.median(e):.3f}, "
                         f"worst {np.max(e):.3f}, fit {f['wall_s']:.0f} s")
        st = camp.get("stored") or {}
        if long["source"]:
            lines.append(f"  the long parts below are read from {long['source']}, not computed here "
                         f"(python benchmarks/bench_s11_current_driven.py reruns them); largest difference between "
                         f"its all-test fit and this run's in a test's in-sample NRMSE: {st.get('same_fit')}")
            for form, f in long["forms"].items():
                e = list(f["nrmse_in_sample"].values())
                lines.append(f"  campaign {form} (stored): BIC {f['bic']:.1f}, in-sample NRMSE median {np.median(e):.3f}, "
                             f"worst {np.max(e):.3f}, fit {f['wall_s']:.0f} s")
        elif st.get("absent"):
            lines.append(f"  no hold-out: {st['absent']}")
        lines.append(f"  chosen by BIC: {long['chosen']}")
        if long["heldout"]:
            held = [h["nrmse"] for h in long["heldout"].values()]
            lines.append(f"  held out (by excitation): median {np.median(held):.3f} (goal "
                         f"{GOAL_MEDIAN}), worst {np.max(held):.3f} (goal {GOAL_WORST}); folds took "
                         f"{long['holdout_wall_s']:.0f} s")
        if long.get("alone"):
            al = long["alone"]["records"]
            lines.append(f"  {long['alone']['test']} fitted alone: in-sample NRMSE "
                         + ", ".join(f"{k} {v['alone']:.3f} (all-test fit {v['all_tests']:.3f})" for k, v in al.items()))
        for k, v in camp.get("earthquake", {}).items():
            lines.append(f"  earthquake record {k}: NRMSE {v['nrmse']:.3f} ({v['method']})")
    dyke = meta.get("dyke")
    if dyke:
        for form, d in dyke["forms"].items():
            lines.append(f"  Dyke {form}: validation NRMSE {d['nrmse_val']:.3f}, RMSE {d['rmse_val_N']:.1f} N "
                         f"(LSTM reference {LSTM_RMSE_N} N; force std {dyke['force_std_val']:.0f} N) by "
                         f"{d['method_val']}; fit {d['wall_s']:.0f} s on {dyke['n_fit']} samples")
    if meta.get("missing"):
        lines.append("  external data absent: set DUFFSYM_EXTERNAL_DATA (see duffsym.data.external_data_dir)")
    return "\n".join(lines)


def main(argv=None, smoke: bool | None = None) -> int:
    if smoke is not None:
        argv = ["--smoke"] if smoke else []
    return C.run_study(argv, doc=__doc__, label=STUDY, config=Config, compute=compute, plot=plot,
                       write_numbers=write_numbers, summarize=summarize, read=read, announce=True)


if __name__ == "__main__":
    sys.exit(main())
