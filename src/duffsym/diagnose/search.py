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
from duffsym.diagnose.noisefloor import NoiseEstimate, estimate_noise, moving_average, restore
from duffsym.diagnose.residuals import ResidualAnalysis, analyse_residuals, rising_crossings
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
#: a free run whose largest |output| exceeds this multiple of the data's is called diverged
DIVERGED = 10.0
#: candidates (best first) whose fitted set is checked against the derived stability certificate
STABILITY_CHECKED = 4
#: base held-out NRMSE below which the model is said to fit the record exactly (noise-free data)
EXACT_FIT = 1e-3
#: with a time budget (``deadline``), the shares of the time left that the base fit and the plain-fit
#: reference may take (IPOPT CPU seconds); the candidates share the rest equally, each at most
#: ``candidate_cpu_time``
BASE_SHARE, REFERENCE_SHARE = 0.3, 0.2
#: IPOPT statuses of a fit stopped by a time limit
OUT_OF_TIME = ("Maximum_CpuTime_Exceeded", "Maximum_WallTime_Exceeded")
#: with a time budget, the fitting data are decimated to at most this many samples (the evidence is still
#: computed at the record's rate); a 10 000-sample fitting part at 1 kHz otherwise costs minutes per fit
BUDGET_SAMPLES = 2000
#: the message of a candidate that was not fitted because the time budget ran out
NOT_TRIED = "not tried: the time budget ran out"


def time_left(deadline: float | None) -> float:
    """Seconds until ``deadline`` (a ``time.monotonic()`` instant); inf without one."""
    return math.inf if deadline is None else deadline - time.monotonic()


def _time_share(deadline: float | None, fraction: float, cap: float | None = None) -> float | None:
    """Wall-clock seconds for a fit that may take ``fraction`` of the time left (at least 2 s), at most ``cap``
    (IPOPT's ``max_wall_time``: on a shared machine a fit's CPU time is a fraction of its wall time)."""
    if deadline is None:
        return cap
    t = max(2.0, fraction * time_left(deadline))
    return t if cap is None else min(cap, t)


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
    diverged: bool = False  # its free run failed or left the data's range (> DIVERGED x max|y|)
    stable: bool | None = None  # the fitted set satisfies the derived stability certificate (None: not checked)
    stability: str = ""  # the certificate's failed conditions, when it fails
    start: int = 1  # 2 when the second start (from the base solution) won

    def to_dict(self) -> dict:
        return dict(effect=self.effect, nrmse_after=self.nrmse_after, delta_bic=self.delta_bic, params=self.params,
                    stderr=self.stderr, nrmse_after_fit=self.nrmse_after_fit, nrmse_after_all=self.nrmse_after_all,
                    improvement=self.improvement, explained=self.explained, supported=self.supported,
                    needed=self.needed, success=self.success, message=self.message, seconds=self.seconds,
                    all_params=self.all_params, physics=self.physics, diverged=self.diverged, stable=self.stable,
                    stability=self.stability, start=self.start)


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
    noise_method: str = "given"
    base_check: dict = field(default_factory=dict)
    prepare: object = None  # the decimation of the fitting data (duffsym.diagnose.prepare.Preparation)
    noise_estimate: NoiseEstimate | None = None  # how the noise was measured (smoothing, measurability)
    inactive: dict = field(default_factory=dict)  # effects of the model that do nothing at its fitted values

    @property
    def best(self) -> Candidate | None:
        """The lowest held-out error among converged candidates whose free run did not diverge."""
        return next((c for c in self.candidates if c.success and not c.diverged), None)

    def to_dict(self) -> dict:
        return dict(
            nrmse=self.nrmse, candidates=[c.to_dict() for c in self.candidates], needed=list(self.needed),
            verdict=self.verdict, model=self.model, effects=list(self.effects), nrmse_heldout=self.nrmse_heldout,
            noise=self.noise, bic_base=self.bic_base, split=self.split, findings=self.residuals.findings(),
            residuals=self.residuals.to_dict(), base_params=dict(self.base_fit.params), timings=self.timings,
            sindy=self.sindy, noise_method=self.noise_method, base_check=self.base_check,
            prepare=self.prepare.to_dict() if self.prepare is not None else None,
            noise_estimate=self.noise_estimate.to_dict() if self.noise_estimate is not None else None,
            inactive=self.inactive,
            rules=dict(bic_threshold=BIC_THRESHOLD, min_improvement=MIN_IMPROVEMENT, min_explained=MIN_EXPLAINED),
        )

    def summary(self) -> str:
        lines = [f"diagnosis of {self.model}{' + ' + ' + '.join(self.effects) if self.effects else ''}: "
                 f"free-run NRMSE {self.nrmse:.4g} (held-out {self.nrmse_heldout:.4g}), noise level {self.noise:.3g} "
                 f"({self.noise_method})"]
        lines.append("where it fails:")
        lines += [f"  - {s}" for s in self.residuals.findings()]
        lines.append("candidates (best first; held-out NRMSE, dBIC, share of excess error explained):")
        for c in self.candidates:
            flag = "needed" if c.needed else ("partial" if c.supported else "")
            pv = ", ".join(f"{k}={v:.4g}" for k, v in c.params.items())
            mark = "" if c.stable is not False else f"  [outside the stability certificate: {c.stability}]"
            lines.append(f"  {c.effect:<22} {c.nrmse_after:8.4g} {c.delta_bic:10.1f} {100 * c.explained:6.0f} %  "
                         f"{flag:<7} {pv}" + ("" if c.success else f"  [{_why_not(c.message)}]") + mark)
        if self.sindy is not None:
            lines.append(f"SINDy cross-check: {self.sindy.get('verdict')}: {self.sindy.get('message', '')}")
        if self.prepare is not None:
            lines.append(self.prepare.summary())
        lines.append(f"verdict: {self.verdict}")
        return "\n".join(lines)


