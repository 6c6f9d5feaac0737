r"""Polynomial terms of the mechanical equation: quadratic stiffness and cubic damping.

Both add a force to the equation of motion of a mechanical model (one with position and
velocity states), in the model's own state units:

- ``quadratic-stiffness``: :math:`\ddot x \mathrel{+}= -k_q x^2`, a restoring force that differs
  for positive and negative displacements (an even, asymmetric spring: a circuit's or a
  spring's imperfect symmetry, or a constant force acting on a cubic spring, which shifts the
  equilibrium and creates a quadratic term about it);
- ``cubic-damping``: :math:`\ddot x \mathrel{+}= -c_3 \dot x^3`, damping growing with the speed
  (an amplifier's or a damper's non-linear resistance).

Where they act: inside the fluid (or oscillator) model, on its internal states x and x', like
the paper's own k3 and c3 terms; not on the piston or the sensor. A negative cubic damping is an
energy-producing term: the diagnosis marks such a fit as outside the stability certificate and
does not call it needed (issue 16). ``input-curvature`` acts on the input path (d -> d + k d'').

Both are linear in their parameter and add no state. In ``duffsym derive`` the cubic damping
adds :math:`-c_3\dot x^4 \le 0` to :math:`\dot V` (dissipative for :math:`c_3 \ge 0`; either sign is
allowed here, the data decide); the quadratic stiffness adds the potential :math:`k_q x^3/3`,
unbounded below, so the Lyapunov argument holds only locally (for :math:`|x| < \alpha/|k_q|` with
a linear stiffness :math:`\alpha`).

Units: the parameters are per unit mass in the model's state units (for Eq. 1 with an input
gain, ``duffing-gain``: x in output units, t in s), so their magnitude depends on the data; the
identification scales them by ``ParamSpec.scale`` and starts them at 0 (the extended model is
then the base model, whose optimum starts the fit, :func:`~duffsym.identify.extended_start`).
"""

from __future__ import annotations

from dataclasses import dataclass

from duffsym.effects.base import Effect, residual
from duffsym.model.core import InputChannel, SymbolicModel
from duffsym.model.symbols import ParamSpec


@dataclass(frozen=True)
class QuadraticStiffness(Effect):
    """An even spring term :math:`\\ddot x \\mathrel{+}= -k_q x^2` (see the module docstring).

    Initial guess: 0 (the base model), started from the base optimum.
    """

    name: str = "quadratic-stiffness"
    prefix: str = "quad_"
    physics: str = (
        "asymmetric spring: a restoring force x^2 (stiffer on one side; a constant force on a cubic "
        "spring shifts the equilibrium and creates it)"
    )
    signature: str = (
        "residual with even harmonics of the motion (2w, DC) growing with amplitude squared; "
        "peaks of one sign under- and of the other over-predicted"
    )
    form: str = "x_ddot += -quad_k * x^2"
    guess: str = "0 (starts from the base optimum)"

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec(
                f"{self.prefix}k",
                "k_{q}",
                0.0,
                -1e12,
                1e12,
                unit="1/(s^2 x)",
                scale=1e4,
                description="quadratic stiffness per unit mass",
            ),
        )

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        x, v = self._require_mechanical(model)
        (k,) = self.parameters()
        return model.extend(effect=self.name, params=(k,), rhs_add={v: -k.symbol * x**2})

    def initial_guess(self, record, y_model) -> dict[str, float]:
        residual(record, y_model)  # checks the length
        return {f"{self.prefix}k": 0.0}


