"""Physical effects as composable extensions of a symbolic model.

An effect adds terms, states, inputs or parameters to a :class:`~duffsym.model.SymbolicModel`
through :meth:`SymbolicModel.extend`; it never edits generated code. Derivations, code generation
and simulation then work on the extended model unchanged.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import sympy as sp

from duffsym.errors import ModelError
from duffsym.model.core import SymbolicModel
from duffsym.model.symbols import ParamSpec


class Effect:
    """Base class of an effect: a name, a one-line physics description, and :meth:`apply`.

    Subclasses prefix their parameter names with ``prefix`` so effects combine without clashes.
    """

    name: str = "effect"
    prefix: str = ""
    physics: str = ""
    signature: str = ""  # how the effect shows in the residuals of a model that lacks it

    def apply(self, model: SymbolicModel) -> SymbolicModel:  # pragma: no cover - interface
        raise NotImplementedError

    def _check_not_applied(self, model: SymbolicModel) -> None:
        if self.name in model.effects:
            raise ModelError(f"effect {self.name} is already applied to model {model.name}")

    def _require_mechanical(self, model: SymbolicModel) -> tuple[sp.Symbol, sp.Symbol]:
        if model.position is None or model.velocity is None:
            raise ModelError(f"effect {self.name} needs a mechanical model (position and velocity states); "
                             f"model {model.name} has none")
        self._check_not_applied(model)
        return model.position, model.velocity


def apply_effects(model: SymbolicModel, effects: Iterable[Effect]) -> SymbolicModel:
    """``model`` with each effect applied in order."""
    for effect in effects:
        model = effect.apply(model)
    return model


@dataclass(frozen=True)
class ForceOffset(Effect):
    """A constant offset of the measured force (load-cell zero error, gas preload seen as a bias).

    .. math:: y \\leftarrow y + y_0
    """

    name: str = "force-offset"
    prefix: str = "off_"
    physics: str = "constant force bias: load-cell zero or accumulator preload"
    signature: str = "residual mean is non-zero; d–y loop shifted vertically"

    def apply(self, model: SymbolicModel) -> SymbolicModel:
        self._check_not_applied(model)
        y0 = ParamSpec(f"{self.prefix}y0", "y_{0}", 0.0, -1e9, 1e9, unit="output unit",
                       description="force offset")
        return model.extend(effect=self.name, params=(y0,), output_add=y0.symbol)


@dataclass(frozen=True)
class CoulombFriction(Effect):
    """Continuous Coulomb (seal) friction on the fluid mass: :math:`-\\mu\\tanh(\\dot x/\\varepsilon)`.

    The smooth ``tanh`` keeps the model continuous (the paper's point) and differentiable for IPOPT.
    """

    name: str = "coulomb-friction"
    prefix: str = "fric_"
    physics: str = "seal friction: a force of constant magnitude opposing the motion"
    signature: str = "step-like residual at velocity reversals, odd in d'"
    epsilon: float = 0.01

    def apply(self, model: SymbolicModel) -> SymbolicModel:
        _, v = self._require_mechanical(model)
        mu = ParamSpec(f"{self.prefix}mu", r"\mu", 0.0, 0.0, 1e6, description="Coulomb friction level")
        term = -mu.symbol * sp.tanh(v / sp.Float(self.epsilon))
        return model.extend(effect=self.name, params=(mu,), rhs_add={v: term})


@dataclass(frozen=True)
class OutputLag(Effect):
    """First-order dynamics between the model force and the measured force (coil, sensor, filter).

    Adds a state :math:`z` with :math:`\\tau\\dot z = y - z`; the output becomes :math:`z`.
    """

    name: str = "output-lag"
    prefix: str = "lag_"
    physics: str = "first-order lag of the measured force: coil inductance, sensor or filter dynamics"
    signature: str = "residual ~ -tau * dy/dt: largest where the force changes fastest"

    def apply(self, model: SymbolicModel) -> SymbolicModel:
        self._check_not_applied(model)
        tau = ParamSpec(f"{self.prefix}tau", r"\tau", 0.01, 1e-6, 10.0, unit="s", description="lag time constant")
        z = sp.Symbol("z_lag", real=True)
        return model.extend(effect=self.name, params=(tau,), states=((z, (model.output - z) / tau.symbol),), output=z)
