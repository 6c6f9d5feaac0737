r"""A fit that does not depend on the units of the record: fit it normalised, map the answer back.

The collocation NLP is scaled by the parameters' nominal magnitudes (``ParamSpec.scale``) and its
bounds, start grid and IPOPT tolerances are those of a record of O(1) amplitudes: the same record in
other units (a force in MN, a displacement in µm) met bounds the true parameters lie outside and
tolerances that stop on an absolute scale (measured: an MR-damper record with its input x 1e-12 fitted
at NRMSE 0.79 instead of 0.009, reported as a success).

When a record's input peak lies outside :data:`UNIT_BAND` (its output peak: outside 10^-4.5 ... 10^4.5,
:func:`record_factors`), :func:`unit_plan` divides them by powers of 1000 (:func:`unit_factor`, the SI
prefixes), so the normalised record of the same experiment is the same whatever prefix it was written
with. The model's unit-scaling map (:func:`duffsym.derive.units.find_unit_scaling`, derived from its
equations) carries the fixed values, bounds and start into the normalised units, and
:meth:`UnitPlan.result` carries the answer back: parameters, standard errors and covariance (through the
map's Jacobian), initial states, free-run outputs and costs. Where the map moves a parameter the problem
fixes as a gauge (``A_f``, set by the states' scaling symmetry), the answer is moved back along that
symmetry (:mod:`duffsym.derive.symmetry`): the output is unchanged.

A model without a derived map (the classical models, whose smoothing widths fix the velocity unit;
composed structures and grouped problems, not handled here) is fitted in the record's units as
before, and ``settings["unit_scaling"]`` (with a flag far from O(1)) says so.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from duffsym.identify.problem import Problem, effect_record_bounds
from duffsym.identify.result import IdentificationResult
from duffsym.identify.unitmap import (
    OUTPUT_BAND,
    UNIT_BAND,
    gauge_factor,
    model_record_factors,
    normalised_records,
    state_symmetry,
    unit_factor,
)

if TYPE_CHECKING:  # the derivation (SymPy) is imported only when a record needs it
    from duffsym.derive.units import UnitScaling

#: Outside this band a fit that cannot be normalised carries a flag (within it, the settings note only).
FLAG_BAND = (1e-3, 1e3)

__all__ = ["FLAG_BAND", "OUTPUT_BAND", "UNIT_BAND", "UnitPlan", "record_factors", "unit_factor", "unit_plan"]


def record_factors(problem: Problem) -> tuple[float, float]:
    """``(a, b)``: the unit factors of the input (if the model reads the record's input) and of the output.

    The output is left as it is within :data:`OUTPUT_BAND` (``b = 1``): measured on an MR-damper record, an
    output x 1e-12 ... 1e6 alone fitted to the same NRMSE (to 5 digits) before this module existed (``A_f =
    max|y|`` absorbs it), while an input x 1e-3 alone already fitted worse (NRMSE 0.0174 against 0.0091).
    Refitting such records normalised would only move fits along ridges of equal cost (the Dyke record's
    k1, k2; output ~1.7e3 N)."""
    return model_record_factors(problem.model, problem.records)


@dataclass(frozen=True)
class UnitPlan:
    """How :func:`~duffsym.identify.fit` treats the record's units: ``applied`` (fit ``problem``, the
    normalised one, from ``x0``, then :meth:`result`) or not (``note`` says why, when it matters)."""

    a: float
    b: float
    applied: bool
    note: str
    problem: Problem | None = None
    x0: dict | None = None
    scaling: UnitScaling | None = None
    gauge: dict = field(default_factory=dict)

    def info(self) -> dict:
        """``settings["unit_scaling"]``: the factors, whether the fit ran normalised, and the map."""
        out: dict = {"input_factor": self.a, "output_factor": self.b, "normalised": self.applied, "note": self.note}
        if self.applied and self.scaling is not None:
            out["map"] = {k: str(e) for k, e in self.scaling.mapping.items()}
            out["states_scale"] = {str(x): str(f) for x, f in zip(self.scaling.model.states, self.scaling.state_scales)}
            if self.gauge:
                out["gauge"] = dict(self.gauge)
        return out

    def annotate(self, result: IdentificationResult) -> IdentificationResult:
        """A fit run in the record's units with the plan's note (and a flag when the units are far from O(1))."""
        if self.a == 1.0 and self.b == 1.0:
            return result
        flags = tuple(result.flags)
        far = any(not FLAG_BAND[0] <= v <= FLAG_BAND[1] for v in (self.a, self.b))
        if far and result.flags is not None:
            flags += ({"flag": "units", "message": self.note},)
        return dataclasses.replace(result, settings={**result.settings, "unit_scaling": self.info()}, flags=flags)

    def result(self, fitted: IdentificationResult, original: Problem) -> IdentificationResult:
        """The normalised fit ``fitted`` in the units of ``original`` (see the module docstring)."""
        assert self.scaling is not None
        model, a, b = original.model, self.a, self.b
        params, s = self.to_record_units(fitted.params)
        params.update({k: float(v) for k, v in original.fixed.items()})
        free = list(fitted.free)
        jac = self._jacobian(fitted.params, free, s)
        cov = _congruence(jac, np.asarray(fitted.covariance, dtype=float))
        stderr = {n: float(math.sqrt(cov[j, j])) if cov[j, j] >= 0 else math.nan for j, n in enumerate(free)}
        x_scale = self._state_factors(s)
        settings = dict(fitted.settings)
        settings.update(_scaled_settings(settings, b))
        if isinstance(settings.get("start"), Mapping) and self.problem is not None:
            start = {**self.problem.fixed, **settings["start"]}
            settings["start"] = {k: v for k, v in self.to_record_units(start, s)[0].items() if k in settings["start"]}
        settings["unit_scaling"] = self.info()
        flags = tuple(
            {**f, "message": f["message"] + f" (bounds in the fit's normalised units: input / {a:g}, output / {b:g})"}
            if f.get("flag") == "on-bound"
            else f
            for f in fitted.flags
        )
        return dataclasses.replace(
            fitted,
            params={n: params[n] for n in model.param_names},
            fixed=dict(original.fixed),
            stderr=stderr,
            covariance=cov,
            cost=fitted.cost * b**2,
            x0=tuple(np.asarray(x, dtype=float) * x_scale for x in fitted.x0),
            y_sim=tuple(np.asarray(y, dtype=float) * b for y in fitted.y_sim),
            defaults_applied=dict(original.defaults_applied),
            settings=settings,
            flags=flags,
        )

    def to_record_units(self, params_n: Mapping[str, float], s: float | None = None) -> tuple[dict, float]:
        """Normalised parameters -> the record's units (the unit map, then the gauge symmetry); with the
        gauge's scale factor ``s`` (solved from the gauge parameter unless given)."""
        assert self.scaling is not None
        p = self.scaling.apply(params_n, self.a, self.b)
        if not self.gauge:
            return p, 1.0
        sym = state_symmetry(self.scaling.model)
        if s is None:
            s = gauge_factor(sym, self.gauge["parameter"], p, self.gauge["value"])
        return sym.apply(p, s), s

    def _jacobian(self, params_n: Mapping[str, float], free: list, s: float) -> np.ndarray:
        """d(free parameters in the record's units) / d(free normalised parameters): the unit map composed
        with the gauge symmetry at ``s``, differentiated symbolically and evaluated at ``params_n``."""
        import sympy as sp

        from duffsym.derive.symmetry import S
        from duffsym.derive.units import A, B

        assert self.scaling is not None
        model = self.scaling.model
        syms = {p.name: p.symbol for p in model.params}
        exprs = dict(self.scaling.mapping)
        if self.gauge:
            gauge_map = state_symmetry(model).mapping
            exprs = {k: gauge_map[k].xreplace({syms[n]: e for n, e in exprs.items()}) for k in model.param_names}
        vals = {syms[n]: sp.Float(float(params_n[n]), 17) for n in model.param_names}
        vals.update({A: sp.Float(self.a, 17), B: sp.Float(self.b, 17), S: sp.Float(s, 17)})
        return np.array([[float(sp.diff(exprs[i], syms[j]).xreplace(vals)) for j in free] for i in free])

    def _state_factors(self, s: float) -> np.ndarray:
        assert self.scaling is not None
        model = self.scaling.model
        f = np.array(self.scaling.state_factors(self.a, self.b))
        if self.gauge:
            sym = state_symmetry(model)
            f = f * np.array([s if x in sym.scaled_states else 1.0 for x in model.states])
        return f