@dataclass(frozen=True)
class CubicDamping(Effect):
    """Damping growing with the speed cubed: :math:`\\ddot x \\mathrel{+}= -c_3 \\dot x^3` (see the module docstring).

    Initial guess: 0 (the base model), started from the base optimum.
    """

    name: str = "cubic-damping"
    prefix: str = "cdamp_"
    physics: str = "non-linear damping growing with the speed cubed (non-linear resistance)"
    signature: str = (
        "residual odd in velocity, largest at the fastest motion (peaks of the resonance "
        "over-predicted at large amplitude), in quadrature with the displacement"
    )
    form: str = "x_ddot += -cdamp_c * x_dot^3"
    guess: str = "0 (starts from the base optimum)"

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec(
                f"{self.prefix}c",
                "c_{3}",
                0.0,
                -1e9,
                1e9,
                unit="s/x^2",
                scale=1e-3,
                description="cubic damping per unit mass",
            ),
        )

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        _, v = self._require_mechanical(model)
        (c,) = self.parameters()
        return model.extend(effect=self.name, params=(c,), rhs_add={v: -c.symbol * v**3})

    def initial_guess(self, record, y_model) -> dict[str, float]:
        residual(record, y_model)  # checks the length
        return {f"{self.prefix}c": 0.0}


@dataclass(frozen=True)
class InputCurvature(Effect):
    r"""A second-derivative correction of the input: :math:`F \to F + \kappa\ddot F` (order 0 only).

    Physics: how the sampled input is reconstructed between samples, the even counterpart of
    :class:`~duffsym.effects.inputs.InputShift`. The fit and the simulation interpolate the
    samples linearly; for a band-limited input (e.g. a DAC with a smoothing filter, or a measured
    analog voltage) the linear interpolant carries a sine of :math:`\theta = \omega\,dt` rad per
    sample with the amplitude :math:`\mathrm{sinc}^2(\theta/2) \approx 1 - \theta^2/12`: it
    flattens the fast components. :math:`\kappa \approx -dt^2/12` restores them to second order
    (:math:`\ddot F \approx -\omega^2 F`); the fitted value also absorbs a short even input filter
    (a symmetric FIR tap). It matters when the input has content at a sizeable fraction of the
    sampling rate (the Silverbox: 200 Hz at 610 Hz, :math:`\theta \approx 2`). The model gains the
    input channel :math:`\ddot F` (from a record: :meth:`duffsym.data.Record.acceleration`, whose
    Savitzky–Golay filter itself attenuates near the Nyquist frequency, so :math:`\kappa` is a
    fitted coefficient, not :math:`-dt^2/12` exactly). Only the input is corrected; a rate channel
    the model already uses is left as is (its correction would need :math:`\dddot F`).

    Initial guess: :math:`-dt^2/12` (the linear interpolation of a band-limited input).
    """

    name: str = "input-curvature"
    prefix: str = "curv_"
    physics: str = (
        "input reconstruction between samples, even part: linear interpolation flattens fast input "
        "components by ~(w dt)^2/12; F -> F + kappa F'' restores them (a symmetric input FIR tap)"
    )
    signature: str = (
        "residual in phase with the input's fast components (correlated with the input at lag 0), "
        "growing with frequency squared"
    )
    form: str = "F -> F + curv_k * F_ddot (order 0; F_ddot a new input channel)"
    guess: str = "kappa = -dt^2/12 (linear interpolation of a band-limited input)"

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec(
                f"{self.prefix}k",
                r"\kappa",
                0.0,
                -1.0,
                1.0,
                unit="s^2",
                scale=1e-6,
                description="second-derivative input correction (-dt^2/12: band-limited input)",
            ),
        )

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        base = self._require_input(model, 0)
        (k,) = self.parameters()
        have = {c.order: c for c in model.inputs if c.signal == base.signal}
        acc = have.get(2, InputChannel(base.signal, 2))
        new = () if 2 in have else (acc,)
        return model.extend(
            effect=self.name, params=(k,), inputs=new, substitute={base.symbol: base.symbol + k.symbol * acc.symbol}
        )

    def initial_guess(self, record, y_model) -> dict[str, float]:
        residual(record, y_model)  # checks the length
        name = f"{self.prefix}k"
        return {name: self._clip(name, -(record.dt**2) / 12)}
