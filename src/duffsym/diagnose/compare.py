r"""``duffsym compare``: several models fitted on the same training records with the same machinery, scored on
held-out data chosen before any fit.

For each model: the collocation fit (:func:`duffsym.identify.fit`, ``n_starts`` IPOPT runs: the first from
the model's start (:func:`duffsym.identify.initial_guess`), the others random log-uniform factors of it), then

- **held-out NRMSE** per record and over the campaign (pooled, RMS(y - yhat) / RMS(y - mean y)). Without
  ``validate`` records, the last ``holdout`` fraction of every record is held out (the split is made before the
  fits; the model is fitted on the first part and its free run is continued from the fitted initial state over
  the whole record, scored on the tail). With ``validate`` records, each is simulated by
  :func:`duffsym.identify.validate` (initial state refined on its first input period);
- the in-sample free-run NRMSE beside it, the number of free parameters, **BIC** :math:`n\log(\mathrm{SSR}/n) +
  k\log n` on the training samples (SSR the fit's collocation cost);
- the **fit time** (wall seconds, build + solve + free run + standard errors) and the **fraction of starts that
  reach the best optimum** (collocation cost within 1 % of the best run's);
- the **simulation cost** per sample (compiled run of the fitted model over the training records, second run
  timed) and the **stiffness met**: mean and largest RK4 substeps per sample (the integrator takes
  :math:`h\rho(J) \le` ``H_LAMBDA`` per substep, so the substeps measure the stiffness) and whether the run fell
  back to the implicit integrator;
- the **stability certificate**: the derived Lyapunov conditions (:func:`duffsym.derive.stability_conditions`,
  at each held command for a command-driven model) hold or fail for the fitted set; for a Bouc-Wen law the
  literature's bound on z (Ikhouane, Manosa, Rodellar 2007, Spencer's sign convention: A > 0, gamma > 0,
  \|beta\| <= gamma) - a boundedness result, not a Lyapunov certificate; otherwise "none derived".
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import cast

import numpy as np

from duffsym.errors import DataError, ModelError

#: Default fraction of each record held out (its end).
HOLDOUT = 0.3
#: A start "reaches the best optimum" when its collocation cost is within this relative distance of the best.
SAME_OPTIMUM = 0.01


@dataclass(frozen=True)
class ModelScore:
    """One model's row of the comparison (see the module docstring for each number)."""

    model: str
    success: bool
    n_params: int
    heldout_nrmse: float
    heldout_records: dict
    insample_nrmse: float
    bic: float
    fit_seconds: float
    starts: int
    starts_at_best: int
    sim_seconds_per_sample: float
    substeps_mean: float
    substeps_max: int
    integrator: str
    certificate: str
    params: dict = field(default_factory=dict)
    message: str = ""

    @property
    def start_fraction(self) -> float:
        return self.starts_at_best / self.starts if self.starts else math.nan

    def to_dict(self) -> dict:
        from duffsym._json import jsonable

        out = {k: getattr(self, k) for k in self.__dataclass_fields__}
        out["start_fraction"] = self.start_fraction
        return jsonable(out)


@dataclass(frozen=True)
class Comparison:
    """The table of :func:`compare`: one :class:`ModelScore` per model, the split used, the predictions."""

    scores: tuple
    split: str
    training: tuple
    heldout: tuple
    predictions: dict = field(default_factory=dict, repr=False)

    def best(self) -> ModelScore | None:
        ok = [s for s in self.scores if s.success and math.isfinite(s.heldout_nrmse)]
        return min(ok, key=lambda s: s.heldout_nrmse) if ok else None

    def to_dict(self) -> dict:
        best = self.best()
        return {
            "split": self.split,
            "training": list(self.training),
            "heldout": list(self.heldout),
            "best": best.model if best else None,
            "models": [s.to_dict() for s in self.scores],
            "table": self.summary(),
        }

    def summary(self) -> str:
        head = (
            f"{'model':<26} {'held-out':>8} {'in-sample':>9} {'k':>3} {'BIC':>10} {'fit s':>7} {'starts':>7} "
            f"{'us/sample':>9} {'substeps':>9}  certificate"
        )
        lines = [f"comparison on {len(self.training)} training record(s); held out: {self.split}", head]
        for s in self.scores:
            lines.append(
                f"{s.model:<26} {s.heldout_nrmse:>8.4f} {s.insample_nrmse:>9.4f} {s.n_params:>3d} "
                f"{s.bic:>10.4g} {s.fit_seconds:>7.1f} {s.starts_at_best:>3d}/{s.starts:<3d} "
                f"{s.sim_seconds_per_sample * 1e6:>9.3f} {s.substeps_mean:>5.1f}/{s.substeps_max:<3d} "
                f"{s.certificate}" + ("" if s.success else f"  [FAILED: {s.message[:60]}]")
            )
        best = self.best()
        if best is not None:
            lines.append(f"best held-out: {best.model} ({best.heldout_nrmse:.4f})")
        recs = list(self.scores[0].heldout_records) if self.scores else []
        if recs:
            lines.append("held-out NRMSE per record: " + ", ".join(recs))
            for s in self.scores:
                lines.append(f"  {s.model:<24} " + " ".join(f"{s.heldout_records.get(r, math.nan):.4f}" for r in recs))
        return "\n".join(lines)


