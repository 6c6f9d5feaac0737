"""Add the missing effects one at a time and watch the error fall.

:func:`ladder` starts from a model, diagnoses it (:func:`~duffsym.diagnose.diagnose`), adds the
effect the evidence supports, diagnoses the extended model, and repeats while an effect is
needed. Each step reports the free-run error on the fitting part and on the held-out tail, the
BIC, and the parameters with their standard errors. The last model is finally refitted on the
whole record (``final_fit``), which is what ``duffsym ladder --out`` saves for ``validate``.

Greedy steps can take a richer effect for a simpler one that a later step makes enough: on an offset +
load-cell-lag record the first step takes ``gas-accumulator`` (the offset's term plus a stiffness that
mimics part of the lag on a sine), the second adds the lag, and the stiffness is then idle. After the
last step every added effect that has a *nested* simpler entry in the catalogue (its parameters a
subset, e.g. ``force-offset`` in ``gas-accumulator``) is tried in its place, and every added effect is
tried without (an effect taken early can become idle once a later one is in: on the same record an input
delay taken for part of the lag); the simpler model is kept when it predicts the held-out tail as well
(within ``TIE``) and its BIC is lower or higher by less than ``PARSIMONY_BIC`` (2: a difference the evidence
cannot tell from none, so the fewer parameters win), and the step says so (backward elimination after the
forward steps).

Several effects fitted together: after each accepted step the extended model is refitted jointly
(:func:`joint_refit`) from several starts — the candidate's own solution, the first base fit with every added
effect's data-based guess, and a continuation from smooth to sharp nonlinearities (a softer play operator,
a wider friction switch) — and the best on the fitting part starts the next diagnosis.

A ladder that finishes: ``budget`` (seconds) bounds the whole run. Each step's diagnosis gets its share (its
base fit, its plain-fit reference and every candidate theirs, see :func:`~duffsym.diagnose.diagnose`), a
reserve is kept for the backward pass and the final fit, and a run stopped by the budget or by Ctrl-C keeps
every finished step and says where it stopped (``stopped``). ``on_step`` is called with the ladder so far
after every step (``duffsym ladder --report`` writes the report then). The end product is never a failed
fit: when the final fit on the whole record does not succeed, the last step's fit (on the fitting part) is
kept and ``final_note`` says so. An added effect whose fitted size is negligible or whose smoothing runs
off is flagged in its step (``inactive``).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from duffsym.data.record import Record
from duffsym.diagnose.options import (
    CANDIDATE_CPU_TIME,
    DEFAULT_BUDGET,
    PARSIMONY_BIC,
    DiagnoseOptions,
    LadderOptions,
)
from duffsym.diagnose.search import TIE, Diagnosis, _fit, diagnose, inactive_effects, time_left, with_default_af
from duffsym.errors import DataError, ModelError
from duffsym.options import field_names, resolve

if TYPE_CHECKING:
    from duffsym.data.decimate import Preparation
    from duffsym.identify.result import IdentificationResult

__all__ = ["DEFAULT_BUDGET", "LadderOptions", "Ladder", "Step", "ladder", "joint_refit", "error_fell"]
#: share of the budget kept for the backward pass and the final fit on the whole record
FINAL_RESERVE = 0.15
#: share of the time left for the steps that one step's diagnosis may take (see _step_deadline)
STEP_SHARE = 0.75


@dataclass(frozen=True)
class Step:
    """One rung of the ladder: the model with ``effects`` and how well it does."""

    effects: tuple[str, ...]
    nrmse: float  # free run over the whole record (fitted on the fitting part)
    nrmse_fit: float
    nrmse_heldout: float
    bic: float
    params: dict
    stderr: dict
    diagnosis: Diagnosis
    discovered: dict | None = None  # the discovered term this step added (see diagnose.discover)
    simplified: str = ""  # "a -> b" when this step replaced an effect by a nested simpler one
    inactive: dict = field(default_factory=dict)  # effect -> why it does nothing at the fitted values
    joint: dict | None = None  # the joint refit that started this step (see joint_refit)
    seconds: float = math.nan
    model: str = ""  # the base model (the element) of this step
    element: str = ""  # how this step's element replaced the previous step's (see _element_switch)

    def to_dict(self) -> dict:
        out = dict(
            effects=list(self.effects),
            nrmse=self.nrmse,
            bic=self.bic,
            nrmse_fit=self.nrmse_fit,
            nrmse_heldout=self.nrmse_heldout,
            params=self.params,
            stderr=self.stderr,
            verdict=self.diagnosis.verdict,
            needed=list(self.diagnosis.needed),
            candidates=[c.to_dict() for c in self.diagnosis.candidates],
        )
        if self.discovered is not None:
            out.update(term=self.discovered["term"], latex=self.discovered["latex"], discovered=self.discovered)
        if self.simplified:
            out["simplified"] = self.simplified
        out.update(inactive=self.inactive, joint=self.joint, seconds=self.seconds, model=self.model)
        if self.element:
            out["element"] = self.element
        return out


@dataclass(frozen=True)
class Ladder:
    """The steps from the base model to the last supported extension."""

    steps: tuple[Step, ...]
    final_fit: IdentificationResult | None
    stopped: str
    timings: dict = field(default_factory=dict)
    prepare: Preparation | None = None  # the decimation of the final fit's data (duffsym.diagnose.prepare.Preparation)
    final_note: str = ""  # when the final fit is not a refit on the whole record, why
    budget: float | None = None
    complete: bool = True  # False: stopped by the budget or an interruption before its natural end

    @property
    def effects(self) -> tuple[str, ...]:
        return self.steps[-1].effects

    def to_dict(self) -> dict:
        final = (
            None
            if self.final_fit is None
            else dict(
                params=self.final_fit.params,
                stderr=self.final_fit.stderr,
                nrmse=self.final_fit.nrmse,
                success=self.final_fit.success,
                status=self.final_fit.status,
                note=self.final_note,
            )
        )
        return dict(
            steps=[s.to_dict() for s in self.steps],
            effects=list(self.effects),
            stopped=self.stopped,
            final=final,
            timings=self.timings,
            budget=self.budget,
            complete=self.complete,
            prepare=self.prepare.to_dict() if self.prepare is not None else None,
        )

    def summary(self) -> str:
        lines = ["ladder (free-run NRMSE over the whole record / held-out tail, BIC on the fitting part):"]
        for i, s in enumerate(self.steps):
            base = "base" if s.model == self.steps[0].model else s.model
            lines.append(
                f"  {i}: {' + '.join((base,) + s.effects):<45} NRMSE {s.nrmse:.4g}  held-out "
                f"{s.nrmse_heldout:.4g}  BIC {s.bic:.1f}"
            )
        lines += [
            f"  step {i} adds a term outside the catalogue (no catalogued effect was needed; it passes the "
            f"same held-out evidence): {s.discovered['words']}"
            for i, s in enumerate(self.steps)
            if s.discovered
        ]
        lines += [
            f"  step {i}: {s.simplified} (as good on the held-out tail, "
            + ("lower BIC)" if s.bic < self.steps[i - 1].bic else f"BIC within {PARSIMONY_BIC:g}: fewer parameters)")
            for i, s in enumerate(self.steps)
            if s.simplified
        ]
        lines += [f"  step {i}: {s.element}" for i, s in enumerate(self.steps) if s.element]
        lines += [
            f"  step {i}: {e} is inactive: {why}" for i, s in enumerate(self.steps) for e, why in s.inactive.items()
        ]
        lines.append(f"stopped: {self.stopped}")
        if self.final_fit is None:
            lines.append("no final fit: " + self.final_note)
        elif self.final_note:
            lines.append(f"final fit: NRMSE {self.final_fit.nrmse:.4g} ({self.final_fit.status}); {self.final_note}")
        else:
            lines.append(f"final fit on the whole record: NRMSE {self.final_fit.nrmse:.4g} ({self.final_fit.status})")
        if self.prepare is not None:
            lines.append("final " + self.prepare.summary())
        return "\n".join(lines)


def ladder(record: Record, model=None, options: LadderOptions | None = None, **settings) -> Ladder:
    """Base fit, then add the best supported effect, refit, and repeat (see the module docstring).

    The settings are the fields of :class:`~duffsym.diagnose.options.LadderOptions`, given as an ``options``
    object, by keyword, or both (the keywords win); the settings of each step's :func:`diagnose` (``screen``,
    ``sindy``, ``bic_threshold``, ...) are also taken by keyword and go into its ``rules``. An unknown setting
    raises :class:`TypeError`.

    Parameters
    ----------
    record, model, candidates, fixed, holdout, noise, mask, progress : as for :func:`diagnose`.
    max_steps : at most this many effects are added.
    accept : ``"needed"`` (default): add an effect only when the diagnosis calls it needed (it removes
        at least half of the excess held-out error: a confident verdict). ``"supported"``: also add
        the best *supported* effect (ΔBIC and held-out improvement pass, but it explains less than
        half of what is left) — for records where several small real effects remain, each too small
        to dominate the residual. Stricter evidence against an effect outside the catalogue is then
        the user's call: each step's held-out error is reported.
    discover : (default on) when no catalogued effect is needed, look outside the catalogue
        (:func:`~duffsym.diagnose.discover.discover_term`: a drifting parameter when the error grows over
        the record, else an output term); it is added only when it passes the same evidence as a needed
        catalogued effect, and the step says so (``"term"``, ``"latex"``).
    budget : seconds for the whole run (None: no limit; ``duffsym ladder`` defaults to ``DEFAULT_BUDGET``).
        ``FINAL_RESERVE`` of it is kept for the backward pass and the final fit; each step's diagnosis
        gets the rest of the time left (its fits their shares, see :func:`diagnose`'s ``deadline``).
    joint : after each accepted step, refit all accepted effects jointly from several starts
        (:func:`joint_refit`) and start the next diagnosis from the best.
    on_step : called with the :class:`Ladder` so far (``complete=False``, no final fit) after each step.
    rules : ``bic_threshold``, ``min_improvement``, ``min_explained`` of :func:`diagnose` (and its other
        settings: ``screen``, ``sindy``, ``decimate``, ``engine``, ...).
    """
    o = _ladder_options(options, settings)
    if o.accept not in ("needed", "supported"):
        raise ValueError(f"accept must be 'needed' or 'supported'; got {o.accept!r}")
    run = _Run(record, o, model)
    try:
        _climb(run)
    except KeyboardInterrupt:
        if not run.steps:
            raise
        stopped = f"stopped at step {len(run.steps)}: interrupted (Ctrl-C)"
        return _finish(
            record,
            run.steps,
            None,
            stopped,
            False,
            run.t0,
            o.budget,
            None,
            "interrupted before the final fit: the last finished step's fit (on the fitting part) is the result",
        )
    rules = dict(o.rules)
    kw = dict(fixed=o.fixed, holdout=o.holdout, noise=o.noise, mask=o.mask, progress=o.progress, **rules)
    model = run.model
    if run.steps and tuple(model.effects) == run.steps[-1].effects:  # the last step's model is the result
        model = _simplify(record, run.base_model, model, run.steps, run.say, {**kw, "deadline": run.end})
    return _final(
        record, model, run.steps, run.stopped, run.complete, run.t0, o.budget, run.end, o.fixed, rules, run.say
    )


#: the settings of :func:`diagnose` a ladder sets itself for each step (the others may be given as ``rules``)
_SET_BY_LADDER = ("start", "deadline")


def _ladder_options(options: LadderOptions | None, settings: Mapping) -> LadderOptions:
    """``options`` with ``settings``: the ladder's own fields, and :func:`diagnose`'s settings added to ``rules``."""
    own = set(field_names(LadderOptions))
    passed = set(field_names(DiagnoseOptions)) - own - set(_SET_BY_LADDER)
    rules = {k: v for k, v in settings.items() if k in passed}
    o = resolve(LadderOptions, options, {k: v for k, v in settings.items() if k not in passed}, "ladder")
    return dataclasses.replace(o, rules={**o.rules, **rules}) if rules else o


class _Run:
    """A ladder run in progress: its options, clock and budget, the steps so far, the model being extended and
    the start of its next diagnosis (the discovered term and the joint refit that started it)."""

    def __init__(self, record: Record, o: LadderOptions, model):
        self.record, self.o = record, o
        self.t0 = time.perf_counter()
        self.end: float | None = None
        self.steps_end: float | None = None
        if o.budget is not None:
            self.end = time.monotonic() + float(o.budget)
            self.steps_end = self.end - FINAL_RESERVE * float(o.budget)
        self.say = o.progress or (lambda msg: None)
        if model is None:
            from duffsym.model.library import mr_damper

            model = mr_damper()
        self.model = self.base_model = model
        self.steps: list[Step] = []
        self.start: dict[str, float] | None = None
        self.stopped, self.complete = "", True
        self.found: Any = None  # the discovered term of the next step
        self.jinfo: dict | None = None  # the joint refit that starts the next step
        self.element = ""  # the element switch that starts the next step (see _element_switch)

    def stop(self, why: str, complete: bool = True) -> None:
        self.stopped, self.complete = why, complete


def _climb(run: _Run) -> None:
    """The forward steps: diagnose, take the needed (or supported, or discovered) effect, refit jointly, repeat
    until none is taken, the budget runs out or ``max_steps`` is reached (``run.stopped`` says which)."""
    o, record = run.o, run.record
    while True:
        if run.steps and time_left(run.steps_end) <= 0:
            return run.stop(f"stopped at step {len(run.steps)}: the time budget ({o.budget:g} s) ran out", False)
        base = "base" if not run.steps or run.base_model.name == run.steps[0].model else run.base_model.name
        run.say(f"step {len(run.steps)}: {' + '.join((base,) + tuple(run.model.effects))}" + _left_text(run.end))
        t_step = time.perf_counter()
        try:
            dg = diagnose(record, run.model, candidates=o.candidates, start=run.start, **_step_settings(run))
        except (ModelError, DataError) as exc:
            if not run.steps:
                raise
            return run.stop(f"stopped at step {len(run.steps)}: its diagnosis failed: {exc}", False)
        seconds = time.perf_counter() - t_step
        run.steps.append(_step(record, run.model, dg, run.found, run.jinfo, seconds, run.element))
        run.found = run.jinfo = None
        run.element = ""
        _report(o.on_step, run.steps, run.t0, o.budget, record)
        chosen = dg.needed[0] if dg.needed else None
        if chosen is None and o.accept == "supported":
            chosen = next((c.effect for c in dg.candidates if c.success and c.supported), None)
        if chosen in (None, "contact-gap") and len(run.steps) <= o.max_steps and _element_switch(run, dg):
            continue
        if chosen is None and o.discover and len(run.steps) <= o.max_steps and dg.residuals.worth_a_search:
            dg, found = _discovery_step(run, dg)
            if found:
                continue
        if not _take(run, dg, chosen):
            return


def _step_settings(run: _Run) -> dict:
    """The diagnosis settings every step of ``run`` shares (its options, decision rules and the step's share of the
    time budget); the candidates and the start are the step's own."""
    o = run.o
    return dict(
        fixed=o.fixed,
        holdout=o.holdout,
        noise=o.noise,
        mask=o.mask,
        progress=o.progress,
        deadline=_step_deadline(run.steps_end, run.steps, o.max_steps),
        **o.rules,
    )


#: rate-dependent base models and their rate-independent form (the element in the path of d)
PATH_FORMS = {"mr-damper": "mr-damper-path"}
#: the ladder switches to the rate-independent element when its held-out error is below this fraction of the best
#: without it
SWITCH_GAIN = 0.9


def _element_switch(run: _Run, dg: Diagnosis) -> bool:
    """A contact gap is a friction element's play: its force is held on both sides of the gap, and a friction
    element's loop does not depend on the speed. When ``contact-gap`` fitted on a rate-dependent element that has
    a rate-independent form (``PATH_FORMS``), that form is fitted with the model's effects and the gap; the ladder
    switches to it (True) when it predicts the held-out tail clearly better (``SWITCH_GAIN``), and the next step
    says so."""
    from duffsym.effects import CATALOGUE, apply_effects
    from duffsym.model.library import get_model

    gap = next((c for c in dg.candidates if c.effect == "contact-gap" and c.success), None)
    name = PATH_FORMS.get(run.base_model.name)
    if gap is None or name is None or any(e not in CATALOGUE for e in run.model.effects):
        return False
    n = dict(run.base_model.structural).get("n_x")
    try:
        base = get_model(name, None if n is None else int(n))
        trial = apply_effects(base, [CATALOGUE[e] for e in (*run.model.effects, "contact-gap")])
    except (ModelError, TypeError, ValueError):
        return False
    before = min(dg.nrmse_heldout, gap.nrmse_after)
    run.say(f"  contact-gap on a rate-dependent element: trying the rate-independent element {name}")
    try:
        trial_dg = diagnose(run.record, trial, candidates=[], **{**_step_settings(run), "sindy": False})
    except (ModelError, DataError) as exc:
        run.say(f"  {name}: {exc}")
        return False
    after = trial_dg.nrmse_heldout
    if not (trial_dg.base_fit.success and after < SWITCH_GAIN * before):
        run.say(f"  {name} + contact-gap: held-out {after:.3g} against {before:.3g}: the element is kept")
        return False
    run.element = (
        f"the element {run.base_model.name} replaced by its rate-independent form {name} (a friction element: "
        f"the force is held on both sides of the gap), with contact-gap: held-out {before:.3g} -> {after:.3g}"
    )
    run.base_model, run.model, run.start = base, trial, dict(trial_dg.base_fit.params)
    return True


def _discovery_step(run: _Run, dg: Diagnosis) -> tuple[Diagnosis, bool]:
    """Look outside the catalogue (no catalogued effect was taken): (the diagnosis, with a note when nothing was
    found or there was no time, True when a discovered term extends the model for the next step)."""
    if run.steps_end is not None and time.monotonic() >= run.steps_end:
        return _with_note(dg, " Term discovery outside the catalogue: not tried, the time budget ran out."), False
    found, model, start, note = _discovered(
        run.record, run.model, dg, run.o.fixed, run.o.mask, run.o.progress, run.o.rules, run.steps_end
    )
    if found is not None:
        run.found, run.model, run.start = found, model, start
        return dg, True
    return _with_note(dg, note), False


def _take(run: _Run, dg: Diagnosis, chosen: str | None) -> bool:
    """Add ``chosen`` to the model (and refit jointly) and return True, or say why the ladder stops and return
    False."""
    from duffsym.effects import CATALOGUE, apply_effects

    o, n = run.o, len(run.steps)
    missed = _out_of_time(dg)
    if chosen is None and missed and run.end is not None:
        run.stop(
            f"stopped at step {n - 1}: the time budget ran out before every candidate was fitted "
            f"({len(missed)} of {len(dg.candidates)} not tried or not converged: {', '.join(missed)}): {dg.verdict}",
            False,
        )
        return False
    if chosen is None and missed:  # no budget: only the per-candidate CPU allowance stopped them
        cpu = o.rules.get("candidate_cpu_time", CANDIDATE_CPU_TIME)
        run.stop(
            f"no further effect is supported by the evidence: {dg.verdict} ({', '.join(missed)}: not converged "
            f"within candidate_cpu_time = {cpu} s; None fits each candidate to the end)"
        )
        return False
    if chosen is None:
        run.stop("no further effect is supported by the evidence: " + dg.verdict)
        return False
    if n > o.max_steps:
        run.stop(f"reached max_steps={o.max_steps}; the last diagnosis still supported {chosen}")
        return False
    best = next(c for c in dg.candidates if c.effect == chosen)
    run.model = apply_effects(run.model, [CATALOGUE[best.effect]])
    run.start = dict(best.all_params)
    if o.joint:
        run.start, run.jinfo = joint_refit(
            run.record,
            run.base_model,
            run.model,
            run.steps,
            run.start,
            fixed=o.fixed,
            holdout=o.holdout,
            mask=o.mask,
            deadline=run.steps_end,
            say=run.say,
            decimate=o.rules.get("decimate", True),
        )
    return True


def _step_deadline(steps_end, steps, max_steps: int):
    """A step's diagnosis may take ``STEP_SHARE`` of the time left for the steps (all of it for the last
    step ``max_steps`` allows), so that a first step on a slow machine leaves time for the next."""
    if steps_end is None:
        return None
    left = time_left(steps_end)
    return steps_end if len(steps) >= max_steps else time.monotonic() + STEP_SHARE * left


def _out_of_time(dg: Diagnosis) -> list[str]:
    """The candidates of ``dg`` that a time limit (the budget or the per-candidate CPU allowance) left unfitted
    or unconverged."""
    from duffsym.diagnose.search import NOT_TRIED

    return [
        c.effect
        for c in dg.candidates
        if not c.success and (c.message.startswith(NOT_TRIED) or "Time_Exceeded" in c.message)
    ]


def _left_text(end) -> str:
    left = time_left(end)
    return "" if not math.isfinite(left) else f" (budget: {max(left, 0):.0f} s left)"


def _step(record, model, dg: Diagnosis, found, jinfo, seconds, element: str = "") -> Step:
    """A :class:`Step` from a diagnosis, with its inactive effects flagged."""
    from duffsym.identify.result import nrmse as _nrmse

    y = dg.measured(record)
    k = dg.split.n_fit
    params = dict(dg.base_fit.params)
    return Step(
        effects=tuple(model.effects),
        nrmse=_nrmse(y, dg.y_base),
        nrmse_fit=_nrmse(y[:k], dg.y_base[:k]),
        nrmse_heldout=dg.nrmse_heldout,
        bic=dg.bic_base,
        params=params,
        stderr=dict(dg.base_fit.stderr),
        diagnosis=dg,
        discovered=found,
        joint=jinfo,
        inactive=inactive_effects(model, record, params, dg.base_fit.stderr),
        seconds=seconds,
        model=model.name,
        element=element,
    )


def _report(on_step, steps, t0, budget, record) -> None:
    """``on_step`` with the ladder so far (no final fit yet)."""
    if on_step is not None:
        on_step(
            Ladder(
                steps=tuple(steps),
                final_fit=None,
                stopped=f"running: {len(steps)} step(s) done",
                timings=_timings(t0),
                budget=budget,
                complete=False,
                final_note="the run has not finished; the last step's fit is on the fitting part",
            )
        )


def _final(record, model, steps, stopped, complete, t0, budget, end, fixed, rules, say) -> Ladder:
    """The last step's model refitted on the whole record (on what is left of the budget); when that fit does
    not succeed, the last step's own fit (a converged fit on the fitting part) is kept and the note says so."""
    from duffsym.diagnose.search import BAND_TIME, BUDGET_SAMPLES, _prepare_fit, refine_in_band

    last = steps[-1]
    dg = last.diagnosis
    work = dg.work(record)  # as the steps fitted it (a force smoothed by a moving average: restored)
    say("final fit on the whole record" + _left_text(end))
    prep, rec_final, _ = _prepare_fit(work, work, None, rules.get("decimate", True), BUDGET_SAMPLES)
    left = time_left(end)
    wall = None if not math.isfinite(left) else max(left, 5.0)
    final = _fit(model, rec_final, with_default_af(model, fixed, work), last.params, max_wall_time=wall)
    if final.success and dg.band is not None and time_left(end) >= BAND_TIME:  # as every step's fit: in the band
        final, _ = refine_in_band(model, final, work, work.n_times, dg.band, None, [(dict(last.params), ())], end)
    note = ""
    if not final.success:
        note = (
            f"the final fit on the whole record did not succeed ({final.status}); kept instead: the last step's "
            "fit on the fitting part" + ("" if last.diagnosis.base_fit.success else " (itself not converged)")
        )
        say(note)
        final = last.diagnosis.base_fit
    return Ladder(
        steps=tuple(steps),
        final_fit=final,
        stopped=stopped,
        timings=_timings(t0),
        prepare=prep,
        final_note=note,
        budget=budget,
        complete=complete,
    )


def _timings(t0: float) -> dict:
    """Wall seconds since ``t0`` and this process's CPU seconds (on a shared machine the CPU time is the
    measure that does not depend on the load)."""
    return {"total": time.perf_counter() - t0, "cpu_process": time.process_time()}


def _finish(record, steps, final, stopped, complete, t0, budget, prep, note) -> Ladder:
    return Ladder(
        steps=tuple(steps),
        final_fit=final if final is not None else steps[-1].diagnosis.base_fit,
        stopped=stopped,
        timings=_timings(t0),
        prepare=prep,
        final_note=note,
        budget=budget,
        complete=complete,
    )


def _nested(name: str, present) -> list[str]:
    """Catalogue entries whose parameters are a proper subset of ``name``'s (e.g. force-offset in
    gas-accumulator), not already in the model."""
    from duffsym.effects import CATALOGUE

    if name not in CATALOGUE:
        return []
    own = {p.name for p in CATALOGUE[name].parameters()}
    return [
        s
        for s, e in CATALOGUE.items()
        if s not in present
        and s != name
        and 0 < len({p.name for p in e.parameters()})
        and {p.name for p in e.parameters()} < own
    ]


def _simplify(record, base_model, model, steps: list, say, kw) -> object:
    """After the last step, backward: each added effect is replaced by a nested simpler catalogue entry, or
    dropped, when the simpler model predicts the held-out tail as well (within ``TIE``) and its BIC is not
    higher by more than ``PARSIMONY_BIC`` (see the module docstring); each change is appended as a step.
    Returns the model of the last step."""
    from duffsym.effects import CATALOGUE, apply_effects
    from duffsym.identify.result import nrmse as _nrmse

    if any(e not in CATALOGUE for e in model.effects):  # a discovered term: left as the ladder built it
        return model
    for name in [e for e in model.effects if e not in base_model.effects]:  # only what the ladder added
        for simpler in _nested(name, model.effects) + [None]:
            if name not in model.effects:
                break
            if time_left(kw.get("deadline")) <= 0:
                say("simplify: skipped, the time budget has run out")
                return model
            last = steps[-1]
            added = [e for e in model.effects if e not in base_model.effects]
            effects = [e for e in (simpler if e == name else e for e in added) if e is not None]
            trial = apply_effects(base_model, [CATALOGUE[e] for e in effects]) if effects else base_model
            say(f"simplify: {name} -> {simpler or 'nothing'}")
            try:
                dg = diagnose(record, trial, candidates=[], start=dict(last.params), **{**kw, "sindy": False})
            except (ModelError, DataError) as exc:  # the simpler model cannot even be fitted: keep the richer one
                say(f"  not simpler: {exc}")
                continue
            if (
                dg.base_fit.success
                and dg.nrmse_heldout <= last.nrmse_heldout * (1 + TIE)
                and dg.bic_base < last.bic + PARSIMONY_BIC
            ):
                k = dg.split.n_fit
                y = dg.measured(record)
                steps.append(
                    Step(
                        effects=tuple(trial.effects),
                        nrmse=_nrmse(y, dg.y_base),
                        nrmse_fit=_nrmse(y[:k], dg.y_base[:k]),
                        nrmse_heldout=dg.nrmse_heldout,
                        bic=dg.bic_base,
                        params=dict(dg.base_fit.params),
                        stderr=dict(dg.base_fit.stderr),
                        diagnosis=dg,
                        simplified=f"{name} -> {simpler}" if simpler else f"{name} dropped",
                    )
                )
                model = trial
                break
    return model


def _discovered(record, model, dg, fixed, mask, progress, rules, deadline=None):
    """(discovery dict, extended model, start) when a discovered term is needed; else (None, model, None, note)."""
    from duffsym.diagnose.discover import discover_term, on_engine

    judge = {k: v for k, v in rules.items() if k in ("bic_threshold", "min_improvement", "min_explained")}
    with on_engine(rules.get("engine")):
        disc = discover_term(record, model, dg, fixed=fixed, mask=mask, progress=progress, deadline=deadline, **judge)
    if not disc.needed:
        why = disc.summary().removeprefix("discovery: ").replace("\n", ";")
        return None, model, None, " Term discovery outside the catalogue: " + why
    (progress or (lambda m: None))(f"adding {disc.effect} (no catalogued effect is needed; it passes the evidence)")
    info = disc.to_dict()
    info["note"] = (
        "no catalogued effect was needed; this discovered term passes the same held-out evidence "
        "(dBIC, held-out fall, share of the excess error)"
    )
    return info, disc.model, dict(disc.all_params), ""


def _with_note(dg: Diagnosis, note: str) -> Diagnosis:
    import dataclasses

    return dataclasses.replace(dg, verdict=dg.verdict + note) if note else dg


def error_fell(lad: Ladder) -> float:
    """Held-out NRMSE of the last step over the first (< 1 when the error fell)."""
    a, b = lad.steps[0].nrmse_heldout, lad.steps[-1].nrmse_heldout
    return b / a if a > 0 else math.nan


#: IPOPT CPU seconds of each fit of the joint refit (without a budget; with one, a share of the time left)
JOINT_CPU_TIME = 60.0


def _as_judged(dg: Diagnosis, record: Record) -> tuple[Diagnosis, np.ndarray, Record]:
    """(``dg``, the measured force as it judged its free runs: a low-pass filtered force in its band, ``record`` as it
    fitted its models: a force smoothed by a moving average restored)."""
    return dg, dg.measured(record), dg.work(record)


def joint_refit(
    record: Record,
    base_model,
    model,
    steps,
    start: Mapping[str, float],
    *,
    fixed=None,
    holdout: float = 0.3,
    mask=None,
    deadline: float | None = None,
    say=None,
    decimate=True,
):
    """All effects the ladder has added to ``base_model`` (now ``model``) refitted together on the fitting part,
    from several starts; returns (the best start for the next diagnosis, what each start reached).

    Starts: ``"candidate"``, the accepted candidate's own fit (``start``, not refitted); ``"guesses"`` (with two
    or more added effects), the first base fit with every added effect's data-based guess made from that base
    fit's free run; ``"continuation"`` (when an added effect has a smoother form, ``SMOOTH_FORMS``, or a
    friction switch), the model with the smoother forms (and the friction switches wide, ``seal_eps`` at a fifth
    of the largest piston speed) fitted from the guesses, then the sharp model from there. The best by the
    free-run error on the fitting part (never the held-out tail) is kept.
    """
    import dataclasses

    from duffsym.diagnose.search import (
        BUDGET_SAMPLES,
        SMOOTH_FORMS,
        _fit,
        _part,
        _prepare_fit,
        _time_share,
        _within_range,
        free_run,
        split_record,
    )
    from duffsym.effects import CATALOGUE, apply_effects

    say = say or (lambda msg: None)
    added = [e for e in model.effects if e not in base_model.effects]
    if any(e not in CATALOGUE for e in added):
        return dict(start), None
    dg, y, work = _as_judged(steps[-1].diagnosis, record)
    k = split_record(record, holdout)
    rec_fit = _part(work, k)
    mask_fit = None if mask is None or "backlash" in model.effects else np.asarray(mask, dtype=bool)[:k]
    _, rec_q, mask_q = _prepare_fit(work, rec_fit, mask_fit, decimate, BUDGET_SAMPLES)
    fixed_m = with_default_af(model, fixed, rec_fit)

    def score(m, params, x0):
        yy = dg.judged(free_run(m, params, work, x0))
        return math.inf if not _within_range(yy, y) else float(np.sqrt(np.mean((y[:k] - yy[:k]) ** 2)) / np.std(y[:k]))

    def run(m, p0, label):
        if time_left(deadline) <= 1.0:
            return None
        say(f"  joint refit of {' + '.join(added)}: {label}")
        fr = _fit(
            m,
            rec_q,
            fixed_m,
            p0,
            mask=mask_q,
            max_iter=300,
            flags=False,
            max_cpu_time=JOINT_CPU_TIME,
            max_wall_time=_time_share(deadline, 0.1),
        )
        return fr

    y_cand = dg.y_candidates.get(added[-1])
    e_cand = math.inf if y_cand is None else float(np.sqrt(np.mean((y[:k] - y_cand[:k]) ** 2)) / np.std(y[:k]))
    tried = {"candidate": (e_cand, dict(start))}
    y0 = np.asarray(steps[0].diagnosis.y_base, dtype=float)[:k]
    guess = {**model.defaults(), **dict(steps[0].params)}
    for e in added:
        guess.update(CATALOGUE[e].initial_guess(rec_fit, y0))
    guess.update({n: v for n, v in fixed_m.items() if n in guess})
    smooth = {e: SMOOTH_FORMS[e] for e in added if e in SMOOTH_FORMS}
    if len(added) >= 2:
        fr = run(model, guess, "from every effect's own guess")
        if fr is not None:
            tried["guesses"] = (score(model, fr.params, fr.x0[0]), dict(fr.params))
    if smooth or "seal-friction" in added:
        catalogue: dict[str, Any] = dict(CATALOGUE)  # dataclass instances (Effect's subclasses are dataclasses)
        soft = apply_effects(
            base_model, [dataclasses.replace(catalogue[e], **smooth[e]) if e in smooth else catalogue[e] for e in added]
        )
        g = dict(guess)
        if "seal_eps" in g:
            g["seal_eps"] = 0.2 * float(np.max(np.abs(np.asarray(record.velocity(), dtype=float))))
        fr = run(soft, g, "smooth forms first")
        fr = run(model, dict(fr.params), "then the sharp forms") if fr is not None else None
        if fr is not None:
            tried["continuation"] = (score(model, fr.params, fr.x0[0]), dict(fr.params))
    best = min(tried, key=lambda n: tried[n][0])
    info = {"starts": {n: v[0] for n, v in tried.items()}, "chosen": best}
    say(
        f"  joint refit: {best} start kept (fitting-part NRMSE "
        + ", ".join(f"{n} {v[0]:.4g}" for n, v in tried.items())
        + ")"
    )
    return tried[best][1], info