def _why_not(message: str) -> str:
    """Why a candidate has no result: screened out, its free run diverged, or its fit failed."""
    if "WallTime_Exceeded" in message:
        return f"not converged: its share of the time budget ran out ({message})"
    return message if message.startswith(("screened out", "free run", "not tried")) else f"fit failed: {message}"


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
    return record.replace(t=record.t[:stop], d=record.d[:stop], y=record.y[:stop], d_dot=v[:stop],
                          command=None if record.command is None else record.command[:stop])


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


#: effects whose nonlinearity is first fitted in a smoother form (continuation from smooth to sharp): the
#: catalogue effect with these fields replaced (a play operator with a switch 2.5x wider, engaging later)
SMOOTH_FORMS = {"backlash": dict(kappa=2.0, offset=0.5)}


def smooth_form(model, name: str):
    """``model`` (whose last effect is ``name``) with that effect in its smoother form (``SMOOTH_FORMS``);
    None when it has none or the model's chain is not known."""
    import dataclasses

    from duffsym.effects import CATALOGUE, effect_chain

    if name not in SMOOTH_FORMS or not model.effects or model.effects[-1] != name:
        return None
    chain = effect_chain(model)
    if chain is None:
        return None
    base, steps = chain
    parent = steps[-2][1] if len(steps) >= 2 else base
    try:
        return dataclasses.replace(CATALOGUE[name], **SMOOTH_FORMS[name]).apply(parent)
    except ModelError:
        return None


#: effects that explain the stretches a deadzone mask (``--mask auto``) leaves out: a model with one of them is
#: fitted on every sample (masked, the flat force after each reversal, the play's only evidence, is not seen and
#: the play's half-width ran to its lower bound on the real friction damper)
EXPLAINS_MASK = ("backlash",)


def unmasked(model, mask):
    """``mask``, or None when ``model`` has an effect that explains the masked stretches (``EXPLAINS_MASK``)."""
    return None if any(e in EXPLAINS_MASK for e in model.effects) else mask


def record_bounds(model, record: Record, fixed: Mapping[str, float] | None = None) -> dict:
    """The bounds of ``model``'s effect parameters scaled to ``record`` (:meth:`Effect.record_bounds`, e.g.
    a friction's smoothing velocity within a range of the record's velocities), for the free parameters."""
    from duffsym.effects import CATALOGUE

    out = {}
    for name in model.effects:
        if name in CATALOGUE:
            out.update(CATALOGUE[name].record_bounds(record))
    return {k: v for k, v in out.items() if k in model.param_names and k not in (fixed or {})}


def inactive_effects(model, record: Record, params: Mapping[str, float], stderr: Mapping[str, float] | None = None,
                     effects=None) -> dict:
    """effect -> why it does nothing on ``record`` at ``params`` (:meth:`Effect.activity`; ``stderr`` the
    standard errors), for the catalogued effects of ``model`` (or those in ``effects``) that are flagged; {}
    when every effect acts."""
    from duffsym.effects import CATALOGUE

    out = {}
    for name in model.effects if effects is None else effects:
        if name in CATALOGUE:
            try:
                why = CATALOGUE[name].activity(record, {**model.defaults(), **dict(params)}, dict(stderr or {}))
            except (KeyError, ValueError, ArithmeticError):
                why = ""
            if why:
                out[name] = why
    return out


def _fit(model, record: Record, fixed: Mapping[str, float], x0: Mapping[str, float] | None, *, mask=None,
         n_starts: int = 1, rng=0, max_iter: int = 500, max_cpu_time: float | None = None,
         bound_restart: bool = False, flags: bool = True, max_wall_time: float | None = None):
    from duffsym.identify import Problem, fit

    fixed = {k: v for k, v in fixed.items() if k in model.param_names}
    problem = Problem(model, record, fixed=fixed, mask=mask, bounds=record_bounds(model, record, fixed))
    start = None
    if x0 is not None:
        start = {k: v for k, v in x0.items() if k in problem.free}
        for k in list(start):
            lo, hi = problem.bounds[k]
            if not lo <= start[k] <= hi:
                start[k] = min(max(start[k], lo + 1e-9 * abs(hi - lo)), hi - 1e-9 * abs(hi - lo))
    options = {"max_cpu_time": float(max_cpu_time)} if max_cpu_time else {}
    options = {**options, "max_wall_time": float(max_wall_time)} if max_wall_time else (options or None)
    # candidates: no restart off bounds (an effect that is not needed ends with its parameter on a bound
    # by design); the base fit restarts as a plain ``fit`` does
    return fit(problem, start, n_starts=n_starts, rng=rng, compute_stderr=True, max_iter=max_iter,
               ipopt_options=options, bound_restart=bound_restart, flags=flags)


