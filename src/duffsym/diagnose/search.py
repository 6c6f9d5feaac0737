"""Which catalogued effect is missing: refit with each candidate added, judge on held-out data.

The procedure (:func:`diagnose`):

1. **Split** the record into a fitting part and a held-out tail (whole input cycles when the
   input is periodic). Every model below is fitted on the first part only.
2. **Base fit** of the model, and the structure of its free-run residual over the whole record
   (:func:`~duffsym.diagnose.residuals.analyse_residuals`).
3. **Each candidate** effect of the catalogue is added to the model and started from the base
   optimum and the effect's data-based initial guess (``Effect.initial_guess(record, y_model)``,
   via :func:`~duffsym.identify.extended_start`), and refitted by collocation + IPOPT on an
   iteration budget (optionally with screening, see ``screen``).
4. **Evidence** per candidate, from free runs of the fitted models over the whole record:
   the held-out NRMSE (prediction on data the fit never saw), ΔBIC on the fitting part
   (free-run sum of squares, penalising the added parameters and initial states), and the share
   of the base model's *excess* held-out error (above the noise level) that the effect removes.
5. **Decision.** A candidate is *supported* when ΔBIC < ``bic_threshold`` (default −10, "very
   strong" on Kass & Raftery's scale) and it lowers the held-out RMSE by at least
   ``min_improvement`` (10 %). It is *needed* — a confident verdict — only when, in addition, it
   removes at least ``min_explained`` (50 %) of the excess held-out error. A supported candidate
   that explains less is reported as a partial explanation and the remaining structure is
   described in words, so that an effect outside the catalogue is not forced onto a wrong one.
   When the base residual is white at the noise level, no candidate is needed.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Iterable, Mapping, Sequence

import numpy as np

from duffsym._progress import reporter
from duffsym.data.record import Record
from duffsym.diagnose.residuals import ResidualAnalysis, analyse_residuals, noise_level, rising_crossings
from duffsym.errors import DataError, ModelError

BIC_THRESHOLD = -10.0
MIN_IMPROVEMENT = 0.10
MIN_EXPLAINED = 0.50
#: two candidates whose held-out RMSE differ by less than this (relative) are reported as a tie
TIE = 0.05
#: IPOPT iterations for a candidate's fit (see :func:`diagnose`)
CANDIDATE_MAX_ITER = 100
#: IPOPT CPU seconds for a candidate's fit (see :func:`diagnose`)
CANDIDATE_CPU_TIME = 30.0
#: IPOPT iterations of a candidate's first, screening fit; candidates continued after it (see :func:`diagnose`)
SCREEN_ITER = 30
SCREEN = 4


@dataclass(frozen=True)
class Candidate:
    """One catalogued effect added to the model and refitted."""

    effect: str
    nrmse_after: float  # held-out free-run NRMSE with the effect
    nrmse_after_fit: float  # free-run NRMSE on the fitting part
    nrmse_after_all: float  # over the whole record
    delta_bic: float
    improvement: float  # 1 - rmse_after / rmse_before on the held-out part
    explained: float  # share of the base model's excess held-out MSE removed
    params: dict  # the effect's own parameters
    stderr: dict
    all_params: dict
    success: bool
    message: str
    seconds: float
    supported: bool = False
    needed: bool = False
    physics: str = ""

    def to_dict(self) -> dict:
        return dict(effect=self.effect, nrmse_after=self.nrmse_after, delta_bic=self.delta_bic, params=self.params,
                    stderr=self.stderr, nrmse_after_fit=self.nrmse_after_fit, nrmse_after_all=self.nrmse_after_all,
                    improvement=self.improvement, explained=self.explained, supported=self.supported,
                    needed=self.needed, success=self.success, message=self.message, seconds=self.seconds,
                    all_params=self.all_params, physics=self.physics)


@dataclass(frozen=True)
class Diagnosis:
    """Where a model fails on a record and which catalogued effect is missing.

    Attributes
    ----------
    model, effects : the diagnosed model and the effects it already had.
    nrmse : the base model's free-run NRMSE over the whole record; ``nrmse_heldout`` over the tail.
    residuals : the structure of the base model's free-run residual.
    candidates : every tried effect, best (lowest held-out NRMSE) first.
    needed : the effect the evidence supports adding, best first (see the module docstring); () when
        none. One at a time: two effects each needed alone may explain the same residual, so the
        ladder adds the best and diagnoses the extended model again.
    verdict : one or two sentences for a person.
    base_fit : the base model's fit on the fitting part; ``y_base`` its free run on the whole record.
    split : the fitting/held-out split (sample counts, time).
    """

    model: str
    effects: tuple
    nrmse: float
    nrmse_heldout: float
    residuals: ResidualAnalysis
    candidates: tuple[Candidate, ...]
    needed: tuple[str, ...]
    verdict: str
    base_fit: object
    y_base: np.ndarray
    split: dict
    noise: float
    bic_base: float
    timings: dict = field(default_factory=dict)
    y_candidates: dict = field(default_factory=dict)
    sindy: dict | None = None

    @property
    def best(self) -> Candidate | None:
        return self.candidates[0] if self.candidates else None

    def to_dict(self) -> dict:
        return dict(
            nrmse=self.nrmse, candidates=[c.to_dict() for c in self.candidates], needed=list(self.needed),
            verdict=self.verdict, model=self.model, effects=list(self.effects), nrmse_heldout=self.nrmse_heldout,
            noise=self.noise, bic_base=self.bic_base, split=self.split, findings=self.residuals.findings(),
            residuals=self.residuals.to_dict(), base_params=dict(self.base_fit.params), timings=self.timings,
            sindy=self.sindy,
            rules=dict(bic_threshold=BIC_THRESHOLD, min_improvement=MIN_IMPROVEMENT, min_explained=MIN_EXPLAINED),
        )

    def summary(self) -> str:
        lines = [f"diagnosis of {self.model}{' + ' + ' + '.join(self.effects) if self.effects else ''}: "
                 f"free-run NRMSE {self.nrmse:.4g} (held-out {self.nrmse_heldout:.4g}), noise level {self.noise:.3g}"]
        lines.append("where it fails:")
        lines += [f"  - {s}" for s in self.residuals.findings()]
        lines.append("candidates (best first; held-out NRMSE, dBIC, share of excess error explained):")
        for c in self.candidates:
            flag = "needed" if c.needed else ("partial" if c.supported else "")
            pv = ", ".join(f"{k}={v:.4g}" for k, v in c.params.items())
            lines.append(f"  {c.effect:<22} {c.nrmse_after:8.4g} {c.delta_bic:10.1f} {100 * c.explained:6.0f} %  "
                         f"{flag:<7} {pv}" + ("" if c.success else f"  [{_why_not(c.message)}]"))
        if self.sindy is not None:
            lines.append(f"SINDy cross-check: {self.sindy.get('verdict')}: {self.sindy.get('message', '')}")
        lines.append(f"verdict: {self.verdict}")
        return "\n".join(lines)


def _why_not(message: str) -> str:
    """Why a candidate has no result: screened out, or its fit failed."""
    return message if message.startswith("screened out") else f"fit failed: {message}"


# ---------------------------------------------------------------------------------------------- split
def split_record(record: Record, holdout: float) -> int:
    """Index where the held-out tail starts: ``1 - holdout`` of the record, moved to the nearest
    rising zero crossing of the input (a whole-cycle boundary) when the input is periodic."""
    if not (0.05 <= holdout <= 0.6):
        raise DataError(f"holdout must be between 0.05 and 0.6 of the record; got {holdout}")
    n = record.n_times
    k = int(round((1 - holdout) * n))
    rising = rising_crossings(record.d)
    if rising.size >= 3:
        ok = rising[(rising > 0.4 * n) & (rising < 0.95 * n)]
        if ok.size:
            k = int(ok[np.argmin(np.abs(ok - k))])
    if k < 40 or n - k < 20:
        raise DataError(f"record {record.name!r} ({n} samples) is too short to hold out a part for the diagnosis; "
                        "give a longer record (several input cycles)")
    return k


def _part(record: Record, stop: int) -> Record:
    v = np.asarray(record.velocity())
    return record.replace(t=record.t[:stop], d=record.d[:stop], y=record.y[:stop], d_dot=v[:stop])


# ---------------------------------------------------------------------------------------------- fits
def _free_run(model, params: Mapping[str, float], record: Record, x0) -> np.ndarray | None:
    """The fit's free run (identify's own) over ``record``; None when it fails or is not finite."""
    from duffsym.identify.collocation import _free_run as free_run, _input_matrix

    y, ok, _ = free_run(model, model.param_vector(params), record, _input_matrix(model, record), x0)
    return y if ok and np.all(np.isfinite(y)) else None


def with_default_af(model, fixed: Mapping[str, float] | None, record: Record) -> dict:
    """``fixed`` with ``A_f = max|y|`` of ``record`` added when the model has ``A_f`` and it is not given:
    every fit of a diagnosis (and of a ladder) then shares the same output scale."""
    out = dict(fixed or {})
    if "A_f" in model.param_names and "A_f" not in out:
        out["A_f"] = float(np.max(np.abs(record.y)))
    return out


def _bic(ssr: float, n: int, k: int) -> float:
    return n * math.log(max(ssr, 1e-300) / n) + k * math.log(n)


def _n_estimated(result, model) -> int:
    return len(result.free) + model.n_states


def _fit(model, record: Record, fixed: Mapping[str, float], x0: Mapping[str, float] | None, *, mask=None,
         n_starts: int = 1, rng=0, max_iter: int = 500, max_cpu_time: float | None = None):
    from duffsym.identify import Problem, fit

    fixed = {k: v for k, v in fixed.items() if k in model.param_names}
    problem = Problem(model, record, fixed=fixed, mask=mask)
    start = None
    if x0 is not None:
        start = {k: v for k, v in x0.items() if k in problem.free}
        for k in list(start):
            lo, hi = problem.bounds[k]
            if not lo <= start[k] <= hi:
                start[k] = min(max(start[k], lo + 1e-9 * abs(hi - lo)), hi - 1e-9 * abs(hi - lo))
    options = {"max_cpu_time": float(max_cpu_time)} if max_cpu_time else None
    # no restart off bounds: an effect that is not needed ends with its parameter on a bound by design,
    # and fit_with_effects already gives every candidate two starts
    return fit(problem, start, n_starts=n_starts, rng=rng, compute_stderr=True, max_iter=max_iter,
               ipopt_options=options, bound_restart=False)


class _CandidateFit:
    """One candidate's fit on the fitting part and its free run over the whole record: a picklable callable,
    so that an :class:`~duffsym.engine.Engine` can fit the candidates in worker processes.

    Called with ``(name, extended model, iteration budget, start)`` (start None: the effect's own guess
    from the base optimum); returns ``(ss_fit, fit, y_free_run, seconds)``, or ``(message, seconds)``
    when the fit raised on bad input."""

    def __init__(self, record, k, rec_fit, base_params, y_base_fit, fixed, mask_fit, cpu_time):
        self.record, self.k, self.rec_fit, self.base_params, self.y_base_fit = record, k, rec_fit, base_params, y_base_fit
        self.fixed, self.mask_fit, self.cpu_time = fixed, mask_fit, cpu_time

    def __call__(self, task):
        from duffsym.effects import CATALOGUE
        from duffsym.identify import extended_start

        name, ext, budget, start = task
        t0 = time.perf_counter()
        try:
            if start is None:
                start = extended_start(ext, CATALOGUE[name], self.rec_fit, self.base_params, self.y_base_fit,
                                       fixed=self.fixed)
            fr = _fit(ext, self.rec_fit, self.fixed, start, mask=self.mask_fit, max_iter=budget,
                      max_cpu_time=self.cpu_time)
        except (ModelError, DataError) as exc:
            return str(exc), time.perf_counter() - t0
        y_ext = _free_run(ext, fr.params, self.record, fr.x0[0])
        k = self.k  # the fitting part: the first k samples of the record
        y = np.asarray(self.record.y, dtype=float)
        ss = float(np.sum((y[:k] - y_ext[:k]) ** 2)) if y_ext is not None else math.inf
        return ss, fr, y_ext, time.perf_counter() - t0


def _map(engine, job, tasks, say, verb, counted=False):
    """``job`` over ``tasks``, in order: here, one after the other (saying each), or on the engine's workers."""
    if engine is None:
        for i, task in enumerate(tasks):
            if counted:
                say(f"  {verb} {task[0]}", done=i, total=len(tasks))
            else:
                say(f"  {verb} {task[0]}")
            yield job(task)
        return
    if not tasks:
        return
    say(f"  {verb} {', '.join(t[0] for t in tasks)} on {engine!r}")
    results: list = [None] * len(tasks)
    for n, outcome in enumerate(engine.as_completed(job, tasks)):
        if not outcome.ok:
            raise outcome.error
        results[outcome.index] = outcome.value
        say(f"  {tasks[outcome.index][0]} fitted", done=n, total=len(tasks))
    yield from results


