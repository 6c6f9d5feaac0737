"""Physical effects as composable extensions of a symbolic model: the :class:`Effect` interface.

An effect adds terms, states, inputs or parameters to a :class:`~duffsym.model.SymbolicModel`
through :meth:`SymbolicModel.extend`; it never edits generated code. Derivations, code generation,
identification, simulation and sampling then work on the extended model unchanged.

Every effect provides, for the diagnosis (``duffsym diagnose``/``ladder``) and for people:

- ``name``, ``physics`` (one line), ``signature`` (one line: how it shows in the residuals of a
  model that lacks it), ``form`` (the equations it adds, one line);
- :meth:`Effect.parameters`: its parameters (:class:`ParamSpec` with unit, bounds, default),
  named with the effect's ``prefix`` so that effects combine;
- :meth:`Effect.apply`: the extended model (raises :class:`ModelError` when not applicable);
- :meth:`Effect.initial_guess`: starting values of its parameters from a record and the free run
  of the fitted model *without* the effect;
- :meth:`Effect.initial_states`: data-based starting trajectories of the states it adds (used by
  the collocation fit, :func:`duffsym.identify.collocation.initial_states`);
- :meth:`Effect.base_output`: the measured output with the effect's own output term removed
  (so the base model's states can be started from the data).

Helpers: :func:`apply_effects`; :func:`effect_chain` (base model and the models after each effect);
:func:`initial_states_with_effects` (used by the collocation fit's state guess). Fitting an
extended model (:func:`~duffsym.identify.extended_start`, :func:`~duffsym.identify.fit_with_effects`)
is in :mod:`duffsym.identify.extended`: effects never import the fitting code.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import cast

import numpy as np
import sympy as sp

from duffsym.errors import DataError, ModelError
from duffsym.model.core import SymbolicModel
from duffsym.model.symbols import ParamSpec


def _not_significant(name: str, params: Mapping[str, float], stderr: Mapping[str, float]) -> str:
    """``name``'s fitted value within two standard errors of zero, in words; "" otherwise (or unknown SE)."""
    v, se = float(params.get(name, math.nan)), float(stderr.get(name, math.nan))
    if math.isfinite(v) and math.isfinite(se) and abs(v) < 2 * se:
        return f"its size is not distinguishable from zero ({name} = {v:.3g} ± {se:.2g})"
    return ""


def sigmoid(u: sp.Expr) -> sp.Expr:
    """Smooth step from 0 to 1: :math:`(1 + \\tanh u)/2` (infinitely differentiable, for IPOPT)."""
    return (1 + sp.tanh(u)) / 2