class _CandidateFit:
    """One candidate's fit on the fitting part and its free run over the whole record: a picklable callable,
    so that an :class:`~duffsym.engine.Engine` can fit the candidates in worker processes.

    Called with ``(name, extended model, iteration budget, start)`` (start None: the effect's own guess
    from the base optimum); returns ``(ss_fit, fit, y_free_run, seconds)``, or ``(message, seconds)``
    when the fit raised on bad input."""

    def __init__(self, record, k, rec_fit, base_params, y_base_fit, fixed, mask_fit, cpu_time, deadline=None,
                 n_tasks=1):
        self.record, self.k, self.rec_fit, self.base_params, self.y_base_fit = record, k, rec_fit, base_params, y_base_fit
        self.fixed, self.mask_fit, self.cpu_time = fixed, mask_fit, cpu_time
        self.deadline, self.n_tasks, self.calls = deadline, max(int(n_tasks), 1), 0

    def _wall(self) -> float | None:
        """This fit's wall seconds with a deadline: an equal share of the time left among the fits still to come
        (counted in this process; on workers each sees the whole time left); None without one."""
        self.calls += 1
        return _time_share(self.deadline, 1.0 / max(self.n_tasks - self.calls + 1, 1))

    def _smooth_first(self, name, ext, start, budget, wall):
        """Continuation from smooth to sharp: an effect with a smoother form (``SMOOTH_FORMS``, e.g. a softer
        play operator) is first fitted in it; its parameters then start the sharp fit (the start is kept
        when the smooth fit fails)."""
        soft = smooth_form(ext, name)
        if soft is None:
            return start
        half = None if self.cpu_time is None else 0.5 * self.cpu_time
        fs = _fit(soft, self.rec_fit, self.fixed, start, mask=unmasked(soft, self.mask_fit), max_iter=budget,
                  max_cpu_time=half,
                  max_wall_time=None if wall is None else 0.5 * wall, flags=False)
        ok = fs.success or fs.status in ("Maximum_Iterations_Exceeded",) + OUT_OF_TIME
        return {**start, **dict(fs.params)} if ok and all(np.isfinite(list(fs.params.values()))) else start

    def __call__(self, task):
        from duffsym.effects import CATALOGUE
        from duffsym.identify import extended_start

        name, ext, budget, start = task
        t0 = time.perf_counter()
        wall = self._wall()
        if time_left(self.deadline) < 1.0:
            return NOT_TRIED, 0.0
        try:
            if start is None:
                start = extended_start(ext, CATALOGUE[name], self.rec_fit, self.base_params, self.y_base_fit,
                                       fixed=self.fixed)
                start = self._smooth_first(name, ext, start, budget, wall)
            # no fit-level flags: the diagnosis judges its candidates itself, stability included (_mark_stability)
            fr = _fit(ext, self.rec_fit, self.fixed, start, mask=unmasked(ext, self.mask_fit), max_iter=budget,
                      max_cpu_time=self.cpu_time, max_wall_time=wall, flags=False)
        except (ModelError, DataError) as exc:
            return str(exc), time.perf_counter() - t0
        y_ext = _free_run(ext, fr.params, self.record, fr.x0[0])
        y_ext = y_ext if _within_range(y_ext, self.record.y) else None
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
    decimate: bool | int = True,
    progress=None,
    engine=None,
    second_start: bool = True,
    deadline: float | None = None,
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
        only if their free-run error on the fitting part ranks among the best ``screen`` of the
        candidates not converged by then (converged ones are not in that ranking: they are done); the
        others are reported as screened out (default 4). None: every candidate gets the full budget. ``bench_diagnose.py`` measures what
        this costs in correct verdicts against refitting all.
    sindy : also run the SINDy cross-check (:func:`duffsym.sindy.sindy_evidence`) on the record
        with the base fit: an independent, data-driven view of which terms the data support. Its
        supported missing terms are quoted in the verdict as corroboration (or contradiction) of
        the ranking; they never decide it, and an inconclusive check is reported as such.
    decimate : fit on the fitting part decimated where its spectrum allows (True, default; see
        :mod:`duffsym.diagnose.prepare`), at most by this factor (an int), or not at all (False or 1). The
        evidence (free runs, held-out errors, ΔBIC, residuals) is always computed at the record's rate;
        the factor and why are in ``prepare``.
    progress : a callable taking a message string (e.g. ``print``), a
        :class:`duffsym._progress.Progress` (counts and time left), or None.
    engine : a started :class:`~duffsym.engine.Engine` to fit the candidates on its workers (the same
        fits, in parallel), or None (default): one after the other in this process.
    second_start : a candidate whose fit failed, diverged, or ended worse on the fitting part than the
        base it extends (a local optimum: it contains the base model) is fitted again from the base
        solution itself with the effect's parameters at their neutral defaults; the better is kept
        (``settings["candidate_start"] = 2`` when the second won). Measured in ``bench_diagnose.py``.
    deadline : a ``time.monotonic()`` instant by which the diagnosis should be done (None: no limit). The
        base fit may take ``BASE_SHARE`` of the time left, the plain-fit reference ``REFERENCE_SHARE``,
        and the candidates share the rest (IPOPT CPU seconds; a fit stopped by it is reported as not
        converged); candidates left when it has passed are reported as ``"not tried: the time budget ran
        out"``; the fitting data are decimated to at most ``BUDGET_SAMPLES`` samples (the factor and why
        are in ``prepare``); the SINDy cross-check is skipped when less than a tenth of the time is left.
    """
    from duffsym.effects import CATALOGUE

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
    est = NoiseEstimate(float(noise), "given") if noise is not None else estimate_noise(y, record.dt)
    sigma, noise_method, floor_noise, w = est.sigma, est.method, not est.measurable, est.smoothing
    # a detected moving average: the models are fitted to the force restored by its regularised inverse
    # (``work``) and every free run is judged through the same average against the measured force
    work = record if w <= 1 else record.replace(y=restore(y, w))
    rec_fit = _part(work, k)

    def through(yy):
        return yy if w <= 1 or yy is None else moving_average(yy, w)

    fixed = with_default_af(model, fixed, rec_fit)
    mask_fit = None if mask is None else np.asarray(mask, dtype=bool)[:k]
    cap = BUDGET_SAMPLES if deadline is not None else None
    prep, rec_fit, mask_fit = _prepare_fit(work, rec_fit, mask_fit, decimate, cap)
    q = prep.factor

    say(f"base fit of {model.name} on {k} of {record.n_times} samples" + (f" (decimated by {q})" if q > 1 else ""))
    if start is None and fit_result is not None:
        start = dict(fit_result.params)
    t_budget = time_left(deadline)
    base, y_work, base_check = _base_fit(model, work, rec_fit, fixed, start, mask, mask_fit, fit_result, say, k=k,
                                         rec_plain=_prepare_fit(work, work, mask, q if cap else decimate, cap and -(-work.n_times // q))[1:]
                                         if q > 1 else None, deadline=deadline)
    y_base = through(y_work)
    r_base = y - y_base
    mse_held = float(np.mean(r_base[held] ** 2))
    ss_fit = float(np.sum(r_base[:k] ** 2))
    bic_base = _bic(ss_fit, k, _n_estimated(base, model))
    base_check["stable"], base_check["stability"] = _certificate(model, base.params)
    from duffsym.identify.result import nrmse as _nrmse

    y_cands = {}
    runs = _candidate_runs(names, model, rec_fit, work, base, y_work[:k], fixed, mask_fit, candidate_max_iter,
                           candidate_cpu_time, screen, say, second_start, engine, q=q, deadline=deadline)
    failed = [r for r in runs if isinstance(r, Candidate)]
    runs = [r for r in runs if not isinstance(r, Candidate)]
    for r in runs:
        if r[4] is not None:
            r[5] = through(r[5])
    if floor_noise:
        # no white-noise floor near Nyquist (pre-filtered or noise-free force): the third-difference
        # estimate measures smoothness; the lowest held-out error of any fitted model bounds the noise
        held_rms = [math.sqrt(mse_held)] + [math.sqrt(float(np.mean((y[held] - r[5][held]) ** 2)))
                                            for r in runs if r[4] is not None and r[4].success and r[5] is not None]
        noise_method = (f"held-out residual floor: the lowest held-out RMS of any fitted model, an upper bound; the "
                        f"noise is {noise_method}")
        sigma = min(held_rms)
    res = analyse_residuals(record, y_base, noise=sigma, noise_kind="floor" if floor_noise else "measured",
                            smoothing=w)
    shifted = abs(res.mean_z) > 5 and abs(res.mean) > 0.2 * res.rmse
    out: list[Candidate] = list(failed)
    exts = {}
    for ss, name, effect, ext, fr, y_ext, secs in runs:
        if fr is None:
            out.append(_failed(name, effect, y_ext, secs))
            continue
        if not fr.success:
            out.append(_failed(name, effect, fr.message, secs))
            continue
        if y_ext is None:
            out.append(_failed(name, effect, f"free run diverged (failed, or left {DIVERGED:g}x the data's range)",
                               secs, diverged=True))
            continue
        y_cands[name] = y_ext
        exts[name] = ext
        r = y - y_ext
        mse_h = float(np.mean(r[held] ** 2))
        improvement = 1 - math.sqrt(mse_h / mse_held) if mse_held > 0 else 0.0
        excess = mse_held - sigma**2
        explained = (mse_held - mse_h) / excess if excess > 0 else 0.0
        dbic = _bic(float(np.sum(r[:k] ** 2)), k, _n_estimated(fr, ext)) - bic_base
        own = [p.name for p in ext.params if p.name not in model.param_names]
        supported = dbic < bic_threshold and improvement >= min_improvement
        # a shifted loop (residual mean a large share of its RMS) is evidence for the offset on its own
        enough = explained >= min_explained or (name == "force-offset" and shifted)
        out.append(Candidate(
            effect=name, nrmse_after=_nrmse(y[held], y_ext[held]), nrmse_after_fit=_nrmse(y[:k], y_ext[:k]),
            nrmse_after_all=_nrmse(y, y_ext), delta_bic=dbic, improvement=improvement,
            explained=float(min(explained, 1.0)), params={p: float(fr.params[p]) for p in own},
            stderr={p: float(fr.stderr.get(p, math.nan)) for p in own}, all_params=dict(fr.params), success=True,
            message=fr.message, seconds=secs, supported=supported,
            needed=supported and enough and not res.at_noise_level, physics=effect.physics,
            start=int(fr.settings.get("candidate_start", 1))))
    out = _mark_stability(_rank(out), exts)
    needed = tuple(c.effect for c in out if c.needed)
    base_held = _nrmse(y[held], y_base[held])
    evidence = _sindy_evidence(record, base, model, say) if _sindy_wanted(sindy, deadline, t_budget, say) else None
    inactive = inactive_effects(model, record, base.params, base.stderr)
    verdict = _full_verdict(res, out, base_held, noise_method, shifted, w, evidence, base_check, inactive)
    return Diagnosis(
        model=model.name, effects=tuple(model.effects), nrmse=_nrmse(y, y_base), nrmse_heldout=base_held,
        residuals=res, candidates=tuple(out), needed=needed[:1] if needed else (), verdict=verdict, base_fit=base,
        y_base=y_base, split={"n_fit": k, "n_heldout": record.n_times - k, "t_split": float(record.t[k])},
        noise=sigma, bic_base=bic_base, timings={"total": time.perf_counter() - t_start},
        y_candidates=y_cands, sindy=evidence, noise_method=noise_method, base_check=base_check, prepare=prep,
        noise_estimate=est, inactive=inactive,
    )


def _full_verdict(res, out, base_held, noise_method, shifted, w, evidence, base_check, inactive) -> str:
    """The diagnosis's sentences: the verdict, the proposal to look outside the catalogue, smoothing, SINDy,
    the base fit's check and the inactive effects."""
    from duffsym.diagnose.discover import proposal

    return (_verdict(res, out, base_held, noise_method, shifted) + proposal(res, out) + _smoothing_sentence(w)
            + _sindy_sentence(evidence, out) + _base_sentence(base_check)
            + "".join(f" Inactive in the fitted model: {e}: {why}." for e, why in inactive.items()))


