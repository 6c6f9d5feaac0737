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
(within ``TIE``) and its BIC is lower, and the step says so (backward elimination after the forward steps).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Iterable, Mapping

import numpy as np

from duffsym.data.record import Record
from duffsym.errors import DataError, ModelError
from duffsym.diagnose.search import TIE, Diagnosis, _fit, diagnose, with_default_af


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

    def to_dict(self) -> dict:
        out = dict(effects=list(self.effects), nrmse=self.nrmse, bic=self.bic, nrmse_fit=self.nrmse_fit,
                   nrmse_heldout=self.nrmse_heldout, params=self.params, stderr=self.stderr,
                   verdict=self.diagnosis.verdict, needed=list(self.diagnosis.needed),
                   candidates=[c.to_dict() for c in self.diagnosis.candidates])
        if self.discovered is not None:
            out.update(term=self.discovered["term"], latex=self.discovered["latex"], discovered=self.discovered)
        if self.simplified:
            out["simplified"] = self.simplified
        return out


@dataclass(frozen=True)
class Ladder:
    """The steps from the base model to the last supported extension."""

    steps: tuple[Step, ...]
    final_fit: object
    stopped: str
    timings: dict = field(default_factory=dict)
    prepare: object = None  # the decimation of the final fit's data (duffsym.diagnose.prepare.Preparation)

    @property
    def effects(self) -> tuple[str, ...]:
        return self.steps[-1].effects

    def to_dict(self) -> dict:
        return dict(steps=[s.to_dict() for s in self.steps], effects=list(self.effects), stopped=self.stopped,
                    final=dict(params=self.final_fit.params, stderr=self.final_fit.stderr, nrmse=self.final_fit.nrmse,
                               success=self.final_fit.success, status=self.final_fit.status),
                    timings=self.timings, prepare=self.prepare.to_dict() if self.prepare is not None else None)

    def summary(self) -> str:
        lines = ["ladder (free-run NRMSE over the whole record / held-out tail, BIC on the fitting part):"]
        for i, s in enumerate(self.steps):
            lines.append(f"  {i}: {' + '.join(('base',) + s.effects):<45} NRMSE {s.nrmse:.4g}  held-out "
                         f"{s.nrmse_heldout:.4g}  BIC {s.bic:.1f}")
        lines += [f"  step {i} adds a term outside the catalogue (no catalogued effect was needed; it passes the "
                  f"same held-out evidence): {s.discovered['words']}" for i, s in enumerate(self.steps) if s.discovered]
        lines += [f"  step {i}: {s.simplified} (as good on the held-out tail, lower BIC)"
                  for i, s in enumerate(self.steps) if s.simplified]
        lines.append(f"stopped: {self.stopped}")
        lines.append(f"final fit on the whole record: NRMSE {self.final_fit.nrmse:.4g} ({self.final_fit.status})")
        if self.prepare is not None:
            lines.append("final " + self.prepare.summary())
        return "\n".join(lines)


def ladder(record: Record, model=None, *, max_steps: int = 4, candidates: Iterable[str] | None = None,
           fixed: Mapping[str, float] | None = None, holdout: float = 0.3, noise: float | None = None, mask=None,
           accept: str = "needed", discover: bool = True, progress=None, **rules) -> Ladder:
    """Base fit, then add the best supported effect, refit, and repeat (see the module docstring).

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
    rules : ``bic_threshold``, ``min_improvement``, ``min_explained`` of :func:`diagnose`.
    """
    from duffsym.effects import CATALOGUE, apply_effects
    from duffsym.identify.result import nrmse as _nrmse

    t0 = time.perf_counter()
    say = progress or (lambda msg: None)
    if model is None:
        from duffsym.model.library import mr_damper

        model = mr_damper()
    y = np.asarray(record.y, dtype=float)
    base_model = model
    steps: list[Step] = []
    start = None
    stopped = ""
    found = None  # the discovered term of the next step
    while True:
        say(f"step {len(steps)}: {' + '.join(('base',) + tuple(model.effects))}")
        dg = diagnose(record, model, candidates=candidates, fixed=fixed, holdout=holdout, noise=noise, mask=mask,
                      start=start, progress=progress, **rules)
        k = dg.split["n_fit"]
        steps.append(Step(
            effects=tuple(model.effects), nrmse=_nrmse(y, dg.y_base), nrmse_fit=_nrmse(y[:k], dg.y_base[:k]),
            nrmse_heldout=dg.nrmse_heldout, bic=dg.bic_base, params=dict(dg.base_fit.params),
            stderr=dict(dg.base_fit.stderr), diagnosis=dg, discovered=found))
        found = None
        if accept not in ("needed", "supported"):
            raise ValueError(f"accept must be 'needed' or 'supported'; got {accept!r}")
        chosen = dg.needed[0] if dg.needed else None
        if chosen is None and accept == "supported":
            chosen = next((c.effect for c in dg.candidates if c.success and c.supported), None)
        if chosen is None and discover and len(steps) <= max_steps and not dg.residuals.at_noise_level:  # discovery
            found, model, start, note = _discovered(record, model, dg, fixed, mask, progress, rules)
            if found is not None:
                continue
            dg = _with_note(dg, note)
        if chosen is None:
            stopped = "no further effect is supported by the evidence: " + dg.verdict
            break
        if len(steps) > max_steps:
            stopped = f"reached max_steps={max_steps}; the last diagnosis still supported {chosen}"
            break
        best = next(c for c in dg.candidates if c.effect == chosen)
        model = apply_effects(model, [CATALOGUE[best.effect]])
        start = dict(best.all_params)
    kw = dict(fixed=fixed, holdout=holdout, noise=noise, mask=mask, progress=progress, **rules)
    model = _simplify(record, base_model, model, steps, say, kw)
    say("final fit on the whole record")
    last = steps[-1]
    from duffsym.diagnose.prepare import prepare_record

    prep, rec_final = prepare_record(record, rules.get("decimate", True))
    final = _fit(model, rec_final, with_default_af(model, fixed, record), last.params)
    return Ladder(steps=tuple(steps), final_fit=final, stopped=stopped, timings={"total": time.perf_counter() - t0},
                  prepare=prep)


