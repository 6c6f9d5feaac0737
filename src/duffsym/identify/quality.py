"""Whether a converged fit is a usable model, and what about it is doubtful (``docs/contract.md``, wave 2).

- :func:`usability`: a fit whose free run is worse than predicting the mean (R² < 0), or whose output
  gain A_f is not positive, is not a model of the record: ``success`` becomes false with a status
  and a message saying why (measured on the hardening corpus: a record whose force column is the
  displacement fitted with free-run NRMSE 12.2 and ``--af 0`` with NRMSE 1.0, both "converged").
- :func:`fit_flags`: doubtful but usable results, listed in ``IdentificationResult.flags`` (FIT.json
  ``"flags"``) and noted once on stderr by ``duffsym fit``: free parameters on a bound, a parameter
  set outside the model's derived stability certificate (:func:`duffsym.derive.stability_certificate`,
  e.g. k1 + k2 < 0: a saddle at the origin), an added effect that does nothing on the records
  (:meth:`~duffsym.effects.base.Effect.activity`), and a model that explains little (R² < 0.5).

Each flag is a dict ``{"flag": name, "message": one line, ...details}``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from duffsym.errors import DuffsymError

#: R² below which a usable fit is flagged as explaining little of the record.
R2_LITTLE = 0.5

#: Relative distance to a bound (in scaled parameters) that counts as "on the bound".
ON_BOUND_RTOL = 1e-6


def usability(problem, rec_params: Sequence[dict], r2: float, status: str, message: str) -> tuple[str, bool, str]:
    """``(status, success, message)`` of a converged fit with a finite free run: failed when R² < 0 or
    A_f <= 0 (``rec_params``: each record's parameters; ``r2`` the pooled free-run R²)."""
    model = problem.model
    if "A_f" in model.param_names:
        bad = sorted({float(p["A_f"]) for p in rec_params if not p["A_f"] > 0})
        if bad:
            return (
                "A_f not positive",
                False,
                f"IPOPT converged ({status}) but the output gain A_f = {bad[0]:g} is not positive: the model "
                "output is zero or sign-flipped; use --af max (the force peak) or a positive value",
            )
    if not r2 >= 0:
        nrmse = math.sqrt(1 - r2) if math.isfinite(r2) else math.inf
        return (
            "worse than the mean",
            False,
            f"IPOPT converged ({status}) but the free run is worse than predicting the mean (R2 {r2:.3g}, "
            f"NRMSE {nrmse:.3g}): this model does not describe the record; check the columns (--columns), "
            "units and the model",
        )
    return status, True, message


def fit_flags(
    problem, nlp, w: np.ndarray, rec_params: Sequence[dict], r2: float, stderr: dict | None = None
) -> list[dict]:
    """The doubtful features of a fit (see the module docstring), in a fixed order."""
    flags = []
    on_bound = _on_bound(problem, nlp, w)
    if on_bound:
        flags.append(on_bound)
    inactive = _inactive_effects(problem, rec_params, stderr or {})
    if inactive:
        flags.append(inactive)
    flags += _outside_certificate(problem.model, rec_params, _command_levels(problem))
    if math.isfinite(r2) and 0 <= r2 < R2_LITTLE:
        flags.append(
            {
                "flag": "explains-little",
                "r2": float(r2),
                "message": f"the model explains little of the record (R2 {r2:.3g} < {R2_LITTLE}): the fit "
                "may be a poor description; check the model, the effects (duffsym diagnose) and "
                "the noise",
            }
        )
    return flags


def _inactive_effects(problem, rec_params: Sequence[dict], stderr: dict) -> dict | None:
    """The flag of the added effects that do nothing on every record at the fitted parameters
    (:func:`inactive_effects`); None when every effect acts on some record."""
    said = [inactive_effects(problem.model, rec, p, stderr) for rec, p in zip(problem.records, rec_params, strict=True)]
    whys = {name: why for name, why in said[0].items() if all(name in s for s in said)} if said else {}
    if not whys:
        return None
    text = "; ".join(f"{name}: {why}" for name, why in whys.items())
    return {
        "flag": "inactive-effect",
        "effects": list(whys),
        "message": f"added effect(s) that do nothing on the data: {text}; the fit switched them off, so they "
        "explain nothing here: drop them, or see whether another parameter took their part (on a bound?)",
    }


def inactive_effects(
    model, record, params: Mapping[str, float], stderr: Mapping[str, float] | None = None, effects=None
) -> dict:
    """effect -> why it does nothing on ``record`` at ``params`` (:meth:`Effect.activity`; ``stderr`` the
    standard errors), for the effects of ``model`` (or those in ``effects``) that are flagged: the objects the model
    holds, else the catalogue's and the extensions' of those names; {} when every effect acts."""
    from duffsym.effects import ADDABLE

    known = {**ADDABLE, **{e.name: e for e in (model.effect_objects or ())}}
    out = {}
    for name in model.effects if effects is None else effects:
        if name in known:
            try:
                why = known[name].activity(record, {**model.defaults(), **dict(params)}, dict(stderr or {}))
            except (KeyError, ValueError, ArithmeticError):
                why = ""
            if why:
                out[name] = why
    return out


def _on_bound(problem, nlp, w: np.ndarray) -> dict | None:
    th = np.clip(np.asarray(w[: nlp.n_slots], dtype=float), nlp.lo, nlp.hi)
    tol = ON_BOUND_RTOL * np.maximum(1.0, np.abs(th))
    hits = []
    for j, name in enumerate(nlp.slot_names):
        for side, b in (("lower", nlp.lo[j]), ("upper", nlp.hi[j])):
            if np.isfinite(b) and abs(th[j] - b) <= tol[j]:
                hits.append((name, side, float(b * nlp.p_scale[j])))
    if not hits:
        return None
    text = ", ".join(f"{n} on its {side} bound {b:g}" for n, side, b in hits)
    return {
        "flag": "on-bound",
        "parameters": [n for n, _, _ in hits],
        "message": f"{text}: the optimum may lie beyond it (a bound that is active is a modelling choice, "
        "not a result); check the bounds, the model and --starts" + _sampling_note(problem, hits),
    }


def _sampling_note(problem, hits) -> str:
    """Why a rate on the bound set by the sampling (:func:`~duffsym.identify.problem.sampling_bounds`) is not
    resolved by the record, and what to do; "" for other bounds."""
    from duffsym.identify.problem import RATE_STEP_LIMIT, sampling_bounds

    limits = sampling_bounds(problem.model, problem.records)
    names = [n for n, side, b in hits if n in limits and math.isclose(b, limits[n][side == "upper"], rel_tol=1e-6)]
    if not names:
        return ""
    return (
        f"; {names[0]}'s bound is set by the sampling (a time constant of 1/{RATE_STEP_LIMIT:g} step): the record "
        "does not resolve a faster state, so treat it as instantaneous, or fit a record sampled faster "
        "(--decimate off)"
    )


#: model key -> ((condition name, numeric test), ...) of its parameter-dependent stability conditions.
_CONDITIONS: dict[str, tuple] = {}


def _conditions(model) -> tuple:
    """The model's derived stability conditions as fast numeric tests (cached per model); () if none apply.

    For a command-driven model the conditions are those of its mechanics at a held command i (the field
    at its equilibrium u = i, :func:`~duffsym.model.library.at_constant_command`): each test then takes
    the parameters and i, and is checked at every command level the records drive the model through.

    The derivation (SymPy, ~0.3 s per model) is stored in the code cache
    (:mod:`duffsym.identify.conditions_cache`) and read back by later processes."""
    if model.key in _CONDITIONS:
        return _CONDITIONS[model.key]
    from duffsym.identify.conditions_cache import load_conditions, save_conditions, tests_from

    stored = load_conditions(model)
    if stored is None:
        stored = _derived_conditions(model)
        if stored is not None:
            save_conditions(model, stored)
    _CONDITIONS[model.key] = tests_from(stored or [])
    return _CONDITIONS[model.key]


def _derived_conditions(model) -> list[tuple[str, list[str], str]] | None:
    """``[(name, argument names, Python expression)]`` of the conditions that depend on parameters; None when
    the derivation failed (a model it does not cover gets no certificate flag)."""
    import sympy as sp
    from sympy.printing.pycode import pycode

    from duffsym.derive.stability import stability_conditions
    from duffsym.model.library import at_constant_command

    out = []
    try:
        frozen = at_constant_command(model)
        target = model if frozen is None else frozen
        if getattr(model, "composition", ()):  # a structure with an element: the coupled linearization's Hurwitz test
            from duffsym.derive.coupled import coupled_analysis

            named = {f"Hurwitz {i + 1}": h > 0 for i, h in enumerate(coupled_analysis(model).hurwitz)}
        else:
            named = stability_conditions(target).named()
        args = [str(p) for p in target.param_symbols]
        for name, cond in named.items():
            if cond in (sp.true, sp.false):  # structural (e.g. an extended model this V does not cover)
                continue
            if not cond.free_symbols <= set(target.param_symbols):
                continue
            out.append((name, args, pycode(cond, fully_qualified_modules=True)))
    except Exception:  # noqa: BLE001 - a model the derivation does not cover gets no certificate flag
        return None
    return out


#: Command levels checked across a record's command range (besides its extremes), for a command-driven model.
COMMAND_LEVELS = 11


def _command_levels(problem) -> tuple[float, ...]:
    """The command levels the records drive the model through (their range on a grid); () without a command."""
    if "command" not in problem.model.signals:
        return ()
    lo, hi = math.inf, -math.inf
    for rec in problem.records:
        try:
            c = np.asarray(rec.command_signal(problem.model.name), dtype=float)
        except DuffsymError:
            continue
        lo, hi = min(lo, float(np.min(c))), max(hi, float(np.max(c)))
    return tuple(np.linspace(lo, hi, COMMAND_LEVELS)) if lo <= hi else ()


def _failed(tests, key: tuple, levels: tuple) -> tuple[list[str], list[float]]:
    """Conditions that fail, and the command levels where any fails (``levels`` () for models without one)."""
    failed, where = [], []
    for lv in levels or (None,):
        args = key if lv is None else key + (lv,)
        bad = [name for name, test in tests if not bool(test(*args))]
        failed += [n for n in bad if n not in failed]
        if bad and lv is not None:
            where.append(lv)
    return failed, where


def _outside_certificate(model, rec_params: Sequence[dict], levels: tuple = ()) -> list[dict]:
    tests = _conditions(model)
    if not tests:
        return []
    seen, flags = set(), []
    for params in rec_params:
        key = tuple(float(params[n]) for n in model.param_names)
        if key in seen:
            continue
        seen.add(key)
        try:
            failed, where = _failed(tests, key, levels)
        except (TypeError, ValueError, ZeroDivisionError):
            continue
        if not failed:
            continue
        at = (
            (
                f" at command {where[0]:.3g}"
                + (f"..{where[-1]:.3g}" if len(where) > 1 else "")
                + f" of the records' range {levels[0]:.3g}..{levels[-1]:.3g}"
            )
            if where
            else ""
        )
        flag: dict[str, Any] = {
            "flag": "outside-stability-certificate",
            "failed": failed,
            "message": f"the fitted set is outside the model's derived stability certificate "
            f"({', '.join(failed)}: {'fails' if len(failed) == 1 else 'fail'}{at})"
            f"{'' if levels else _origin(model, params)}; it describes this record only, do not "
            "extrapolate it (duffsym derive --json states the conditions)",
        }
        if where:
            flag["command_levels"] = [float(v) for v in where]
        flags.append(flag)
    return flags


def _origin(model, params) -> str:
    """ ", the origin is a saddle/unstable" from the linearization at the origin, else ""."""
    import sympy as sp

    try:
        J = sp.Matrix(model.rhs).jacobian(sp.Matrix(model.states))
        at = dict.fromkeys(model.states, 0) | dict.fromkeys(model.input_symbols, 0)
        at |= {p.symbol: float(params[p.name]) for p in model.params}
        eig = np.linalg.eigvals(np.array(J.subs(at).evalf(), dtype=float))
    except Exception:  # noqa: BLE001 - the flag stands without the linearization
        return ""
    if not np.any(eig.real > 1e-12):
        return ""
    kind = "a saddle" if np.any(eig.real < -1e-12) else "unstable"
    return f"; the origin is {kind} (linearization eigenvalues {', '.join(f'{e.real:.4g}' for e in eig)})"
