r"""Discovery over a campaign: what one parameter set misses across records, and what it follows.

A campaign is several records of one device (currents, pressures, amplitudes, frequencies), fitted with one
parameter set (:func:`duffsym.identify.fit` on a list of records). :func:`discover_campaign` asks what that
parameter set lacks across them, with the method of :mod:`duffsym.diagnose.discover` applied to the whole
campaign:

1. the base model is fitted to the *training* records (the held-out ones are named by the user before any fit,
   by condition: e.g. every record of one pressure, or of one amplitude and frequency);
2. each training record's free-run residual and the derivatives of its free run with respect to the base's
   free parameters are stacked, each record weighted by ``1/std(y)`` (so a 100 N record counts as much as a
   1000 N one, as in its NRMSE);
3. the term library (:func:`duffsym.diagnose.discover.term_library`) is built on the stacked signals, with the
   records' command column (current, pressure) among the positions, so ``command·tanh(d'/ε)`` — a friction
   level that grows with the pressure, a yield that grows with the current — is a candidate;
4. the base's linearised refit is projected out (:func:`~duffsym.diagnose.discover.without_base`) and stability
   selection over resampled input cycles of all training records keeps the stable families;
5. each proposed term set is fitted to the training records through the normal path and run free on every
   record; the lowest BIC on the training records is kept and judged on the held-out records.

The term is *supported* when its BIC on the training records is lower by more than ``BIC_THRESHOLD`` (in
magnitude) and the held-out records' median NRMSE falls; the result names it in words, with the catalogue
effect it resembles, and reports every record's error before and after.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from duffsym.diagnose import discover as D
from duffsym.effects.discovered import DiscoveredEffect, resembles, term_latex, term_words
from duffsym.errors import DataError, ModelError

#: a term is supported when the training BIC falls by more than this (2 ln B > 10: very strong evidence)
BIC_THRESHOLD = 10.0


@dataclass(frozen=True)
class CampaignDiscovery:
    """What :func:`discover_campaign` found: the term (``found``), the evidence, and every record's error."""

    found: bool
    supported: bool
    effect: str
    words: str
    latex: str
    resembles: list
    heldout_before: dict  # held-out record -> free-run NRMSE of the base fit
    heldout_after: dict
    training_before: dict
    training_after: dict
    delta_bic: float  # on the training records (weighted free-run residuals)
    params: dict
    stderr: dict
    selection: dict
    message: str
    seconds: float
    model: object = field(default=None, repr=False)
    result: object = field(default=None, repr=False)  # the extended model's fit (IdentificationResult)

    def to_dict(self) -> dict:
        keys = ("found", "supported", "effect", "words", "latex", "resembles", "heldout_before", "heldout_after",
                "training_before", "training_after", "delta_bic", "params", "stderr", "selection", "message",
                "seconds")  # fmt: skip
        return {k: getattr(self, k) for k in keys}

    def summary(self) -> str:
        med = _median
        lines = [f"campaign discovery: {self.effect or 'no term'}"]
        if self.found:
            like = f" (resembles {', '.join(self.resembles)})" if self.resembles else ""
            lines.append(f"  {self.words}{like}")
            lines.append(
                f"  training median NRMSE {med(self.training_before):.4g} -> {med(self.training_after):.4g}, "
                f"held-out median {med(self.heldout_before):.4g} -> {med(self.heldout_after):.4g} "
                f"(worst {max(self.heldout_before.values()):.4g} -> {max(self.heldout_after.values()):.4g}), "
                f"dBIC {self.delta_bic:.1f}: {'supported' if self.supported else 'not supported'}"
            )
        lines.append(f"  {self.message}")
        return "\n".join(lines)


def _median(d: Mapping[str, float]) -> float:
    return float(np.median(list(d.values()))) if d else math.nan