def _congruence(jac: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """``J C J^T`` summed over the non-zero entries of ``J`` only (an infinite variance stays where it acts)."""
    n = jac.shape[0]
    out = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            ks, ls = np.flatnonzero(jac[i]), np.flatnonzero(jac[j])
            out[i, j] = sum(jac[i, k] * cov[k, m] * jac[j, m] for k in ks for m in ls) if len(ks) and len(ls) else 0.0
    return out


def _scaled_settings(settings: dict, b: float) -> dict:
    """The settings whose numbers carry the output's or the parameters' units, in the record's units."""
    out: dict = {}
    if "y_norm" in settings:
        out["y_norm"] = settings["y_norm"] * b
    if "start_costs" in settings:
        out["start_costs"] = [c * b**2 for c in settings["start_costs"]]
    note = settings.get("bound_restart")
    if isinstance(note, dict):
        out["bound_restart"] = {
            **note,
            **{k: note[k] * b**2 for k in ("cost_before", "cost_after") if isinstance(note.get(k), (int, float))},
        }
    return out


def _why_not(problem: Problem, scaling: UnitScaling, a: float, b: float) -> str:
    """Why the plan cannot normalise ``problem`` ("" when it can)."""
    model = problem.model
    if getattr(model, "composition", ()):
        return "a composed structure is rescaled by its own elements' magnitudes, not by the record's units"
    if problem.group_order or problem.per_group:
        return "a grouped fit (per-group parameters) is not normalised"
    if not scaling.applies(a, b):
        return f"model {model.name} has no derived unit-scaling map ({scaling.text})"
    if not scaling.diagonal:
        return f"model {model.name}'s unit-scaling map mixes parameters, so its bounds cannot be carried over"
    return ""


def _gauge(problem: Problem, scaling: UnitScaling, a: float, b: float) -> dict:
    """The gauge parameter (``A_f``, fixed, moved by the unit map and by the states' symmetry) and its value."""
    if "A_f" not in problem.fixed:
        return {}
    sym = state_symmetry(problem.model)
    if not sym.exists or "A_f" not in sym.mapping or sym.tangent.get("A_f", 0) == 0:
        return {}
    return {"parameter": "A_f", "value": float(problem.fixed["A_f"])}


def unit_plan(problem: Problem, x0=None) -> UnitPlan:
    """How to fit ``problem`` whatever its units (see the module docstring)."""
    a, b = record_factors(problem)
    if a == 1.0 and b == 1.0:
        return UnitPlan(a, b, False, "")
    where = f"max|d| ~ {a:g}, max|y| ~ {b:g}"
    from duffsym.derive.units import find_unit_scaling

    scaling = find_unit_scaling(problem.model)
    why = _why_not(problem, scaling, a, b)
    gauge = {} if why else _gauge(problem, scaling, a, b)
    x0_n, normalised = None, None
    if not why:
        try:
            factors = _composite_factors(problem, scaling, a, b, gauge)
            normalised = _normalised_problem(problem, factors, a, b, gauge)
            x0_n = _normalised_start(problem, scaling, a, b, gauge, x0)
        except ValueError as e:
            why = str(e)
    if why:
        note = (
            f"the record is far from unit scale ({where}) and was fitted in its own units: {why}; its bounds, start "
            "and tolerances are those of O(1) units, so rescale the record (change its units) if the fit is poor"
        )
        return UnitPlan(a, b, False, note, scaling=scaling)
    plan = UnitPlan(
        a,
        b,
        True,
        f"fitted normalised ({where}: input / {a:g}, output / {b:g}) and mapped back through "
        f"model {problem.model.name}'s unit-scaling map" + (" and its A_f gauge symmetry" if gauge else ""),
        scaling=scaling,
        gauge=gauge,
        x0=x0_n,
    )
    return dataclasses.replace(plan, problem=normalised)


def _normalised_records(problem: Problem, a: float, b: float):
    return normalised_records(problem.records, a, b)


def _composite_factors(problem: Problem, scaling: UnitScaling, a: float, b: float, gauge: dict) -> dict:
    """Each parameter's factor from the normalised units to the record's (the unit map, then the A_f gauge), or
    None where the gauge mixes it with others (``c2 -> c1 + c2 - s c1``)."""
    factors: dict[str, float | None] = {k: scaling.factor(k, a, b) for k in problem.model.param_names}
    if not gauge:
        return factors
    import sympy as sp

    from duffsym.derive.symmetry import S

    sym = state_symmetry(problem.model)
    value = gauge["value"]
    s = gauge_factor(sym, "A_f", {"A_f": value / b * scaling.factor("A_f", a, b)}, value)
    for k, f in factors.items():
        ratio = sp.simplify(sym.mapping[k] / problem.model.param(k).symbol)
        factors[k] = None if ratio.free_symbols - {S} or f is None else f * float(ratio.xreplace({S: sp.Float(s, 17)}))
    return factors


def _divided(name: str, value: float, factors: dict, what: str) -> float:
    f = factors[name]
    if f is None:
        raise ValueError(f"{what} of {name} cannot be carried along the A_f gauge (it mixes {name} with others)")
    return value / f


def _normalised_problem(problem: Problem, factors: dict, a: float, b: float, gauge: dict) -> Problem:
    """``problem`` in the normalised units: its records divided, fixed values and given bounds mapped.

    Raises
    ------
    ValueError
        For a fixed value, bound or constraint on a parameter the A_f gauge mixes with others."""
    model = problem.model
    fixed = {
        k: _divided(k, v, factors, "the fixed value") for k, v in problem.fixed.items() if k != gauge.get("parameter")
    }
    if gauge:  # keep the gauge's ratio to the output peak: O(1) states in the normalised fit
        fixed[gauge["parameter"]] = gauge["value"] / b
    record_scaled = effect_record_bounds(model, problem.records)
    bounds = {}
    for k, (lo, hi) in problem.bounds.items():
        spec = model.param(k)
        if (lo, hi) == (spec.lower, spec.upper) or record_scaled.get(k) == (lo, hi):
            continue  # the model's (O(1) units) or the record's own: the normalised problem sets them
        lo_n, hi_n = _divided(k, lo, factors, "a bound"), _divided(k, hi, factors, "a bound")
        bounds[k] = (min(lo_n, hi_n), max(lo_n, hi_n))
    constraints = []
    for coeffs, lo, hi in problem.constraints:
        constraints.append(({k: c / _divided(k, 1.0, factors, "a constraint") for k, c in coeffs.items()}, lo, hi))
    return Problem(
        model,
        _normalised_records(problem, a, b),
        free=problem.free,
        fixed=fixed,
        bounds=bounds,
        weights=problem.weights or None,
        mask=problem.mask or None,
        mask_info=problem.mask_info,
        constraints=constraints or None,
    )


def _normalised_start(problem: Problem, scaling: UnitScaling, a: float, b: float, gauge: dict, x0):
    """The caller's start ``x0`` (by name or ordered as the free parameters) in the normalised units; names
    the model does not have (and a sequence of the wrong length) are passed on for the fit to refuse.

    Raises
    ------
    ValueError
        When a given value cannot be carried along the A_f gauge without a value that is missing (the fit then
        runs in the record's units)."""
    if x0 is None:
        return None
    names = problem.slot_names
    if not isinstance(x0, Mapping):
        vals = np.asarray(x0, dtype=float).reshape(-1)
        if vals.size != len(names):
            return x0
        x0 = dict(zip(names, map(float, vals)))
    known = set(problem.model.param_names)
    given = {k: float(v) for k, v in x0.items() if k in known}
    if gauge:
        given = _along_gauge(problem, given, gauge["value"] / b * scaling.factor("A_f", a, b))
    return {**dict(x0), **{k: v / scaling.factor(k, a, b) for k, v in given.items()}}


def _along_gauge(problem: Problem, given: dict, target: float) -> dict:
    """The given (partial) parameters moved along the states' symmetry until A_f equals ``target``.

    Raises
    ------
    ValueError
        When a given value's image needs a value that is neither given nor fixed."""
    import sympy as sp

    from duffsym.derive.symmetry import S

    sym = state_symmetry(problem.model)
    known = {**problem.fixed, **given}
    s = gauge_factor(sym, "A_f", known, target)
    values = {problem.model.param(k).symbol: sp.Float(v, 17) for k, v in known.items()}
    values[S] = sp.Float(s, 17)
    out = {}
    for k in given:
        image = sym.mapping[k].xreplace(values)
        if image.free_symbols:
            raise ValueError(f"the start of {k} cannot be carried along the A_f gauge without {image.free_symbols}")
        out[k] = float(image)
    return out