# ---------------------------------------------------------------------------------------------- main
def diagnose(
    record: Record,
    model=None,
    *,
    fit_result=None,
    start: Mapping[str, float] | None = None,
    candidates: Iterable[str] | None = None,
    fixed: Mapping[str, float] | None = None,
    holdout: float = 0.3,
    noise: float | None = None,
    mask=None,
    bic_threshold: float = BIC_THRESHOLD,
    min_improvement: float = MIN_IMPROVEMENT,
    min_explained: float = MIN_EXPLAINED,
    candidate_max_iter: int = CANDIDATE_MAX_ITER,
    candidate_cpu_time: float | None = CANDIDATE_CPU_TIME,
    screen: int | None = SCREEN,
    sindy: bool = True,
    progress=None,
    engine=None,
) -> Diagnosis:
    """Where ``model`` fails on ``record`` and which catalogued effect is missing.

    Parameters
    ----------
    record : the measurement.
    model : the model to diagnose (default: the model of ``fit_result``, else the MR damper, n = 5).
    fit_result : an existing fit; its model (with effects) is diagnosed and its parameters start
        the base refit on the fitting part.
    start : starting parameter values of the base fit (default: those of ``fit_result``, else the
        paper's tuning procedure, :func:`~duffsym.identify.initial_guess`).
    candidates : effect names to try (default: every catalogued effect the model lacks).
    fixed : parameters held fixed in every fit (besides the problem defaults: A_f = max|y|, k3 = 0).
    holdout : fraction of the record held out at its end.
    noise : the output noise standard deviation, if known (default: estimated from the data).
    mask : per-sample booleans: samples left out of every objective (whole record; the held-out
        errors are computed on all samples).
    candidate_max_iter : IPOPT iterations allowed to each candidate's fit. It starts from the base
        optimum and the effect's guess, so a candidate that explains the data converges in a few
        tens of iterations; one that does not (e.g. a play width driven towards 0, where the
        smooth switch becomes sharp) is reported as not converged instead of costing minutes.
    candidate_cpu_time : IPOPT CPU seconds allowed to each candidate's fit (None: no limit). A
        budget, not evidence: a candidate stopped by it is reported as not converged, and the
        verdict does not rest on it (use None for a reproducible run on a loaded machine).
    screen : with screening (an int), every candidate is first fitted on a budget of
        ``SCREEN_ITER`` IPOPT iterations; those not converged by then continue to the full budget
        only if their free-run error on the fitting part ranks among the best ``screen``; the
        others are reported as screened out (default 4). None: every candidate gets the full budget. ``bench_diagnose.py`` measures what
        this costs in correct verdicts against refitting all.
    sindy : also run the SINDy cross-check (:func:`duffsym.sindy.sindy_evidence`) on the record
        with the base fit: an independent, data-driven view of which terms the data support. Its
        supported missing terms are quoted in the verdict as corroboration (or contradiction) of
        the ranking; they never decide it, and an inconclusive check is reported as such.
    progress : a callable taking a message string (e.g. ``print``), a
        :class:`duffsym._progress.Progress` (counts and time left), or None.
    engine : a started :class:`~duffsym.engine.Engine` to fit the candidates on its workers (the same
        fits, in parallel), or None (default): one after the other in this process.
    """
    from duffsym.effects import CATALOGUE, apply_effects

    t_start = time.perf_counter()
    say = reporter(progress)
    if fit_result is not None:
        from duffsym.identify import model_from_result

        model = model if model is not None else model_from_result(fit_result)
    if model is None:
        from duffsym.model.library import mr_damper

        model = mr_damper()
    names = list(CATALOGUE) if candidates is None else list(candidates)
    unknown = [c for c in names if c not in CATALOGUE]
    if unknown:
        raise ModelError(f"unknown effect(s) {unknown}; choose from {sorted(CATALOGUE)} (duffsym effects lists them)")
    names = [c for c in names if c not in model.effects]
    k = split_record(record, holdout)
    rec_fit = _part(record, k)
    held = slice(k, record.n_times)
    y = np.asarray(record.y, dtype=float)
    sigma = float(noise) if noise is not None else noise_level(y)
    fixed = with_default_af(model, fixed, rec_fit)
    mask_fit = None if mask is None else np.asarray(mask, dtype=bool)[:k]

    say(f"base fit of {model.name} on {k} of {record.n_times} samples")
    if start is None and fit_result is not None:
        start = dict(fit_result.params)
    base = _fit(model, rec_fit, fixed, start, mask=mask_fit)
    if not base.success:
        raise ModelError(f"the base fit failed ({base.status}: {base.message}); the diagnosis needs a converged base "
                         "model: check the data and the model, or give a fit with --fit")
    y_base = _free_run(model, base.params, record, base.x0[0])
    if y_base is None:
        raise ModelError("the base model's free run over the whole record failed; the diagnosis needs a stable base model")
    res = analyse_residuals(record, y_base, noise=sigma)
    r_base = y - y_base
    mse_held = float(np.mean(r_base[held] ** 2))
    ss_fit = float(np.sum(r_base[:k] ** 2))
    bic_base = _bic(ss_fit, k, _n_estimated(base, model))
    from duffsym.identify.result import nrmse as _nrmse

    out: list[Candidate] = []
    y_cands = {}
    # every candidate is fitted; with screening, first on a short iteration budget: those that have
    # not converged by then continue only if their free-run error ranks among the best ``screen``
    budget = candidate_max_iter if screen is None else min(SCREEN_ITER, candidate_max_iter)
    job = _CandidateFit(record, k, rec_fit, dict(base.params), y_base[:k], fixed, mask_fit, candidate_cpu_time)
    tasks = []
    for name in names:
        try:
            tasks.append((name, apply_effects(model, [CATALOGUE[name]]), budget, None))
        except ModelError as exc:
            say(f"  {name}: not applicable ({exc})")
    runs = []
    for (name, ext, _, _), got in zip(tasks, _map(engine, job, tasks, say, "trying", counted=True)):
        if isinstance(got[0], str):  # the candidate's fit raised: (message, seconds)
            out.append(_failed(name, CATALOGUE[name], got[0], got[1]))
            continue
        ss, fr, y_ext, secs = got
        runs.append([ss, name, CATALOGUE[name], ext, fr, y_ext, secs])
    if screen is not None:
        runs.sort(key=lambda item: item[0])
        go_on = []
        for rank, run in enumerate(runs):
            ss, name, effect, ext, fr, y_ext, secs = run
            if fr.success or fr.status not in ("Maximum_Iterations_Exceeded", "Maximum_CpuTime_Exceeded"):
                continue
            if rank >= screen:
                run[4] = None
                run[5] = (f"screened out: not converged in {budget} IPOPT iterations and its free-run error ranks "
                          f"{rank + 1} of {len(runs)} (screen={screen})")
                continue
            go_on.append(run)
        for run, got in zip(go_on, _map(engine, job, [(r[1], r[3], candidate_max_iter, r[4].params) for r in go_on],
                                        say, "continuing")):
            if isinstance(got[0], str):
                run[4], run[5] = None, got[0]
                continue
            run[4], run[5], run[6] = got[1], got[2], run[6] + got[3]
    for ss, name, effect, ext, fr, y_ext, secs in runs:
        if fr is None:
            out.append(_failed(name, effect, y_ext, secs))
            continue
        if not fr.success or y_ext is None:
            out.append(_failed(name, effect, fr.message if not fr.success else "free run failed", secs))
            continue
        y_cands[name] = y_ext
        r = y - y_ext
        mse_h = float(np.mean(r[held] ** 2))
        improvement = 1 - math.sqrt(mse_h / mse_held) if mse_held > 0 else 0.0
        excess = mse_held - sigma**2
        explained = (mse_held - mse_h) / excess if excess > 0 else 0.0
        dbic = _bic(float(np.sum(r[:k] ** 2)), k, _n_estimated(fr, ext)) - bic_base
        own = [p.name for p in ext.params if p.name not in model.param_names]
        supported = dbic < bic_threshold and improvement >= min_improvement
        out.append(Candidate(
            effect=name, nrmse_after=_nrmse(y[held], y_ext[held]), nrmse_after_fit=_nrmse(y[:k], y_ext[:k]),
            nrmse_after_all=_nrmse(y, y_ext), delta_bic=dbic, improvement=improvement,
            explained=float(min(explained, 1.0)), params={p: float(fr.params[p]) for p in own},
            stderr={p: float(fr.stderr.get(p, math.nan)) for p in own}, all_params=dict(fr.params), success=True,
            message=fr.message, seconds=secs, supported=supported,
            needed=supported and explained >= min_explained and not res.at_noise_level, physics=effect.physics))
    out = _rank(out)
    needed = tuple(c.effect for c in out if c.needed)
    base_held = _nrmse(y[held], y_base[held])
    evidence = _sindy_evidence(record, base, model, say) if sindy else None
    verdict = _verdict(res, out, base_held) + _sindy_sentence(evidence, out)
    return Diagnosis(
        model=model.name, effects=tuple(model.effects), nrmse=_nrmse(y, y_base), nrmse_heldout=base_held,
        residuals=res, candidates=tuple(out), needed=needed[:1] if needed else (), verdict=verdict, base_fit=base,
        y_base=y_base, split={"n_fit": k, "n_heldout": record.n_times - k, "t_split": float(record.t[k])},
        noise=sigma, bic_base=bic_base, timings={"total": time.perf_counter() - t_start},
        y_candidates=y_cands, sindy=evidence,
    )