def _within_range(y_run, y) -> bool:
    return y_run is not None and float(np.max(np.abs(y_run))) <= DIVERGED * float(np.max(np.abs(y)))


def _base_fit(model, record, rec_fit, fixed, start, mask, mask_fit, fit_result, say, k=None, rec_plain=None,
              deadline=None):
    """The base fit on the fitting part, at least as good there as a plain ``fit`` of the whole record.

    The base model is fitted on the fitting part as a plain ``fit`` would (restart off bounds); a
    plain fit of the whole record (or ``fit_result``) is the reference. When the reference's free
    run is better on the fitting part, the base is refitted from the reference's parameters and the
    better of the two kept. ``base_check`` reports both errors, which start won, and whether the
    base is as good as the reference (within 5 %); the verdict says so when it is not. ``k``: the
    fitting part's length at the record's rate (default ``rec_fit``'s, when not decimated);
    ``rec_plain``: (record, mask) of the plain fit (default ``record``, ``mask``; a decimated copy).
    ``deadline``: the base fit may take ``BASE_SHARE`` of the time left, the reference and the refit from
    it ``REFERENCE_SHARE`` each (``check["budget"]`` says which stopped on it).
    """
    y = np.asarray(record.y, dtype=float)
    k = rec_fit.n_times if k is None else k
    mask, mask_fit = unmasked(model, mask), unmasked(model, mask_fit)
    base = _fit(model, rec_fit, fixed, start, mask=mask_fit, bound_restart=True,
                max_wall_time=_time_share(deadline, BASE_SHARE))
    out_of_time = [] if base.status not in OUT_OF_TIME else ["base fit"]
    # a base fit stopped by its share of the time budget is still used when its free run holds (the verdict
    # says it was not converged)
    y_base = _free_run(model, base.params, record, base.x0[0]) if base.success or out_of_time else None
    y_base = y_base if _within_range(y_base, y) else None
    if fit_result is not None and tuple(getattr(fit_result, "free", ())) and fit_result.x0:
        plain, plain_src = fit_result, "the given fit"
    else:
        say("  reference: a plain fit of the whole record")
        rec_p, mask_p = (record, mask) if rec_plain is None else rec_plain
        plain = _fit(model, rec_p, fixed, start, mask=mask_p, bound_restart=True,
                     max_wall_time=_time_share(deadline, REFERENCE_SHARE / (1 - BASE_SHARE)))
        plain_src = "a plain fit of the record"
        out_of_time += ["plain-fit reference"] if plain.status in OUT_OF_TIME else []
    x0p = plain.x0[0] if plain.x0 and len(plain.x0[0]) == model.n_states else None
    y_plain = _free_run(model, {**model.defaults(), **dict(plain.params)}, record, x0p)
    y_plain = y_plain if _within_range(y_plain, y) else None

    def err(yy):
        return math.inf if yy is None else math.sqrt(float(np.mean((y[:k] - yy[:k]) ** 2))) / float(np.std(y[:k]))

    won = "tuning guess" if start is None else "given start"
    if err(y_plain) < 0.99 * err(y_base):
        say("  base refit from the reference's parameters")
        alt = _fit(model, rec_fit, fixed, dict(plain.params), mask=mask_fit, bound_restart=True,
                   max_wall_time=_time_share(deadline, REFERENCE_SHARE / (1 - BASE_SHARE - REFERENCE_SHARE)))
        y_alt = _free_run(model, alt.params, record, alt.x0[0]) if alt.success else None
        y_alt = y_alt if _within_range(y_alt, y) else None
        if err(y_alt) < err(y_base):
            base, y_base, won = alt, y_alt, "the reference's parameters"
    if y_base is None:
        if not base.success:
            raise ModelError(f"the base fit failed ({base.status}: {base.message}); the diagnosis needs a converged "
                             "base model: check the data and the model, or give a fit with --fit")
        raise ModelError("the base model's free run over the whole record failed; the diagnosis needs a stable base "
                         "model")
    e_base, e_plain = err(y_base), err(y_plain)
    check = dict(reference=plain_src, nrmse_fit_part=e_base, reference_nrmse_fit_part=e_plain, start=won,
                 as_good=bool(e_base <= 1.05 * e_plain), budget=out_of_time)
    return base, y_base, check