def split_records(records: Sequence, holdout: float = HOLDOUT) -> tuple[list, list]:
    """(training part, held-out tail) of each record: the last ``holdout`` fraction held out."""
    if not 0.0 < holdout < 1.0:
        raise DataError(f"holdout must be a fraction in (0, 1) of each record; got {holdout!r}")
    train, tail = [], []
    for r in records:
        k = int(round(r.n_times * (1.0 - holdout)))
        if k < 20 or r.n_times - k < 10:
            raise DataError(
                f"record {r.name or '(unnamed)'}: {r.n_times} samples are too few to hold out "
                f"{holdout:g} of them (need >= 20 to fit and >= 10 held out); give longer records or "
                "held-out files (--validate)"
            )
        train.append(r.slice(0, k))
        tail.append(k)
    return train, tail


def resolve_model(spec):
    """A model from a name, ``"name:n"`` (an exponent or power) or a :class:`~duffsym.model.SymbolicModel`."""
    from duffsym.model import get_model

    if not isinstance(spec, str):
        return spec
    name, _, n = spec.partition(":")
    if not n:
        return get_model(name.strip())
    try:
        value = float(n)
    except ValueError:
        raise ModelError(f"model {spec!r}: the part after ':' must be the exponent n (e.g. bouc-wen:2)") from None
    return get_model(name.strip(), int(value) if value.is_integer() else value)


def compare(
    records: Sequence,
    models: Sequence,
    *,
    validate: Sequence | None = None,
    holdout: float = HOLDOUT,
    n_starts: int = 4,
    start_spread: float = 3.0,
    rng: int = 0,
    fixed: Mapping[str, float] | None = None,
    max_iter: int = 500,
    starts: Mapping[str, Mapping[str, float]] | None = None,
    progress: Callable[[str], None] | None = None,
) -> Comparison:
    """Fit each of ``models`` on the training records and score it on held-out data (module docstring).

    Parameters
    ----------
    records : the records (:class:`~duffsym.data.Record`).
    models : model names (``"spencer"``, ``"mr-damper-current:5"``) or model objects.
    validate : held-out records; then ``records`` are used whole for training.
    holdout : without ``validate``, the fraction of each record held out (its end).
    n_starts, start_spread, rng : the multistart of :func:`duffsym.identify.fit`.
    fixed : parameter values to hold in every model that has the parameter (e.g. ``{"eta": 100}``: the field rate
        is not identifiable from records at constant currents).
    max_iter : IPOPT's iteration limit per start.
    starts : per model name, start values of (some of) its parameters (e.g. a published fit); the others, and
        models not named, start from :func:`duffsym.identify.initial_guess`.
    progress : a callable taking one line of text, or None.
    """
    say = progress or (lambda msg: None)
    if not records:
        raise DataError("compare needs at least one record")
    resolved = [resolve_model(m) for m in models]
    if not resolved:
        raise ModelError("compare needs at least one model (--models a,b,c; duffsym models lists them)")
    if validate:
        train, tails, held = list(records), None, list(validate)
        split = f"{len(held)} validation record(s): " + ", ".join(r.name or "(unnamed)" for r in held)
    else:
        train, tails = split_records(records, holdout)
        held = list(records)
        split = f"the last {holdout:g} of each record (chosen before fitting)"
    scores, preds = [], {}
    for model in resolved:
        say(f"fitting {model.name} on {len(train)} record(s) from {n_starts} start(s)")
        score, pred = _score_model(
            model,
            train,
            held,
            tails,
            n_starts=n_starts,
            start_spread=start_spread,
            rng=rng,
            fixed={k: v for k, v in (fixed or {}).items() if k in model.param_names},
            max_iter=max_iter,
            x0=dict((starts or {}).get(model.name, {})) or None,
        )
        say(f"  {model.name}: held-out NRMSE {score.heldout_nrmse:.4f}, fit {score.fit_seconds:.1f} s")
        scores.append(score)
        preds[model.name] = pred
    return Comparison(
        tuple(scores),
        split,
        tuple(r.name or f"record {i}" for i, r in enumerate(train)),
        tuple(r.name or f"record {i}" for i, r in enumerate(held)),
        preds,
    )