def _rank(cands: list[Candidate]) -> list[Candidate]:
    """Best first: lowest held-out NRMSE; among candidates within ``TIE`` of the best, lowest ΔBIC
    first (of two effects that predict equally well, the one with fewer parameters, e.g. a force
    offset before a gas accumulator whose stiffness comes out zero)."""
    ok = sorted((c for c in cands if c.success and math.isfinite(c.nrmse_after)), key=lambda c: c.nrmse_after)
    rest = [c for c in cands if c not in ok]
    if ok:
        tie = [c for c in ok if c.nrmse_after <= ok[0].nrmse_after * (1 + TIE)]
        ok = sorted(tie, key=lambda c: c.delta_bic) + ok[len(tie):]
    return ok + rest


def _sindy_evidence(record, base_fit, model, say) -> dict:
    """The SINDy cross-check's evidence, or why it could not run on this model."""
    from duffsym.sindy import sindy_evidence

    say("  SINDy cross-check")
    try:
        return sindy_evidence([record], fit=base_fit, model=model)
    except (ModelError, DataError, ValueError, ArithmeticError) as exc:
        # the cross-check is corroboration only: a failure here must not cost the diagnosis
        return {"verdict": "not applicable", "conclusive": False, "missing_terms": [],
                "message": f"the SINDy cross-check could not run on this model: {type(exc).__name__}: {exc}"}