def discover_campaign(
    records: Sequence,
    model,
    heldout: Sequence[str],
    *,
    base=None,
    fixed: Mapping[str, float] | None = None,
    constraints=None,
    tries: int = D.TRIES,
    time_limit: float | None = None,
    progress: Callable[[str], None] | None = None,
) -> CampaignDiscovery:
    """Look for the term ``model`` lacks across the campaign ``records`` (module docstring).

    ``heldout``: names of the records judged only (never fitted, never used to select); at least one, and at
    least one record left to train on. ``base``: the base model's fit to the training records, if already made.
    ``fixed``, ``constraints``: as for :class:`duffsym.identify.Problem`, in every fit. ``time_limit``: wall
    seconds of each fit (IPOPT's ``max_wall_time``; a fit stopped by it is not a success and is said so).
    """
    t0 = time.perf_counter()
    say = progress or (lambda msg: None)
    train, held = _split(records, heldout)
    if base is None:
        say(f"base fit of {model.name} on {len(train)} training records")
        base = _fit(model, train, fixed, constraints, limit=time_limit)
        if not base.success:
            raise DataError(f"the base fit of {model.name} on the training records failed: {base.message}")
    base_runs = _free_runs(base, records, model)
    before = {name: e for name, (e, _) in base_runs.items()}
    poor = {r.name: before[r.name] for r in train if not before[r.name] < 1.0}
    if poor:
        worst = ", ".join(f"{k} {v:.3g}" for k, v in poor.items())
        why = (
            f"the base model's free run is no better than the records' mean on {worst} (NRMSE >= 1): a term found "
            "in its residual would mean nothing; choose a base that follows the records (e.g. a friction model for "
            "a seal)"
        )
        return _nothing({}, before, held, t0, why)
    effects, selection = propose_campaign(train, model, base, tries)
    if not effects:
        return _nothing(selection, before, held, t0)
    fits = []
    for eff in effects:
        say(f"fitting {eff.name} on the training records")
        ext = eff.apply(model)
        try:
            start = {**base.params, **{p.name: p.default for p in eff.parameters()}}
            res = _fit(ext, train, fixed, constraints, start, limit=time_limit)
        except (ModelError, DataError) as exc:
            say(f"  failed: {exc}")
            continue
        if res.success:
            runs = _free_runs(res, train, ext)
            fits.append((eff, ext, res, runs, _bic(runs, train, len(res.free))))
    if not fits:
        return _nothing(selection, before, held, t0, "the fits of the proposed terms failed")
    eff, ext, res, runs, bic = min(fits, key=lambda f: f[4])
    after = {name: e for name, (e, _) in {**runs, **_free_runs(res, held, ext)}.items()}
    dbic = bic - _bic(base_runs, train, len(base.free))
    return _judged(eff, ext, res, dbic, before, after, held, selection, t0)


def _split(records, heldout: Sequence[str]):
    names = [r.name for r in records]
    unknown = sorted(set(heldout) - set(names))
    if unknown:
        raise DataError(f"held-out record(s) {unknown} are not in the campaign ({names})")
    held = [r for r in records if r.name in set(heldout)]
    train = [r for r in records if r.name not in set(heldout)]
    if not held or not train:
        raise DataError("a campaign discovery needs at least one held-out record and one to train on")
    return train, held


def _fit(model, records, fixed, constraints, x0=None, limit: float | None = None):
    from duffsym.identify import Problem, fit

    fixed = {k: v for k, v in (fixed or {}).items() if k in model.param_names}
    x0 = None if x0 is None else {k: v for k, v in x0.items() if k in model.param_names and k not in fixed}
    problem = Problem(model, list(records), fixed=fixed, constraints=constraints or ())
    return fit(problem, x0=x0) if limit is None else fit(problem, x0=x0, max_wall_time=float(limit))


def _free_runs(res, records, model) -> dict[str, tuple[float, np.ndarray]]:
    """Each record's free run, from the state estimated over its first period (:func:`duffsym.identify.validate`):
    name -> (NRMSE, output). A run worse than the mean (R² < 0) is not a validation success; its NRMSE says by how
    much."""
    from duffsym.identify import validate

    out = {}
    for r in records:
        v = validate(res, r, model)
        out[r.name] = (float(v.nrmse) if math.isfinite(v.nrmse) else math.inf, np.asarray(v.y_sim, float))
    return out


def _bic(runs: Mapping[str, tuple[float, np.ndarray]], records, n_free: int) -> float:
    """n log(RSS/n) + k log n of the free runs (:func:`_free_runs`) on ``records``, each record's residual over its
    std(y)."""
    rss, n = 0.0, 0
    for r in records:
        e = (np.asarray(r.y, float) - runs[r.name][1]) / float(np.std(r.y))
        rss += float(np.sum(e**2)) if np.all(np.isfinite(e)) else math.inf
        n += e.size
    return n * math.log(rss / n) + n_free * math.log(n) if math.isfinite(rss) else math.inf


