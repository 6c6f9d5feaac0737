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
    physics: str = (
        "friction inside the fluid model: a force of constant magnitude opposing the internal velocity x' "
        "(continuous, tanh); piston seal friction is seal-friction"
    )
    signature: str = "step-like residual at velocity reversals, odd in velocity (opposes the motion)"
    form: str = "x_ddot += -fric_mu * tanh(x_dot / 0.01)"
    guess: str = "mu = 10 * (step of the residual against sign(y_model)) / max|y| (rough)"
    epsilon: float = 0.01

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec(
                f"{self.prefix}mu",
                r"\mu",
                0.0,
                0.0,
                1e6,
                unit="1",
                scale=1.0,
                description="Coulomb friction level (force on the normalised mass)",
            ),
        )

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


#: The even functions of the element's state that :class:`DirectionalDamping` can use (smoothed |.|).
DIRECTION_FORMS = {
    "velocity": "|x'|",  # sigma |x'|   (path: a damping coefficient c +- c_dir)
    "velocity-quadratic": "|x'| x'",  # sigma |x'| x'
    "position": "|x|",  # sigma |x|
}


def smooth_abs(u: sp.Expr, eps: float) -> sp.Expr:
    r""":math:`\sqrt{u^2 + \varepsilon^2} - \varepsilon` (= |u| up to :math:`\varepsilon`, smooth, 0 at 0)."""
    e = sp.Float(eps)
    return sp.sqrt(u**2 + e**2) - e


@dataclass(frozen=True)
class DirectionalDamping(Effect):
    r"""A direction-dependent damping of a two-state element driven by (d, d'):
    :math:`\dot x_2 \mathrel{+}= -c_{dir}\,\dot d\,g(x)`, with :math:`g` even (default
    :math:`g = |\dot x|`, smoothed as :math:`\sqrt{u^2+\varepsilon^2}-\varepsilon`, :math:`\varepsilon` = 1e-3).

    Physics: a resistance that is larger while the drive loads the element (its force and the drive's
    velocity of the same sign) than while it unloads it, by :math:`\pm c_{dir}|\dot x|` — e.g. the
    different flow resistance of a valve or a seal in its two directions of motion, or a friction that
    grows with the element's force. In the path-time element (:func:`duffsym.model.library.path_time`,
    :math:`\dot d = \rho\sigma`, :math:`\sigma \approx \operatorname{sign}\dot d`) it reads
    :math:`x_2' \mathrel{+}= -c_{dir}\sigma g(x)` per unit path: with ``form="velocity"`` the path damping of
    :math:`x_2` is :math:`c_1 + c_2 + c_{dir}\,\sigma\operatorname{sign}x_2`, different on loading and
    unloading. That is the term Eq. 12 cannot make (its velocity terms are odd in :math:`\dot x` and the
    direction enters only through :math:`c_1\dot d`). Note: with ``form="velocity"`` and :math:`k_1 = k_2
    = k_3 = c_3 = 0` the path element is a Bouc-Wen element of exponent 1 in :math:`z = x_2`; the other
    forms (:math:`|\dot x|\dot x`, :math:`|x|`) are not.

    Stability (``duffsym derive``): the term adds :math:`-c_{dir}\dot d\,x_2 g(x)` to :math:`\dot V`,
    sign-indefinite. With ``form="velocity"`` it is bounded by :math:`|c_{dir}||\dot d|x_2^2 \le
    |c_{dir}|\rho x_2^2`, so the path element stays dissipative for :math:`|c_{dir}| < c_1 + c_2` (the
    Lyapunov argument of Eq. 12 then holds with the damping :math:`c_1 + c_2 - |c_{dir}|`); the other
    forms are not covered by it (quadratic and cross terms).
    """

    name: str = "directional-damping"
    prefix: str = "dir_"
    physics: str = (
        "a damping larger on loading than on unloading: x'' += -c_dir d' g(x), g even "
        "(valve/seal resistance different in the two directions)"
    )
    signature: str = (
        "loops whose slope after a reversal differs from the slope before it by an amount growing "
        "with the element's force (not odd in the element's velocity)"
    )
    form: str = "x_ddot += -dir_c * d_dot * |x_dot|  (|u| = sqrt(u^2 + 1e-6) - 1e-3)"
    guess: str = "0 (starts from the base optimum)"
    shape: str = "velocity"
    epsilon: float = 1e-3

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec(
                f"{self.prefix}c",
                "c_{dir}",
                0.0,
                -1e4,
                1e4,
                unit="1/(d unit)",
                scale=1.0,
                description=f"direction-dependent damping, d' {DIRECTION_FORMS[self.shape]}",
            ),
        )

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        if self.shape not in DIRECTION_FORMS:
            from duffsym.errors import ModelError

            raise ModelError(f"directional-damping: shape must be one of {sorted(DIRECTION_FORMS)}; got {self.shape!r}")
        x, v = self._require_mechanical(model)
        d_dot = self._require_input(model, 1).symbol
        (c,) = self.parameters()
        u = {
            "velocity": smooth_abs(v, self.epsilon),
            "velocity-quadratic": smooth_abs(v, self.epsilon) * v,
            "position": smooth_abs(x, self.epsilon),
        }[self.shape]
        return model.extend(effect=self.name, params=(c,), rhs_add={v: -c.symbol * d_dot * u})