def _score_model(model, train, held, tails, *, n_starts, start_spread, rng, fixed, max_iter, x0=None):
    """One model: fit, held-out error, BIC, starts, simulation cost, certificate."""
    from duffsym.identify import Problem, fit

    t0 = time.perf_counter()
    try:
        res = fit(
            Problem(model, train, fixed=fixed or None),
            x0,
            n_starts=n_starts,
            start_spread=start_spread,
            rng=rng,
            max_iter=max_iter,
        )
    except (ModelError, DataError) as exc:
        return _failed(model, str(exc)), {}
    fit_s = time.perf_counter() - t0
    per_rec, preds = _heldout(model, res, train, held, tails)
    pooled = _pooled(held, tails, preds)
    costs = [c for c in res.settings.get("start_costs", []) if math.isfinite(c)]
    at_best = sum(c <= min(costs) * (1 + SAME_OPTIMUM) for c in costs) if costs else 0
    sim_s, sub_mean, sub_max, how = simulation_cost(model, res, train)
    n = res.n_samples
    bic = n * math.log(max(res.cost, 1e-300) / n) + len(res.free) * math.log(n)
    score = ModelScore(
        model.name,
        bool(res.success),
        len(res.free),
        pooled,
        per_rec,
        float(res.nrmse),
        bic,
        fit_s,
        n_starts,
        int(at_best),
        sim_s,
        sub_mean,
        sub_max,
        how,
        certificate(model, res),
        dict(res.params),
        res.message,
    )
    return score, preds


def _failed(model, message: str):
    return ModelScore(
        model.name,
        False,
        0,
        math.inf,
        {},
        math.inf,
        math.inf,
        0.0,
        0,
        0,
        math.nan,
        math.nan,
        0,
        "",
        "none derived",
        {},
        message,
    )


def _heldout(model, res, train, held, tails) -> tuple[dict, dict]:
    """Held-out NRMSE per record and the predictions (the scored part of each held-out record)."""
    from duffsym.identify import validate
    from duffsym.identify.result import nrmse

    per, preds = {}, {}
    for i, rec in enumerate(held):
        name = rec.name or f"record {i}"
        if tails is None:
            v = validate(res, rec, model)
            y_hat = np.asarray(v.y_sim, dtype=float) if v.success else np.full(rec.n_times, np.nan)
            y = np.asarray(rec.y)
        else:
            y_hat = _continued_run(model, res, rec, i)[tails[i] :]
            y = np.asarray(rec.y)[tails[i] :]
        per[name] = nrmse(y, y_hat) if y_hat.size == y.size else math.inf
        preds[name] = y_hat
    return per, preds


def _continued_run(model, res, rec, i: int) -> np.ndarray:
    """The fitted model's free run over the whole record from the initial state fitted on its training part."""
    from duffsym.simulate import simulate_record

    x0 = cast("Sequence[float]", np.asarray(res.x0[i], dtype=float))  # simulate_record takes an array too
    tr = simulate_record(model, res.params, rec, x0=x0, on_failure="return")
    return np.asarray(tr.y, dtype=float) if tr.success else np.full(rec.n_times, np.nan)


def _pooled(held, tails, preds) -> float:
    """Pooled held-out NRMSE over every held-out sample."""
    ys, yh = [], []
    for i, rec in enumerate(held):
        name = rec.name or f"record {i}"
        y = np.asarray(rec.y)[(tails[i] if tails is not None else 0) :]
        if preds[name].size != y.size:
            return math.inf
        ys.append(y)
        yh.append(preds[name])
    y, y_hat = np.concatenate(ys), np.concatenate(yh)
    if not np.all(np.isfinite(y_hat)):
        return math.inf
    return float(np.sqrt(np.mean((y - y_hat) ** 2)) / np.std(y))