def _nested(name: str, present) -> list[str]:
    """Catalogue entries whose parameters are a proper subset of ``name``'s (e.g. force-offset in
    gas-accumulator), not already in the model."""
    from duffsym.effects import CATALOGUE

    if name not in CATALOGUE:
        return []
    own = {p.name for p in CATALOGUE[name].parameters()}
    return [s for s, e in CATALOGUE.items() if s not in present and s != name
            and 0 < len({p.name for p in e.parameters()}) and {p.name for p in e.parameters()} < own]


def _simplify(record, base_model, model, steps: list, say, kw) -> object:
    """After the last step, backward: each added effect is replaced by a nested simpler catalogue entry, or
    dropped, when the simpler model predicts the held-out tail as well (within ``TIE``) and has the lower
    BIC (see the module docstring); each change is appended as a step. Returns the model of the last step."""
    from duffsym.effects import CATALOGUE, apply_effects
    from duffsym.identify.result import nrmse as _nrmse

    y = np.asarray(record.y, dtype=float)
    if any(e not in CATALOGUE for e in model.effects):  # a discovered term: left as the ladder built it
        return model
    for name in [e for e in model.effects if e not in base_model.effects]:  # only what the ladder added
        for simpler in _nested(name, model.effects) + [None]:
            if name not in model.effects:
                break
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
            if dg.nrmse_heldout <= last.nrmse_heldout * (1 + TIE) and dg.bic_base < last.bic:
                k = dg.split["n_fit"]
                steps.append(Step(
                    effects=tuple(trial.effects), nrmse=_nrmse(y, dg.y_base), nrmse_fit=_nrmse(y[:k], dg.y_base[:k]),
                    nrmse_heldout=dg.nrmse_heldout, bic=dg.bic_base, params=dict(dg.base_fit.params),
                    stderr=dict(dg.base_fit.stderr), diagnosis=dg,
                    simplified=f"{name} -> {simpler}" if simpler else f"{name} dropped"))
                model = trial
                break
    return model


def _discovered(record, model, dg, fixed, mask, progress, rules):
    """(discovery dict, extended model, start) when a discovered term is needed; else (None, model, None, note)."""
    from duffsym.diagnose.discover import discover_term

    judge = {k: v for k, v in rules.items() if k in ("bic_threshold", "min_improvement", "min_explained")}
    disc = discover_term(record, model, dg, fixed=fixed, mask=mask, progress=progress, **judge)
    if not disc.needed:
        why = disc.summary().removeprefix("discovery: ").replace("\n", ";")
        return None, model, None, " Term discovery outside the catalogue: " + why
    (progress or (lambda m: None))(f"adding {disc.effect} (no catalogued effect is needed; it passes the evidence)")
    info = disc.to_dict()
    info["note"] = ("no catalogued effect was needed; this discovered term passes the same held-out evidence "
                    "(dBIC, held-out fall, share of the excess error)")
    return info, disc.model, dict(disc.all_params), ""


def _with_note(dg: Diagnosis, note: str) -> Diagnosis:
    import dataclasses

    return dataclasses.replace(dg, verdict=dg.verdict + note) if note else dg


def error_fell(lad: Ladder) -> float:
    """Held-out NRMSE of the last step over the first (< 1 when the error fell)."""
    a, b = lad.steps[0].nrmse_heldout, lad.steps[-1].nrmse_heldout
    return b / a if a > 0 else math.nan