def _candidate_runs(names, model, rec_fit, record, base, y_model_fit, fixed, mask_fit, candidate_max_iter,
                    candidate_cpu_time, screen, say, second_start: bool = True, engine=None, q: int = 1,
                    deadline: float | None = None) -> list:
    """Each candidate fitted (with screening, see :func:`diagnose`; a second start, see ``second_start``;
    on ``engine``'s workers when given): rows ``[ss, name, effect, ext, fit, y_ext, seconds]`` (``y_ext``
    None when the free run diverged; ``fit`` None when screened out, with the reason in place of
    ``y_ext``), or a failed :class:`Candidate`."""
    from duffsym.effects import CATALOGUE, apply_effects

    y = np.asarray(record.y, dtype=float)
    k = len(y_model_fit)  # the fitting part at the record's rate; rec_fit may be decimated by q
    ss_base = float(np.sum((y[:k] - np.asarray(y_model_fit)) ** 2))
    out: list = []
    budget = candidate_max_iter if screen is None else min(SCREEN_ITER, candidate_max_iter)
    job = _CandidateFit(record, k, rec_fit, dict(base.params), np.asarray(y_model_fit)[::q], fixed, mask_fit,
                        candidate_cpu_time, deadline, len(names) + (screen or 0))
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
    if second_start and time_left(deadline) > 1.0:
        # lost to a local optimum (failed, diverged, or worse than the base it extends): a second start
        # at the base solution itself, the effect's parameters at their neutral defaults
        lost = [r for r in runs if not r[4].success or r[0] > ss_base]
        starts = [(r[1], r[3], budget, {**dict(base.params), **{p.name: p.default for p in r[2].parameters()}})
                  for r in lost]
        for run, got in zip(lost, _map(engine, job, starts, say, "second start for")):
            if isinstance(got[0], str):
                continue
            ss2, fr2, y2, secs2 = got
            run[6] += secs2
            if (fr2.success or not run[4].success) and (ss2 < run[0] or (fr2.success and not run[4].success)):
                fr2.settings["candidate_start"] = 2
                run[0], run[4], run[5] = ss2, fr2, y2
    if screen is not None and time_left(deadline) <= 1.0:
        for run in runs:
            if not run[4].success and run[4].status == "Maximum_Iterations_Exceeded":
                run[4], run[5] = None, f"{NOT_TRIED} after its screening fit ({budget} IPOPT iterations)"
    elif screen is not None:
        # only the candidates still being fitted compete for continuation: a fit stopped half-way is not
        # ranked against converged ones (an output lag at 30 iterations ranked 10 of 11 behind them, and the
        # ladder lost it on an offset + lag record; it converges to the true lag when continued)
        runs.sort(key=lambda item: item[0])
        open_runs = [r for r in runs if not r[4].success
                     and r[4].status in ("Maximum_Iterations_Exceeded",) + OUT_OF_TIME]
        go_on = []
        for rank, run in enumerate(open_runs):
            if rank >= screen:
                run[4] = None
                run[5] = (f"screened out: not converged in {budget} IPOPT iterations and its free-run error ranks "
                          f"{rank + 1} of the {len(open_runs)} candidates not converged by then (screen={screen})")
                continue
            go_on.append(run)
        for run, got in zip(go_on, _map(engine, job, [(r[1], r[3], candidate_max_iter, r[4].params) for r in go_on],
                                        say, "continuing")):
            if isinstance(got[0], str):
                run[4], run[5] = None, got[0]
                continue
            start2 = run[4].settings.get("candidate_start")
            run[4], run[5], run[6] = got[1], got[2], run[6] + got[3]
            if start2:
                run[4].settings["candidate_start"] = start2
    return out + runs