class Effect:
    """Base class of the catalogue's effects (see the module docstring for the interface).

    Subclasses are frozen dataclasses; they implement :meth:`parameters` and :meth:`_extend`, and
    override :meth:`initial_guess`, :meth:`initial_states` and :meth:`base_output` where needed.
    ``n_states`` is the number of states the effect appends to the state vector.
    """

    name: str = "effect"
    prefix: str = ""
    physics: str = ""
    signature: str = ""
    form: str = ""
    guess: str = ""  # how initial_guess estimates the parameters, one line
    n_states: int = 0

    # ------------------------------------------------------------------ interface
    def parameters(self) -> tuple[ParamSpec, ...]:
        """The parameters the effect adds (prefixed names, units, bounds, default)."""
        return ()

    def apply(self, model: SymbolicModel) -> SymbolicModel:
        """``model`` with this effect added.

        Raises
        ------
        ModelError
            If the effect is already applied, or does not apply to this model (e.g. needs a
            mechanical model, or duplicates a term another applied effect already has).
        """
        self._check_not_applied(model)
        new = self._extend(model)
        # the new model holds its parent and this effect (SymbolicModel.lineage): a fresh object, set once
        object.__setattr__(new, "lineage", (new.key, model, self))
        return new

    def _extend(self, model: SymbolicModel) -> SymbolicModel:  # pragma: no cover - interface
        raise NotImplementedError

    def initial_guess(self, record, y_model) -> dict[str, float]:
        """Starting values of the effect's parameters from the data.

        Parameters
        ----------
        record : the measured :class:`~duffsym.data.Record`.
        y_model : (n_times,) free-run output of the fitted model *without* this effect.

        Returns
        -------
        dict
            Parameter name -> value, inside the parameter's bounds.
        """
        residual(record, y_model)  # checks the length
        return {p.name: p.default for p in self.parameters()}

    def initial_states(self, X_base: np.ndarray, record, params: Mapping[str, float]) -> np.ndarray:
        """Starting trajectories ``(n_times, n_states)`` of the states this effect adds.

        ``X_base`` holds the guesses of the states before this effect (base states first);
        ``params`` the parameter values by name (all of the extended model's).
        """
        return np.zeros((np.asarray(record.t).size, self.n_states))

    def base_output(self, y: np.ndarray, record, params: Mapping[str, float]) -> np.ndarray:
        """The output ``y`` with this effect's own output term removed (identity if it has none)."""
        return y

    def record_bounds(self, record) -> dict[str, tuple[float, float]]:
        """Bounds of the effect's parameters scaled to ``record`` (e.g. a smoothing velocity tied to the
        record's velocity range), tighter than the static ``ParamSpec`` bounds; {} when none."""
        return {}

    def record_scales(self, record) -> dict[str, float]:
        """Magnitudes of the effect's parameters on ``record``, where they follow the record's units (a friction
        force the force's spread, a switching velocity the record's speeds): the fit scales those parameters by
        the larger of this and ``ParamSpec.scale``; {} when none."""
        return {}

    def relevance(self, record) -> str:
        """Why a diagnosis need not try this effect on ``record`` by default, in words ("" when it should: the
        default). An effect whose evidence is a feature the record plainly lacks says so here (the contact gap on a
        record without zero-force plateaus); a user naming it among the candidates still has it tried."""
        return ""

    def activity(self, record, params: Mapping[str, float], stderr: Mapping[str, float] | None = None) -> str:
        """Why the fitted effect does nothing on ``record`` (its size negligible or not distinguishable from zero,
        or its smoothing run off so that its switch is flat or linear over the record), in words; "" when it acts
        (or cannot be told). Default: an effect of one parameter whose value is within two standard errors of 0."""
        specs = self.parameters()
        if len(specs) != 1 or not stderr:
            return ""
        return _not_significant(specs[0].name, params, stderr)

    def describe(self) -> dict:
        """Everything ``duffsym effects --json`` shows about the effect."""
        return {
            "effect": self.name,
            "physics": self.physics,
            "signature": self.signature,
            "form": self.form,
            "initial_guess": self.guess,
            "new_states": self.n_states,
            "parameters": [
                {
                    "name": p.name,
                    "unit": p.unit,
                    "default": p.default,
                    "lower": p.lower,
                    "upper": p.upper,
                    "description": p.description,
                }
                for p in self.parameters()
            ],
        }

    # ------------------------------------------------------------------ helpers
    def _check_not_applied(self, model: SymbolicModel) -> None:
        if self.name in model.effects:
            raise ModelError(f"effect {self.name} is already applied to model {model.name}")

    def _require_mechanical(self, model: SymbolicModel) -> tuple[sp.Symbol, sp.Symbol]:
        if model.position is None or model.velocity is None:
            raise ModelError(
                f"effect {self.name} needs a mechanical model (position and velocity states); "
                f"model {model.name} has none"
            )
        return model.position, model.velocity

    def _require_input(self, model: SymbolicModel, order: int = 0):
        """The model's input channel of ``order`` on its first signal, or a ModelError."""
        chans = [c for c in model.inputs if c.order == order]
        if not chans:
            raise ModelError(
                f"effect {self.name} acts on the input and its derivative of order {order}; "
                f"model {model.name} has inputs {[c.name for c in model.inputs]}"
            )
        return chans[0]

    def _spec(self, name: str) -> ParamSpec:
        for p in self.parameters():
            if p.name == name:
                return p
        raise KeyError(name)

    def _clip(self, name: str, value: float, fallback: float | None = None) -> float:
        """``value`` clipped to the (closed) bounds of parameter ``name``; ``fallback`` (else the default) if not
        finite."""
        p = self._spec(name)
        if not math.isfinite(value):
            value = p.default if fallback is None else fallback
        return float(min(max(value, p.lower), p.upper))


