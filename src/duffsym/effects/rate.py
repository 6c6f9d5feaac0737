"""Rate physics of an MR damper that one parameter set of Eq. 12 misses across 0.1-5 Hz (issue 23): candidates a
rheologist would try, each an :class:`~duffsym.effects.base.Effect` on the piston.

Not in the ladder's catalogue (:data:`duffsym.effects.CATALOGUE`; adding them would change every ladder): they
are listed in :data:`RATE_EFFECTS` and tried by the campaign comparison of study s11 / the benchmark
``benchmarks/bench_rate_physics.py``.

- ``maxwell-branch`` (pre-yield viscoelasticity): a spring and a dashpot in series on the piston, in parallel
  with the fluid element. Derivation: the spring's extension ``e`` and the dashpot's share the piston
  velocity, ``d' = e' + z/c``, and the branch force is ``z = k e``; so ``z' = k d' - z/tau`` with ``tau = c/k``.
  Storage ``V = z^2/(2k)`` (``k > 0``): ``dV/dt = z d' - z^2/(k tau)``, the power the piston puts in less a
  non-negative dissipation, so the branch is passive and adds no instability to the fluid element's Lyapunov
  argument (the certificate of the extended model is the base one with ``k > 0``, ``tau > 0``). Its force
  lags the velocity by ``atan(omega tau)``: a damper ``c`` at low frequency, a spring ``k`` above ``1/tau`` --
  a stiffness that grows with the excitation frequency, which Eq. 12 with fixed coefficients lacks. On a
  command-driven model the spring follows the field, ``k(u) = k + k_u u`` (the fluid's pre-yield modulus
  grows with the field).
- ``field-yield`` (a yield force that does not scale with the rate): ``y += (F + F_u u) tanh(d'/eps)``, a
  Bingham plastic's yield on the piston with the field's slope. Eq. 12's fluid force ``A_f x'`` reaches its
  plateau through the rate-dependent ``c3 x'^n`` term, so its plateau moves with the excitation's velocity;
  a Bingham yield stays. An output term: passive (``F tanh(d'/eps) d' >= 0`` for ``F(u) >= 0``), which the bounds
  keep (F, F_u >= 0 for a command u >= 0: a fold of the UTFSM campaign fitted F = -9.4 N without them).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from duffsym.effects.base import Effect, _not_significant, lstsq_coeffs, residual
from duffsym.effects.output import _piston, piston_path, switch_inactivity
from duffsym.model.core import SymbolicModel
from duffsym.model.symbols import ParamSpec


def _field(model: SymbolicModel):
    from duffsym.model.library import FIELD

    return FIELD if FIELD in model.states else None


def maxwell_force(v: np.ndarray, k: np.ndarray | float, tau: float, dt: float) -> np.ndarray:
    """The branch force for a piston velocity ``v`` sampled at ``dt``, started from rest (``z' = k v - z/tau``,
    exact for a velocity held over each sample)."""
    a = float(np.exp(-dt / tau))
    drive = np.broadcast_to(np.asarray(k, dtype=float), np.shape(v)) * np.asarray(v, dtype=float)
    z = np.zeros(np.size(v))
    for i in range(1, z.size):
        z[i] = a * z[i - 1] + tau * (1 - a) * drive[i - 1]
    return z


@dataclass(frozen=True)
class MaxwellBranch(Effect):
    """A Maxwell (spring-dashpot series) branch on the piston: :math:`\\dot z = (k + k_u u)\\,\\dot d - z/\\tau`,
    :math:`y \\leftarrow y + z` (module docstring for the derivation and the passivity argument).

    Initial guess: :math:`\\tau` = a tenth of the record's input period; :math:`k` from least squares of the
    base model's residual on the branch force for unit stiffness (at least 0). Initial state trajectory: that
    force at the guess.
    """

    name: str = "maxwell-branch"
    prefix: str = "mx_"
    physics: str = (
        "pre-yield viscoelasticity: a spring and a dashpot in series on the piston, parallel to the "
        "fluid element (a damper below 1/tau, a spring above; the spring follows the field)"
    )
    signature: str = (
        "residual in phase with the displacement at high frequency and with the velocity at low "
        "frequency: the loop's slope changes with the excitation frequency"
    )
    form: str = "z' = (mx_k + mx_k_u u) d' - z / mx_tau, y += z"
    guess: str = "tau = period/10; k = least squares of the residual on the unit-stiffness branch force, >= 0"
    n_states: int = 1

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec(
                f"{self.prefix}k",
                "k_{m}",
                0.0,
                0.0,
                1e9,
                unit="output unit / input unit",
                scale=0.1,
                description="spring of the Maxwell branch",
            ),
            ParamSpec(
                f"{self.prefix}k_u",
                "k_{m}^{(u)}",
                0.0,
                -1e9,
                1e9,
                unit="output unit / input unit per command unit",
                scale=0.1,
                description="change of the branch spring per unit field",
            ),
            ParamSpec(
                f"{self.prefix}tau",
                r"\tau_{m}",
                0.05,
                1e-4,
                1e3,
                unit="s",
                scale=0.05,
                description="relaxation time c/k of the branch",
            ),
        )

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        _piston(self, model, 1)
        _, v = piston_path(model)
        k, k_u, tau = self.parameters()
        u = _field(model)
        stiff = k.symbol + (k_u.symbol * u if u is not None else 0)
        z = sp.Symbol("z_mx", real=True)
        params = (k, k_u, tau) if u is not None else (k, tau)
        return model.extend(effect=self.name, params=params, states=((z, stiff * v - z / tau.symbol),), output_add=z)

    def initial_guess(self, record, y_model) -> dict[str, float]:
        r = residual(record, y_model)
        v = np.asarray(record.velocity(), dtype=float)
        tau = self._clip(f"{self.prefix}tau", 0.1 * record.period)
        (k,) = lstsq_coeffs(r - r.mean(), maxwell_force(v, 1.0, tau, record.dt))
        return {
            f"{self.prefix}k": self._clip(f"{self.prefix}k", max(k, 0.0)),
            f"{self.prefix}k_u": 0.0,
            f"{self.prefix}tau": tau,
        }

    def initial_states(self, X_base, record, params) -> np.ndarray:
        u = record.command_signal(missing=0.0)  # no command: the field term is absent
        k = params.get(f"{self.prefix}k", 0.0) + params.get(f"{self.prefix}k_u", 0.0) * u
        z = maxwell_force(np.asarray(record.velocity(), dtype=float), k, params[f"{self.prefix}tau"], record.dt)
        return z[:, None]

    def base_output(self, y, record, params):
        return y - self.initial_states(None, record, params)[:, 0]


@dataclass(frozen=True)
class FieldYield(Effect):
    """A Bingham yield force on the piston that follows the field: :math:`y \\leftarrow y + (F + F_u u)
    \\tanh(\\dot d/\\varepsilon)` (module docstring).

    Initial guess: :math:`\\varepsilon` = 2 % of max|d'|; :math:`F, F_u` by least squares of the residual on
    :math:`\\tanh(\\dot d/\\varepsilon)` and the command times it.
    """

    name: str = "field-yield"
    prefix: str = "fy_"
    physics: str = (
        "Bingham yield of the MR fluid on the piston: a force of field-dependent magnitude opposing the "
        "piston velocity, independent of the rate once yielded"
    )
    signature: str = "step of the residual at every velocity reversal, growing with the current"
    form: str = "y += (fy_F + fy_F_u u) tanh(d_dot / fy_eps)"
    guess: str = "eps = 2 % of max|d'|; F, F_u = least squares of the residual on tanh(d'/eps) and i tanh(d'/eps)"

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec(  # >= 0 and rising with the field: a yield opposes the motion (a negative one would drive it)
                f"{self.prefix}F",
                "F_{y}",
                0.0,
                0.0,
                1e9,
                unit="output unit",
                scale=0.1,
                description="yield force at zero field",
            ),
            ParamSpec(
                f"{self.prefix}F_u",
                "F_{y}^{(u)}",
                0.0,
                0.0,
                1e9,
                unit="output unit per command unit",
                scale=0.1,
                description="change of the yield force per unit field",
            ),
            ParamSpec(
                f"{self.prefix}eps",
                r"\varepsilon_{y}",
                0.1,
                1e-6,
                1e9,
                unit="input unit / s",
                scale=0.1,
                description="piston velocity at which the yield is 76 % developed (tanh 1)",
            ),
        )

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        _piston(self, model, 1)
        _, v = piston_path(model)
        F, F_u, eps = self.parameters()
        u = _field(model)
        mag = F.symbol + (F_u.symbol * u if u is not None else 0)
        params = (F, F_u, eps) if u is not None else (F, eps)
        return model.extend(effect=self.name, params=params, output_add=mag * sp.tanh(v / eps.symbol))

    def initial_guess(self, record, y_model) -> dict[str, float]:
        r = residual(record, y_model)
        v = np.asarray(record.velocity(), dtype=float)
        eps = self._clip(f"{self.prefix}eps", 0.02 * (float(np.max(np.abs(v))) or 1.0))
        s = np.tanh(v / eps)
        _, F, F_u = lstsq_coeffs(r, np.ones_like(v), s, record.command_signal(missing=0.0) * s)
        return {
            f"{self.prefix}F": self._clip(f"{self.prefix}F", F),
            f"{self.prefix}F_u": self._clip(f"{self.prefix}F_u", F_u),
            f"{self.prefix}eps": eps,
        }

    def base_output(self, y, record, params):
        return y - self._force(record, params)

    def _force(self, record, params) -> np.ndarray:
        v = np.asarray(record.velocity(), dtype=float)
        mag = params[f"{self.prefix}F"] + params.get(f"{self.prefix}F_u", 0.0) * record.command_signal(missing=0.0)
        return mag * np.tanh(v / params[f"{self.prefix}eps"])

    def activity(self, record, params, stderr=None) -> str:
        """Inactive when its force is negligible against the record's, when its switch is flat over the record (a
        viscous term), or when neither of its magnitudes is distinguishable from zero."""
        eps = float(params[f"{self.prefix}eps"])
        why = switch_inactivity(record, self._force(record, params), f"{self.prefix}eps", eps, "a yield")
        if why:
            return why
        names = [n for n in (f"{self.prefix}F", f"{self.prefix}F_u") if n in params]
        whys = [_not_significant(n, params, stderr or {}) for n in names]
        return " and ".join(whys) if all(whys) else ""


#: The rate candidates by name (outside the ladder's catalogue; see the module docstring).
RATE_EFFECTS: dict[str, Effect] = {e.name: e for e in (MaxwellBranch(), FieldYield())}