def _certificate(model, params) -> tuple[bool | None, str]:
    """Whether ``params`` satisfy the derived stability certificate of ``model`` (None: not derivable
    for this model), and the failed conditions in words."""
    from duffsym.derive.stability import stability_certificate

    try:
        cert = stability_certificate(model, dict(params))
    except (ModelError, ValueError, TypeError, NotImplementedError, ArithmeticError):
        return None, ""
    if any(c.statement.split(" (")[0].strip() == "False" for c in cert.failed):
        return None, ""  # a condition false for every parameter set: the argument does not cover this model
    return bool(cert.holds), "; ".join(f"{c.name} ({c.statement})" for c in cert.failed)


def _mark_stability(cands: list[Candidate], exts: Mapping) -> list[Candidate]:
    """The first ``STABILITY_CHECKED`` converged candidates and every supported one, checked against
    the stability certificate; one outside it is marked and is not *needed* (energy-producing terms,
    e.g. a negative cubic damping, are not a passive damper's physics), though it stays supported."""
    from dataclasses import replace

    out = []
    seen = 0
    for c in cands:
        if c.success and c.effect in exts and (seen < STABILITY_CHECKED or c.supported):
            seen += 1
            stable, why = _certificate(exts[c.effect], c.all_params)
            c = replace(c, stable=stable, stability=why, needed=c.needed and stable is not False)
        out.append(c)
    return out


