"""Effects on the mechanical state equations: continuous Coulomb friction inside the fluid model.

Its twin on the piston side, seal friction on the measured piston velocity added to the measured
force, is :class:`duffsym.effects.output.SealFriction` (``seal-friction``)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from duffsym.effects.base import Effect, lstsq_coeffs, residual
from duffsym.model.core import SymbolicModel
from duffsym.model.symbols import ParamSpec


@dataclass(frozen=True)
class CoulombFriction(Effect):
    """Continuous Coulomb friction inside the fluid model, on its internal velocity:
    :math:`\\ddot x \\mathrel{+}= -\\mu\\tanh(\\dot x/\\varepsilon)`.

    Where it acts, and why here: on the model's moving mass (the fluid's :math:`x`), i.e. friction
    whose effect on the force passes through the fluid dynamics (e.g. a yield-stress-like resistance
    of the fluid itself). Friction of the piston seals acts on the piston velocity and adds to the
    measured force directly: that is ``seal-friction`` (:class:`~duffsym.effects.output.SealFriction`).

    A force of constant magnitude opposing the motion, made continuous (the paper's point) and
    differentiable for IPOPT by ``tanh`` with a fixed :math:`\\varepsilon = 0.01`. It acts on the
    model's internal velocity :math:`\\dot x`, normalised by the convention :math:`A_f = \\max|y|`
    (:math:`|\\dot x| \\lesssim 1`), so :math:`\\varepsilon` is 1 % of the velocity range whatever the data's
    units; the friction is fully developed above ~3 % of it. In the Lyapunov argument of
    ``duffsym derive`` it adds :math:`-\\mu\\dot x\\tanh(\\dot x/\\varepsilon) \\le 0` to :math:`\\dot V`
    (dissipative for :math:`\\mu \\ge 0`).

    Initial guess: the residual is projected on :math:`-\\mathrm{sign}(y_{model})` (a force step at each
    reversal); the step ``s`` (output units) is turned into a force on the normalised mass as
    :math:`\\mu \\approx c\\,s/\\max|y|` with a typical normalised damping :math:`c = 10` — a rough start only.
    """

    name: str = "coulomb-friction"
    prefix: str = "fric_"
    physics: str = ("friction inside the fluid model: a force of constant magnitude opposing the internal velocity x' "
                    "(continuous, tanh); piston seal friction is seal-friction")
    signature: str = "step-like residual at velocity reversals, odd in velocity (opposes the motion)"
    form: str = "x_ddot += -fric_mu * tanh(x_dot / 0.01)"
    guess: str = "mu = 10 * (step of the residual against sign(y_model)) / max|y| (rough)"
    epsilon: float = 0.01

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (ParamSpec(f"{self.prefix}mu", r"\mu", 0.0, 0.0, 1e6, unit="1", scale=1.0,
                          description="Coulomb friction level (force on the normalised mass)"),)

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        _, v = self._require_mechanical(model)
        (mu,) = self.parameters()
        term = -mu.symbol * sp.tanh(v / sp.Float(self.epsilon))
        return model.extend(effect=self.name, params=(mu,), rhs_add={v: term})

    def initial_guess(self, record, y_model) -> dict[str, float]:
        r = residual(record, y_model)
        ym = np.asarray(y_model, dtype=float)
        (s,) = lstsq_coeffs(r - r.mean(), -np.sign(ym))
        peak = float(np.max(np.abs(record.y))) or 1.0
        name = f"{self.prefix}mu"
        return {name: self._clip(name, max(10.0 * s / peak, 0.0))}