def stacked(records, model, res) -> tuple[dict, np.ndarray, np.ndarray | None, list[np.ndarray]]:
    """(signals, residual, sensitivities, blocks) of the campaign, stacked record after record, each record's rows
    weighted by ``1/std(y)``; the command column is a position signal when any record has one; blocks are the
    input cycles of every record (:func:`duffsym.diagnose.discover.blocks`)."""
    cols, rs, Js, blocks, w = [], [], [], [], []
    n0 = 0
    for i, rec in enumerate(records):
        x0 = res.x0[i]
        tr = res.simulate(rec, x0=x0)
        c = D.signals(rec, model, np.asarray(tr.x, float))
        c["command"] = np.asarray(rec.command_signal(missing=0.0), float)
        wi = 1.0 / float(np.std(rec.y))
        J = D.base_sensitivities(model, res, rec, len(rec.y), x0=x0)
        Js.append(None if J is None else J * wi)
        rs.append((np.asarray(rec.y, float) - np.asarray(tr.y, float)) * wi)
        w.append(np.full(len(rec.y), wi))
        cols.append(c)
        blocks += [b + n0 for b in D.blocks(rec, len(rec.y))]
        n0 += len(rec.y)
    sig = {k: np.concatenate([c[k] for c in cols]) for k in cols[0]}
    J_all = None if any(J is None for J in Js) else np.vstack([J for J in Js if J is not None])
    return {**sig, "_weight": np.concatenate(w)}, np.concatenate(rs), J_all, blocks


def propose_campaign(records, model, res, tries: int = D.TRIES) -> tuple[list[DiscoveredEffect], dict]:
    """The term sets for the campaign fit ``res`` on ``records``: the families stable over resampled cycles of
    all records, after the base's linearised refit is projected out; as :func:`duffsym.diagnose.discover.propose`
    for one record."""
    sig, r, J, blocks = stacked(records, model, res)
    weight = sig.pop("_weight")[:, None]
    terms, Theta = D.library_matrix(sig)
    Theta = Theta * weight
    varying = [j for j in range(len(terms)) if np.ptp(Theta[:, j]) > 0]  # e.g. the command of records without one
    sel = D.select_stable([terms[j] for j in varying], Theta[:, varying], r, J, blocks)
    selection = {
        "library": len(sel.terms),
        "records": len(records),
        "blocks": len(blocks),
        "inclusion": sel.inclusion(),
        "base_refit": "none" if J is None else f"projected out ({J.shape[1]} free parameters)",
    }
    return sel.effects(sel.supports()[: max(tries, 1)], 1), selection


def _nothing(selection, before, held, t0, message: str = "") -> CampaignDiscovery:
    names = {r.name for r in held}
    best = max(selection.get("inclusion", {"": 0}).items(), key=lambda kv: kv[1], default=("", 0))
    why = message or f"no term is stable over resampled cycles (highest inclusion {best[1]:.2f}, {best[0]})"
    return CampaignDiscovery(
        found=False, supported=False, effect="", words="", latex="", resembles=[],
        heldout_before={k: v for k, v in before.items() if k in names}, heldout_after={},
        training_before={k: v for k, v in before.items() if k not in names}, training_after={},
        delta_bic=math.nan, params={}, stderr={}, selection=selection, message=why,
        seconds=time.perf_counter() - t0,
    )  # fmt: skip


def _judged(eff, ext, res, dbic, before, after, held, selection, t0) -> CampaignDiscovery:
    names = {r.name for r in held}
    hb = {k: v for k, v in before.items() if k in names}
    ha = {k: v for k, v in after.items() if k in names}
    fitted = DiscoveredEffect(eff.terms, tuple(float(res.params[p.name]) for p in eff.parameters()), eff.index)
    expr = fitted.expression(fitted.coefs)
    supported = bool(dbic < -BIC_THRESHOLD and _median(ha) < _median(hb))
    verdict = (
        "the term lowers the training BIC and the held-out error: one parameter set with it describes the campaign "
        "better" if supported else "the term does not pass the evidence (training BIC and held-out median NRMSE)"
    )  # fmt: skip
    own = [p.name for p in eff.parameters()]
    return CampaignDiscovery(
        found=True, supported=supported, effect=fitted.name, words=f"{term_words(expr)} added to the output",
        latex=term_latex(expr), resembles=[x for x in map(resembles, eff.terms) if x],
        heldout_before=hb, heldout_after=ha,
        training_before={k: v for k, v in before.items() if k not in names},
        training_after={k: v for k, v in after.items() if k not in names},
        delta_bic=float(dbic), params={n: float(res.params[n]) for n in own},
        stderr={n: float(res.stderr.get(n, math.nan)) for n in own}, selection=selection, message=verdict,
        seconds=time.perf_counter() - t0, model=ext, result=res,
    )  # fmt: skip