def apply_effects(model: SymbolicModel, effects: Iterable[Effect]) -> SymbolicModel:
    """``model`` with each effect applied in order."""
    for effect in effects:
        model = effect.apply(model)
    return model


def effect_chain(model: SymbolicModel) -> tuple[SymbolicModel, list[tuple[Effect, SymbolicModel]]] | None:
    """The base model and, in order, each effect applied to it with the model after it; None if unknown.

    A model built by :meth:`Effect.apply` holds its parent and the effect object
    (:meth:`SymbolicModel.effect_steps`); others are rebuilt from the model library (by name and power,
    as :func:`duffsym.identify.model_from_result` does for a fit saved without its model) and accepted
    only if the rebuilt equations are identical.
    """
    held = model.effect_steps()
    if held is not None:  # the chain is known, so is its base; the model layer types the effects as objects
        return cast(SymbolicModel, model.base_model), cast("list[tuple[Effect, SymbolicModel]]", list(held))
    from duffsym.effects import CATALOGUE
    from duffsym.model.library import get_model

    if any(e not in CATALOGUE for e in model.effects):
        return None
    struct = dict(model.structural)
    try:
        n = struct.get("n_x")
        base = get_model(model.name, None if n is None or model.name == "duffing" else int(n))
    except (ModelError, TypeError, ValueError):
        return None
    steps = []
    m = base
    try:
        for e in model.effects:
            m = CATALOGUE[e].apply(m)
            steps.append((CATALOGUE[e], m))
    except ModelError:
        return None
    return (base, steps) if m.key == model.key else None


def initial_states_with_effects(model: SymbolicModel, record, params: np.ndarray, base_states) -> np.ndarray | None:
    """Data-based state guess of an extended model: the base model's guess (from the measured output
    with the effects' output terms removed), then each effect's columns. None if the chain is unknown.

    ``base_states(model, record, params)`` is the base models' guess
    (:func:`duffsym.identify.collocation.initial_states`).
    """
    chain = effect_chain(model)
    if chain is None:
        return None
    base, steps = chain
    values = dict(zip(model.param_names, map(float, np.asarray(params, dtype=float))))
    y = np.asarray(record.y, dtype=float)
    for eff, _ in reversed(steps):
        y = eff.base_output(y, record, values)
    rec_base = record
    if not np.array_equal(y, record.y):
        try:
            rec_base = record.replace(y=y)
        except DataError:  # a degenerate corrected output (e.g. constant): start from the measured one
            rec_base = record
    X = base_states(base, rec_base, np.array([values[n] for n in base.param_names]))
    for eff, _ in steps:
        cols = np.asarray(eff.initial_states(X, record, values), dtype=float).reshape(X.shape[0], eff.n_states)
        X = np.column_stack([X, cols]) if eff.n_states else X
    if X.shape != (record.n_times, model.n_states):
        return None
    return X


# ---------------------------------------------------------------------------------------------- data helpers
def residual(record, y_model) -> np.ndarray:
    """``y - y_model`` as floats, checked for length."""
    y = np.asarray(record.y, dtype=float)
    ym = np.asarray(y_model, dtype=float).reshape(-1)
    if ym.shape != y.shape:
        raise ModelError(f"y_model must have one value per sample of the record ({y.size}); got {ym.size}")
    return y - ym


def lstsq_coeffs(r: np.ndarray, *columns: np.ndarray) -> np.ndarray:
    """Least-squares coefficients of ``r`` on the given columns (0 where a column is degenerate)."""
    A = np.column_stack(columns)
    coef, *_ = np.linalg.lstsq(A, r, rcond=1e-10)
    return np.where(np.isfinite(coef), coef, 0.0)