def simulation_cost(model, res, records) -> tuple[float, float, int, str]:
    """(seconds per sample, mean substeps per sample, largest, integrator) of the fitted model's compiled runs
    over ``records`` (the second run is timed: the first compiles)."""
    from duffsym.simulate import simulate_record

    p = model.param_vector(res.params)
    total, n, subs, how = 0.0, 0, [], set()
    for i, rec in enumerate(records):
        # simulate_record takes an array too
        x0 = cast("Sequence[float]", np.asarray(res.x0[i], dtype=float)) if i < len(res.x0) else None
        simulate_record(model, p, rec, x0=x0, on_failure="return")
        t0 = time.perf_counter()
        tr = simulate_record(model, p, rec, x0=x0, on_failure="return")
        total += time.perf_counter() - t0
        n += rec.n_times
        subs.append(np.asarray(tr.substeps))
        how.add(tr.method + (" (fallback)" if tr.fallback else ""))
    s = np.concatenate(subs) if subs else np.zeros(0)
    return (
        total / max(n, 1),
        float(np.mean(s)) if s.size else math.nan,
        int(s.max()) if s.size else 0,
        ", ".join(sorted(how)),
    )


def certificate(model, res) -> str:
    """ "holds", "fails: ..." (derived Lyapunov conditions), a literature bound, or "none derived"."""
    derived = _derived_conditions(model)
    if derived:
        bad = [f for f in res.flags if f.get("flag") == "outside-stability-certificate"]
        return (
            "Lyapunov: fails (" + ", ".join(map(str, bad[0].get("failed", [])))[:60] + ")" if bad else "Lyapunov: holds"
        )
    names = set(model.param_names)
    if {"A", "gamma", "beta"} <= names:
        p = res.params
        ok = p["A"] > 0 and p["gamma"] > 0 and abs(p["beta"]) <= p["gamma"]
        return f"Bouc-Wen z bound (literature): {'holds' if ok else 'fails'}"
    return "none derived"


def _derived_conditions(model) -> bool:
    """True when duffsym derives stability conditions with parameters in them for this model."""
    from duffsym.derive.stability import stability_conditions
    from duffsym.model.library import at_constant_command

    try:
        target = at_constant_command(model) or model
        named = stability_conditions(target).named()
    except Exception:  # noqa: BLE001 - a model the derivation does not cover has no certificate
        return False
    syms = set(target.param_symbols)
    return any(getattr(c, "free_symbols", set()) and c.free_symbols <= syms for c in named.values())


def plot_comparison(comparison: Comparison, path) -> None:
    """Three panels: held-out NRMSE per record and pooled (bars per model), fit time and the fraction of starts
    at the best optimum, simulation cost per sample (log scale) with the substeps met."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from duffsym.plot.loops import save_figure

    scores = [s for s in comparison.scores if s.heldout_records]
    names = [s.model for s in scores]
    recs = list(scores[0].heldout_records) + ["pooled"] if scores else []
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), gridspec_kw={"width_ratios": [2.2, 1, 1]})
    w = 0.8 / max(len(names), 1)
    x = np.arange(len(recs))
    for j, s in enumerate(scores):
        vals = [s.heldout_records[r] for r in recs[:-1]] + [s.heldout_nrmse]
        axes[0].bar(x + (j - (len(names) - 1) / 2) * w, np.minimum(vals, 2.0), w, label=s.model)
    axes[0].set_xticks(x, recs, rotation=30, ha="right", fontsize="small")
    axes[0].set_ylabel("held-out NRMSE (clipped at 2)")
    axes[0].set_title(f"held-out error ({comparison.split[:60]})", fontsize="small")
    axes[0].legend(fontsize="x-small")
    y = np.arange(len(names))
    axes[1].barh(y, [s.fit_seconds for s in scores], color="0.6")
    for j, s in enumerate(scores):
        axes[1].text(s.fit_seconds, j, f" {s.starts_at_best}/{s.starts} starts", va="center", fontsize="x-small")
    axes[1].set_xlim(0, 1.7 * max([s.fit_seconds for s in scores] + [1e-3]))
    axes[1].set_yticks(y, names, fontsize="small")
    axes[1].set_xlabel("fit time, s (text: starts at the best optimum)")
    axes[2].barh(y, [s.sim_seconds_per_sample * 1e6 for s in scores], color="0.4")
    for j, s in enumerate(scores):
        axes[2].text(
            s.sim_seconds_per_sample * 1e6,
            j,
            f" {s.substeps_mean:.1f}/{s.substeps_max} substeps",
            va="center",
            fontsize="x-small",
        )
    axes[2].set_xscale("log")
    costs = [s.sim_seconds_per_sample * 1e6 for s in scores if s.sim_seconds_per_sample > 0]
    if costs:
        axes[2].set_xlim(min(costs) / 2, max(costs) * 30)
    axes[2].set_yticks(y, [""] * len(names))
    axes[2].set_xlabel("simulation cost, us per sample (log)")
    fig.suptitle("duffsym compare: the same fit and simulation for every model")
    fig.tight_layout()
    save_figure(fig, path)