def _sindy_sentence(evidence: dict | None, cands: Sequence[Candidate]) -> str:
    if not evidence or not evidence.get("conclusive"):
        return ""
    found = [m for m in evidence.get("missing_terms", []) if m.get("supported")]
    if not found:
        return ""
    terms = ", ".join(f"{m['term']}" + (f" ({m['effect']})" if m.get("effect") else "") for m in found)
    best = next((c for c in cands if c.success), None)
    effects = {m.get("effect") for m in found}
    if best is not None and best.needed and best.effect in effects:
        return f" The SINDy cross-check independently selects {terms}, the term of {best.effect}."
    return f" The SINDy cross-check selects term(s) the model lacks: {terms}."


def _failed(name, effect, message, seconds) -> Candidate:
    return Candidate(effect=name, nrmse_after=math.nan, nrmse_after_fit=math.nan, nrmse_after_all=math.nan,
                     delta_bic=math.nan, improvement=math.nan, explained=math.nan, params={}, stderr={},
                     all_params={}, success=False, message=message, seconds=seconds, physics=effect.physics)


def _verdict(res: ResidualAnalysis, cands: Sequence[Candidate], base_held: float) -> str:
    ok = [c for c in cands if c.success]
    best = ok[0] if ok else None
    where = res.findings()
    if res.at_noise_level and not any(c.needed for c in ok):
        return (f"No effect is needed: the residual is white and at the noise level "
                f"(RMS {res.rmse:.3g} vs noise {res.noise:.3g}); no catalogued effect improves the held-out error "
                f"convincingly.")
    if best is not None and best.needed:
        s = (f"The model fails: {where[0] if where else 'the residual is structured'}. "
             f"Adding {best.effect} ({best.physics}) explains it: the held-out NRMSE falls from {base_held:.3g} to "
             f"{best.nrmse_after:.3g} (dBIC {best.delta_bic:.0f}, {100 * best.explained:.0f} % of the excess error).")
        ties = [c for c in ok[1:] if c.needed and c.nrmse_after <= best.nrmse_after * (1 + TIE)]
        if ties:
            s += (f" {', '.join(c.effect for c in ties)} explain{'s' if len(ties) == 1 else ''} it almost as well "
                  "here: this record cannot tell them apart.")
        return s
    if best is not None and best.supported:
        return (f"The model fails: {where[0] if where else 'the residual is structured'}. "
                f"{best.effect} helps (held-out NRMSE {base_held:.3g} -> {best.nrmse_after:.3g}, dBIC "
                f"{best.delta_bic:.0f}) but removes only {100 * best.explained:.0f} % of the excess error, so it is not "
                f"the missing effect with confidence. What remains: {'; '.join(where[:2]) if where else 'unclear'}.")
    return ("No catalogued effect explains what the model misses: "
            + ("; ".join(where[:3]) if where else "the residual is structured")
            + (f". The best candidate, {best.effect}, changes the held-out NRMSE only from {base_held:.3g} to "
               f"{best.nrmse_after:.3g}." if best is not None else "."))