def _prepare_fit(record: Record, rec_fit: Record, mask_fit, decimate, max_samples: int | None = None):
    """(preparation, fitting data, their mask): ``rec_fit`` decimated on its own (no held-out sample
    enters its anti-aliasing filter) by the factor chosen from the whole record's spectrum; with
    ``max_samples`` (a time budget) at least by the factor that leaves at most that many samples (unless
    decimation is off)."""
    import dataclasses

    from duffsym.diagnose.prepare import choose_decimation, decimate_mask, decimate_record

    cap = 1 if decimate is False else (None if decimate is True else int(decimate))
    prep = choose_decimation(record, n_fit=rec_fit.n_times, max_factor=cap)
    need = -(-rec_fit.n_times // max_samples) if max_samples and cap != 1 else 1
    if need > prep.factor and prep.rate_in == prep.rate_in:  # uniform sampling (rate_in not NaN)
        q = need if cap is None else min(need, cap)
        prep = dataclasses.replace(prep, factor=q, rate=prep.rate_in / q, n_out=-(-prep.n_in // q),
                                   reason=f"the time budget: at most {max_samples} fitting samples (the spectrum alone "
                                   f"asked for a factor {prep.factor})")
    rec = decimate_record(rec_fit, prep.factor)
    return prep, rec, decimate_mask(mask_fit, prep.factor, rec.n_times)


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


def _sindy_wanted(sindy: bool, deadline, t_budget: float, say) -> bool:
    """Whether to run the SINDy cross-check: asked for, and more than a tenth of the diagnosis's time left."""
    if sindy and time_left(deadline) < 0.1 * t_budget:
        say("  SINDy cross-check skipped: the time budget is nearly spent")
        return False
    return sindy


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


def _failed(name, effect, message, seconds, diverged: bool = False) -> Candidate:
    return Candidate(effect=name, nrmse_after=math.nan, nrmse_after_fit=math.nan, nrmse_after_all=math.nan,
                     delta_bic=math.nan, improvement=math.nan, explained=math.nan, params={}, stderr={},
                     all_params={}, success=False, message=message, seconds=seconds, physics=effect.physics,
                     diverged=diverged)


def _share(c: Candidate, floor: bool) -> str:
    """The share of the excess error a candidate removes, in words; with the held-out floor as the noise
    reference the best candidate removes all of it by construction, so no share is quoted."""
    if floor:
        return "how much error is left above the noise cannot be said: the noise is not measurable"
    return f"{100 * c.explained:.0f} % of the excess error"


def _not_needed_why(c: Candidate) -> str:
    if c.stable is False:
        return "its fitted set is outside the derived stability certificate (energy-producing)"
    return f"removes only {100 * c.explained:.0f} % of the excess error"


def _smoothing_sentence(w: int) -> str:
    if w <= 1:
        return ""
    return (f" The force is smoothed by a {w}-sample moving average (detected in its spectrum): the models were "
            "fitted to the force restored by its regularised inverse and judged through the same average against "
            "the measured force.")


def _base_sentence(check: Mapping) -> str:
    s = ""
    if check.get("budget"):
        s += (f" Time budget: the {' and the '.join(check['budget'])} stopped on {'its' if len(check['budget']) == 1 else 'their'}"
              " share of the budget before converging (give more with --budget).")
    if check and not check.get("as_good", True):
        s += (f" Caution: the diagnosis's base fit (free-run NRMSE {check['nrmse_fit_part']:.3g} on the fitting part) "
              f"is worse than {check['reference']} ({check['reference_nrmse_fit_part']:.3g}): every candidate is "
              "judged against a weaker base.")
    if check.get("stable") is False:
        s += (f" The base fit is outside the derived stability certificate ({check.get('stability')}): "
              "an energy-producing parameter set; treat its numbers with care.")
    return s


def _verdict(res: ResidualAnalysis, cands: Sequence[Candidate], base_held: float, noise_method: str = "given",
             shifted: bool = False) -> str:
    ok = [c for c in cands if c.success and not c.diverged]
    best = ok[0] if ok else None
    where = res.findings()
    floor = noise_method.startswith("held-out residual floor")
    noise_said = (f" (noise level {res.noise:.3g}, from {noise_method.split(':')[0]})" if not floor else
                  f" (the noise is not measurable on this record; the reference {res.noise:.3g} is the lowest held-out "
                  "RMS of any fitted model, an upper bound of the noise)")
    if base_held < EXACT_FIT and not any(c.needed for c in ok):
        return (f"The model fits the record exactly: held-out NRMSE {base_held:.2g}, below {EXACT_FIT:g} (noise-free "
                "data?); nothing is left to explain and no effect is needed.")
    if res.at_noise_level and not any(c.needed for c in ok):
        if floor:
            return ("The model fits as well as any candidate: no catalogued effect lowers the held-out error "
                    f"convincingly (held-out NRMSE {base_held:.3g}){noise_said}.")
        return (f"The model fits to the noise: the residual is white and at the noise level "
                f"(RMS {res.rmse:.3g} vs noise {res.noise:.3g}, from {noise_method}); no effect is needed, and no "
                f"catalogued effect improves the held-out error convincingly.")
    if res.excess < 1.5 and not floor and not any(c.needed for c in ok):
        return (f"The model fits to the noise level but not to white noise: the residual RMS is {res.rmse:.3g}, "
                f"{res.excess:.2g}x the noise (from {noise_method}), yet {100 * res.acf_outside:.0f} % of its "
                "autocorrelation lags are outside the 95 % bound: a small structured misfit remains that no catalogued "
                "effect lowers convincingly; no effect is needed.")
    unstable = [c for c in ok[:STABILITY_CHECKED] if c.stable is False and c.supported and c.explained >= 0.5]
    tail = ""
    if unstable:
        tail = (" Not taken although supported, because the fitted set is outside the derived stability certificate "
                "(energy-producing): " + "; ".join(f"{c.effect} ({c.stability})" for c in unstable) + ".")
    if best is not None and best.needed:
        s = (f"The model fails: {where[0] if where else 'the residual is structured'}{noise_said}. "
             f"Adding {best.effect} ({best.physics}) explains it: the held-out NRMSE falls from {base_held:.3g} to "
             f"{best.nrmse_after:.3g} (dBIC {best.delta_bic:.0f}, {_share(best, floor)}).")
        if best.effect == "force-offset" and shifted and best.explained < 0.5:
            s += " It is taken because the loop is shifted (residual mean a large share of its RMS)."
        ties = [c for c in ok[1:] if c.needed and c.nrmse_after <= best.nrmse_after * (1 + TIE)]
        if ties:
            s += (f" {', '.join(c.effect for c in ties)} explain{'s' if len(ties) == 1 else ''} it almost as well "
                  "here: this record cannot tell them apart.")
        return s + tail
    needed = next((c for c in ok if c.needed), None)
    if needed is not None:
        return (f"The model fails: {where[0] if where else 'the residual is structured'}{noise_said}. "
                f"Adding {needed.effect} ({needed.physics}) explains it: the held-out NRMSE falls from {base_held:.3g} "
                f"to {needed.nrmse_after:.3g} (dBIC {needed.delta_bic:.0f}, {_share(needed, floor)}).") + tail
    if best is not None and best.supported:
        return (f"The model fails: {where[0] if where else 'the residual is structured'}{noise_said}. "
                f"{best.effect} helps (held-out NRMSE {base_held:.3g} -> {best.nrmse_after:.3g}, dBIC "
                f"{best.delta_bic:.0f}) but {_not_needed_why(best)}, so it is not the missing effect with confidence. "
                f"What remains: {'; '.join(where[:2]) if where else 'unclear'}.") + tail
    return ("No catalogued effect explains what the model misses: "
            + ("; ".join(where[:3]) if where else "the residual is structured") + noise_said
            + (f". The best candidate, {best.effect}, changes the held-out NRMSE only from {base_held:.3g} to "
               f"{best.nrmse_after:.3g}." if best is not None else ".") + tail)
