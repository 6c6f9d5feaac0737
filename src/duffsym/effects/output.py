"""Effects on the measured force: offset, gas accumulator, inertia, parallel damping, asymmetry, output lag.

Each adds a term to the output (or, for the lag, a filter state between the model force and the
measured force). None of them changes the state equations of the mechanical model, so the
Lyapunov argument of ``duffsym derive`` is unchanged by them (only the output map changes); the
output lag adds a stable first-order state (:math:`\\tau > 0`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from duffsym.effects.base import Effect, _not_significant, lstsq_coeffs, residual
from duffsym.errors import ModelError
from duffsym.model.core import InputChannel, SymbolicModel
from duffsym.model.symbols import ParamSpec

#: Parameters of the additive output effects: set to 0 they remove their term (see Asymmetry).
ADDITIVE_OUTPUT_PARAMS = ("off_y0", "gas_k", "inertia_m")

OFFSET = ParamSpec(
    "off_y0",
    "y_{0}",
    0.0,
    -1e9,
    1e9,
    unit="output unit",
    scale=1.0,
    description="constant force: load-cell zero error or accumulator preload",
)


def whole_cycle_mean(record) -> float:
    """Mean of the measured force over the whole input cycles of the record (all of it if unknown).

    A symmetric damper's force is odd in the motion and averages to zero over whole cycles; a base
    model lacking the offset can mimic part of it (e.g. a drifting state with k1 = k2 = 0), so the
    mean residual underestimates it, while the whole-cycle mean of ``y`` does not.
    """
    y = np.asarray(record.y, dtype=float)
    t = np.asarray(record.t, dtype=float)
    try:
        n = int(np.floor((t[-1] - t[0]) / record.period))
        stop = int(np.searchsorted(t, t[0] + n * record.period)) if n >= 1 else y.size
    except (IndexError, ZeroDivisionError, ValueError):
        stop = y.size
    v = float(np.mean(y[: max(stop, 2)]))
    return v if np.isfinite(v) else 0.0


@dataclass(frozen=True)
class ForceOffset(Effect):
    """A constant offset of the measured force: :math:`y \\leftarrow y + y_0`.

    Where it acts: on the sensor (load-cell zero error) or, as a preload, on the piston; the same
    constant in the measured force either way.

    Physics: load-cell zero error, or the preload force of a gas accumulator. On a single record a
    constant preload and a sensor offset are the same term (not separable); the
    :class:`GasAccumulator` therefore uses this very parameter, ``off_y0``, for its preload, and
    the two effects are not applied together (force-offset after gas-accumulator raises).

    Initial guess: the mean of the measured force over whole input cycles (see :func:`whole_cycle_mean`).
    """

    name: str = "force-offset"
    prefix: str = "off_"
    physics: str = (
        "constant force: load-cell zero error or gas-accumulator preload (the same term on one record; "
        "gas-accumulator includes it)"
    )
    signature: str = "residual mean is non-zero; d-y loop shifted vertically, residual not correlated with d or d'"
    form: str = "y += off_y0"
    guess: str = "off_y0 = mean of y over whole input cycles"

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (OFFSET,)

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        if OFFSET.name in model.param_names:
            raise ModelError(
                f"model {model.name} already has the constant force {OFFSET.name} (from "
                f"{', '.join(model.effects) or 'the model'}); a second offset would not be identifiable"
            )
        return model.extend(effect=self.name, params=(OFFSET,), output_add=OFFSET.symbol)

    def initial_guess(self, record, y_model) -> dict[str, float]:
        residual(record, y_model)
        return {OFFSET.name: self._clip(OFFSET.name, whole_cycle_mean(record))}

    def base_output(self, y, record, params):
        if "gas_k" in params:  # a gas accumulator added after it shares off_y0 and removes it itself
            return y
        return y - params[OFFSET.name]


@dataclass(frozen=True)
class GasAccumulator(Effect):
    """Gas accumulator: preload and gas-spring stiffness on the piston displacement,
    :math:`y \\leftarrow y + y_0 + k_a d`.

    Where it acts: on the piston, through its displacement (the rod volume in the cylinder), and
    directly on the measured force. The measured ``d`` stands for the piston displacement: with a
    joint play the actuator and piston differ by at most the half-width, a second-order error here.

    The accumulator's gas volume changes with the rod volume in the cylinder, so its pressure, and
    the force it adds, is (linearised) a preload plus a stiffness on the piston displacement ``d``.
    The preload is the force-offset parameter ``off_y0`` itself (a constant preload and a sensor
    zero error cannot be told apart on one record); applied to a model that already has
    ``off_y0`` (force-offset) it adds the stiffness only. ``gas_k`` may take either sign, as the
    sign of ``d`` depends on the rig's convention.

    Under a single sine :math:`\\ddot d = -\\omega^2 d`, so the stiffness and the piston inertia
    (:class:`PistonInertia`) are the same term; a multisine or several frequencies separate them.

    Initial guess: ``off_y0`` as for force-offset; ``gas_k`` by least squares of the residual on ``[1, d]``.
    """

    name: str = "gas-accumulator"
    prefix: str = "gas_"
    physics: str = (
        "gas spring of the accumulator: preload off_y0 (= force-offset, same term) plus stiffness "
        "gas_k on the piston displacement"
    )
    signature: str = (
        "residual linear in d (in phase with the displacement, loop tilted) plus a constant; "
        "on one sine indistinguishable from inertia"
    )
    form: str = "y += off_y0 + gas_k * d"
    guess: str = "off_y0 = mean of y over whole cycles; gas_k = least squares of the residual on [1, d]"

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            OFFSET,
            ParamSpec(
                f"{self.prefix}k",
                "k_{a}",
                0.0,
                -1e9,
                1e9,
                unit="output unit / input unit",
                scale=0.1,
                description="gas-spring stiffness on the piston displacement",
            ),
        )

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        d = _piston(self, model, 0)
        off, k = self.parameters()
        params = (k,) if off.name in model.param_names else (off, k)
        term = k.symbol * d.symbol + (off.symbol if off in params else 0)
        return model.extend(effect=self.name, params=params, output_add=term)

    def initial_guess(self, record, y_model) -> dict[str, float]:
        r = residual(record, y_model)
        d = np.asarray(record.d, dtype=float)
        c0, c1 = lstsq_coeffs(r, np.ones_like(d), d)
        return {
            OFFSET.name: self._clip(OFFSET.name, whole_cycle_mean(record)),
            f"{self.prefix}k": self._clip(f"{self.prefix}k", c1),
        }

    def base_output(self, y, record, params):
        return y - params[OFFSET.name] - params[f"{self.prefix}k"] * np.asarray(record.d)


@dataclass(frozen=True)
class PistonInertia(Effect):
    """Piston and fluid inertia: :math:`y \\leftarrow y + m_p \\ddot d`.

    Where it acts: on the piston (its mass, and the fluid it drags, are accelerated by the
    actuator), directly in the measured force; not in the fluid model, whose mass ``m`` the paper
    normalises away (Eq. 12).

    The mass of the piston, rod and the fluid it accelerates adds a force proportional to the
    piston acceleration. The model gains the input channel :math:`\\ddot d` (``d_ddot``): from an
    :class:`~duffsym.excitation.Excitation` it is exact; from a record it is the Savitzky–Golay
    derivative of the velocity (:meth:`duffsym.data.Record.acceleration`). ``inertia_m >= 0``
    (in the convention where the damping force is positive with the velocity).

    Under a single sine it is collinear with the gas stiffness (:math:`\\ddot d = -\\omega^2 d`).

    Initial guess: the :math:`\\ddot d` coefficient of the least-squares fit of the residual on
    :math:`[1, \\dot d, \\ddot d]` (the velocity column takes up a damping misfit of the base fit,
    in quadrature with the acceleration on a sine).
    """

    name: str = "inertia"
    prefix: str = "inertia_"
    physics: str = "inertia of piston, rod and accelerated fluid: a force proportional to the piston acceleration"
    signature: str = (
        "residual proportional to d'' (in phase with -d on a sine), growing with frequency squared; "
        "loops wider at high frequency"
    )
    form: str = "y += inertia_m * d_ddot"
    guess: str = "d'' coefficient of the least squares of the residual on [1, d', d''] (record acceleration)"

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec(
                f"{self.prefix}m",
                "m_{p}",
                0.0,
                0.0,
                1e9,
                unit="output unit / (input unit/s^2)",
                scale=0.01,
                description="piston and fluid mass",
            ),
        )

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        _piston(self, model, 0)
        (m,) = self.parameters()
        acc = InputChannel("d", 2)
        return model.extend(effect=self.name, params=(m,), inputs=(acc,), output_add=m.symbol * acc.symbol)

    def initial_guess(self, record, y_model) -> dict[str, float]:
        r = residual(record, y_model)
        a = np.asarray(record.acceleration(), dtype=float)
        v = np.asarray(record.velocity(), dtype=float)
        _, _, c = lstsq_coeffs(r, np.ones_like(a), v, a)
        return {f"{self.prefix}m": self._clip(f"{self.prefix}m", c)}

    def base_output(self, y, record, params):
        return y - params[f"{self.prefix}m"] * np.asarray(record.acceleration())


@dataclass(frozen=True)
class ParallelDamping(Effect):
    """A viscous damper in parallel with the model, on the piston: :math:`y \\leftarrow y + c_0\\dot d`;
    on a command-driven model its coefficient follows the field, :math:`c_0(u) = c_0 + c_{0u} u`.

    Where it acts: on the piston, beside the fluid element (the :math:`c_0` of Spencer et al.'s
    phenomenological model, whose :math:`c_0 = c_{0a} + c_{0b} u`). The fluid element's force
    :math:`A_f\\dot x` saturates once the :math:`c_3\\dot x^n` term dominates (the yield); the force of an MR
    damper keeps rising with the piston speed after yield (the post-yield viscous slope), which this
    term carries. With a backlash applied the piston velocity is the backlash state's rate.

    Initial guess: least squares of the residual on :math:`[1, \\dot d]` (and :math:`i\\,\\dot d`, the
    command standing for the field, on a command-driven model).
    """

    name: str = "parallel-damping"
    prefix: str = "pd_"
    physics: str = (
        "viscous damper in parallel with the fluid element on the piston (Spencer's c0; field-dependent "
        "on a command-driven model): the post-yield slope of force against velocity"
    )
    signature: str = (
        "residual proportional to d' (in phase with the velocity), growing at high speed: the measured "
        "force keeps rising after yield while the model's saturates"
    )
    form: str = "y += (pd_c + pd_c_u * u_field) * d_dot (pd_c_u only on a command-driven model)"
    guess: str = "least squares of the residual on [1, d'] (and command * d' on a command-driven model)"

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec(
                f"{self.prefix}c",
                "c_{0}",
                0.0,
                -1e9,
                1e9,
                unit="output unit / (input unit/s)",
                scale=0.1,
                description="parallel viscous damping",
            ),
            ParamSpec(
                f"{self.prefix}c_u",
                "c_{0}^{(u)}",
                0.0,
                -1e9,
                1e9,
                unit="output unit / (input unit/s) per command unit",
                scale=0.1,
                description="change of the parallel damping per unit field",
            ),
        )

    def _field(self, model: SymbolicModel):
        from duffsym.model.library import FIELD

        return FIELD if FIELD in model.states else None

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        _piston(self, model, 1)
        _, v = piston_path(model)
        c, c_u = self.parameters()
        u = self._field(model)
        if u is None:
            return model.extend(effect=self.name, params=(c,), output_add=c.symbol * v)
        return model.extend(effect=self.name, params=(c, c_u), output_add=(c.symbol + c_u.symbol * u) * v)

    def initial_guess(self, record, y_model) -> dict[str, float]:
        r = residual(record, y_model)
        v = np.asarray(record.velocity(), dtype=float)
        cmd = record.command
        if cmd is None:
            _, c = lstsq_coeffs(r, np.ones_like(v), v)
            return {f"{self.prefix}c": self._clip(f"{self.prefix}c", c), f"{self.prefix}c_u": 0.0}
        _, c, c_u = lstsq_coeffs(r, np.ones_like(v), v, np.asarray(cmd, dtype=float) * v)
        return {
            f"{self.prefix}c": self._clip(f"{self.prefix}c", c),
            f"{self.prefix}c_u": self._clip(f"{self.prefix}c_u", c_u),
        }

    def base_output(self, y, record, params):
        v = np.asarray(record.velocity(), dtype=float)
        c_u = params.get(f"{self.prefix}c_u", 0.0)
        # the field at its equilibrium: the command history, or a constant-current record's label
        field = np.asarray(record.command_signal(), dtype=float) if c_u else 0.0
        return y - (params[f"{self.prefix}c"] + c_u * field) * v


@dataclass(frozen=True)
class FieldAsymmetry(Effect):
    """The field of a command-driven model rises and decays at different rates:
    :math:`\\dot u = -\\eta\\,(1 + a\\tanh((i - u)/\\varepsilon))\\,(u - i)`, rate :math:`\\eta(1 + a)` while the field
    rises towards the command and :math:`\\eta(1 - a)` while it decays.

    Where it acts: in the coil and the fluid, between the command and the field. A current driver pushes
    the coil current up against its inductance but lets it decay through the coil's resistance (and eddy
    currents in the steel slow the decay of the flux), so switching on and off differ; a symmetric
    first-order lag averages the two. Only for models with a field state driven by a command.

    Initial guess: :math:`a = 0` (the symmetric lag of the fitted model) and :math:`\\varepsilon` = 2 % of
    the command's range.
    """

    name: str = "field-asymmetry"
    prefix: str = "fa_"
    physics: str = (
        "the field rises and decays at different rates (current driver against the coil's inductance "
        "on switch-on, resistance and eddy currents on switch-off)"
    )
    signature: str = (
        "residual after command switches, of one sign after switch-on and the other after switch-off "
        "(the model's force rises too slowly and decays too fast, or the reverse)"
    )
    form: str = "u' = -eta (1 + fa_a tanh((i - u)/fa_eps)) (u - i)"
    guess: str = "fa_a = 0; fa_eps = 2 % of the command's range"

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec(
                f"{self.prefix}a",
                "a_{u}",
                0.0,
                -0.95,
                0.95,
                unit="1",
                scale=0.1,
                description="relative rate difference, rising +a, decaying -a",
            ),
            ParamSpec(
                f"{self.prefix}eps",
                r"\\varepsilon_{u}",
                0.05,
                1e-4,
                1e3,
                unit="command unit",
                scale=0.05,
                description="field-command difference over which the rate switches (tanh 1)",
            ),
        )

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        from duffsym.model.library import COMMAND, FIELD

        if FIELD not in model.states or COMMAND not in model.inputs or "eta" not in model.param_names:
            raise ModelError(
                f"effect {self.name} needs a command-driven model with a field state (e.g. "
                f"mr-damper-current); model {model.name} has none"
            )
        a, eps = self.parameters()
        u, i, eta = FIELD, COMMAND.symbol, model.param("eta").symbol
        term = -eta * a.symbol * sp.tanh((i - u) / eps.symbol) * (u - i)
        return model.extend(effect=self.name, params=(a, eps), rhs_add={u: term})

    def initial_guess(self, record, y_model) -> dict[str, float]:
        residual(record, y_model)
        span = float(np.ptp(np.asarray(record.command, dtype=float))) if record.command is not None else 0.0
        eps = 0.02 * span if span > 0 else self._spec(f"{self.prefix}eps").default
        return {f"{self.prefix}a": 0.0, f"{self.prefix}eps": self._clip(f"{self.prefix}eps", eps)}


@dataclass(frozen=True)
class Asymmetry(Effect):
    """Different force levels in compression and extension:
    :math:`y \\leftarrow y + a\\,F\\tanh(\\dot x/\\varepsilon)`, with :math:`F` the model's force before the
    additive output terms (offset, gas, inertia).

    Where it acts: in the fluid force, switched by the direction of the fluid flow :math:`\\dot x`
    (which chamber is pressurised), so inside the model's output rather than on the piston.

    With :math:`F = A_f\\dot x` this is :math:`A_f\\dot x\\,(1 + a\\,\\mathrm{sign}\\,\\dot x)`: gain
    :math:`1 + a` for :math:`\\dot x > 0` and :math:`1 - a` for :math:`\\dot x < 0` (rod-side vs
    piston-side areas, valve asymmetry). The switch acts on the model's internal velocity
    :math:`\\dot x`, which is normalised by the convention :math:`A_f = \\max|y|` (so
    :math:`|\\dot x| \\lesssim 1` whatever the units), with a fixed :math:`\\varepsilon = 0.05`; near
    :math:`\\dot x = 0` the term is :math:`\\approx a A_f \\dot x^2/\\varepsilon`, smooth. Applied after an
    output lag it scales the lagged force.

    Initial guess: least squares of the residual on :math:`|y_{model}|`.
    """

    name: str = "asymmetry"
    prefix: str = "asym_"
    physics: str = "compression and extension give different force levels (rod/piston areas, valves)"
    signature: str = "residual even in velocity: ~ a*|y| (same sign in both half-cycles, zero at reversals)"
    form: str = "y += asym_a * F * tanh(x_dot / 0.05), F the model force"
    guess: str = "least squares of the residual on |y_model|"
    epsilon: float = 0.05

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec(
                f"{self.prefix}a",
                "a",
                0.0,
                -0.95,
                0.95,
                unit="1",
                scale=0.1,
                description="relative force difference, extension +a, compression -a",
            ),
        )

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        _, v = self._require_mechanical(model)
        (a,) = self.parameters()
        zero = {model.param(n).symbol: 0 for n in ADDITIVE_OUTPUT_PARAMS if n in model.param_names}
        force = model.output.xreplace(zero)
        return model.extend(
            effect=self.name, params=(a,), output_add=a.symbol * force * sp.tanh(v / sp.Float(self.epsilon))
        )

    def initial_guess(self, record, y_model) -> dict[str, float]:
        r = residual(record, y_model)
        ym = np.abs(np.asarray(y_model, dtype=float))
        (c,) = lstsq_coeffs(r, ym)
        return {f"{self.prefix}a": self._clip(f"{self.prefix}a", c)}

    def base_output(self, y, record, params):
        a = params[f"{self.prefix}a"]
        return np.where(y >= 0, y / (1 + a), y / (1 - a))


#: The smallest lag time constant (s). A lag far below a sample is not observable, and the limit
#: tau -> 0 is singular: fitted to data without a lag, tau ran to 1e-6 s, where the free run needed
#: more than 5000 RK4 substeps per 5 ms sample and failed; at 1e-4 s it needs about 80 and the fit
#: reports tau on its bound, i.e. no lag.
LAG_TAU_MIN = 1e-4


@dataclass(frozen=True)
class OutputLag(Effect):
    """First-order dynamics between the model force and the measured force (coil inductance of the
    field, sensor or anti-alias filter): a state :math:`z` with :math:`\\tau\\dot z = y - z`; the
    output becomes :math:`z`.

    Where it acts: on the sensor chain (load cell, amplifier, anti-alias filter), after every
    force of the device is summed.

    To first order in :math:`\\tau\\omega` the lag is :math:`z \\approx y - \\tau\\dot y`, the same as an
    input delay :math:`\\tau` (:class:`~duffsym.effects.inputs.InputDelay`); they differ at second order
    (the lag attenuates by :math:`1/\\sqrt{1 + \\tau^2\\omega^2}` and rounds sharp corners, the delay
    only shifts).

    Initial guess:
    :math:`\\tau = -\\langle r, \\dot y_{model}\\rangle / \\langle \\dot y_{model}, \\dot y_{model}\\rangle`
    (the residual's projection on the model force's rate), at least ``dt/2`` (a base fit absorbs
    part of the lag in its parameters, so the projection underestimates it). Initial state
    trajectory: :math:`z` = the measured force.
    """

    name: str = "output-lag"
    prefix: str = "lag_"
    physics: str = "first-order lag of the measured force: coil inductance, sensor or filter dynamics"
    signature: str = (
        "residual ~ -tau * dy/dt: largest where the force changes fastest, loop corners rounded; "
        "to first order the same as an input delay"
    )
    form: str = "z' = (y - z) / lag_tau, output z"
    guess: str = "tau = -<r, dy_model/dt> / <dy_model/dt, dy_model/dt>, at least dt/2"
    n_states: int = 1

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec(
                f"{self.prefix}tau",
                r"\tau",
                0.01,
                LAG_TAU_MIN,
                10.0,
                unit="s",
                scale=0.01,
                description="lag time constant",
            ),
        )

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        (tau,) = self.parameters()
        z = sp.Symbol("z_lag", real=True)
        return model.extend(effect=self.name, params=(tau,), states=((z, (model.output - z) / tau.symbol),), output=z)

    def initial_guess(self, record, y_model) -> dict[str, float]:
        r = residual(record, y_model)
        ym = np.asarray(y_model, dtype=float)
        rate = np.gradient(ym, np.asarray(record.t))
        (c,) = lstsq_coeffs(r - r.mean(), -(rate - rate.mean()))
        name = f"{self.prefix}tau"
        return {name: self._clip(name, max(c, 0.5 * record.dt), 0.5 * record.dt)}

    def initial_states(self, X_base, record, params) -> np.ndarray:
        return np.asarray(record.y, dtype=float)[:, None]


def _piston(effect: Effect, model: SymbolicModel, order: int) -> InputChannel:
    """The model's piston-displacement input channel (signal ``d``), or a ModelError."""
    chan = effect._require_input(model, order)
    if chan.signal != "d":
        raise ModelError(
            f"effect {effect.name} acts on the piston displacement d; model {model.name} is driven by {chan.signal!r}"
        )
    return chan


def piston_path(model: SymbolicModel) -> tuple[sp.Expr, sp.Expr]:
    """The piston displacement and velocity as the model sees them: ``d, d'``; or, when a joint
    backlash is already applied, the piston's ``b`` and ``b'`` from its gap state (the play sits between the
    measured actuator displacement and the piston)."""
    from duffsym.effects.inputs import GAP_STATE, Backlash

    chans = {c.order: c.symbol for c in model.inputs if c.signal == "d"}
    if 0 not in chans or 1 not in chans:
        raise ModelError(f"model {model.name} has no piston displacement and velocity inputs (d, d_dot)")
    names = [str(s) for s in model.states]
    if GAP_STATE in names:  # b = d - h' z, b' = d' - h' z' (whatever the form of the play's switch)
        i, h = names.index(GAP_STATE), Backlash().width(model)
        return chans[0] - h * model.states[i], chans[1] - h * model.rhs[i]
    return chans[0], chans[1]


#: The seal friction's switching velocity as a fraction of the largest piston speed of the record:
#: the start of the fit of ``seal_eps`` (the parameter is fitted).
SEAL_EPS_FRACTION = 0.02
#: ``seal_eps`` may range over these fractions of the record's largest piston speed (``record_bounds``).
SEAL_EPS_RANGE = (1e-4, 1.0)
#: an added effect whose output term's RMS is below this fraction of the force's spread is called inactive
NEGLIGIBLE = 0.005


@dataclass(frozen=True)
class SealFriction(Effect):
    """Piston seal friction, acting on the *piston*: :math:`y \\leftarrow y + F_c\\tanh(\\dot d/\\varepsilon)`.

    Where it acts, and why here: the seals rub between the piston rod and the cylinder, so their
    friction force depends on the piston velocity :math:`\\dot d` (measured), and it reaches the load
    cell directly, beside the fluid force: it is a term of the output, not of the fluid model.
    The catalogue's ``coulomb-friction`` is the other place physics allows, a friction inside the
    fluid model on its internal velocity :math:`\\dot x` (it shapes the hysteresis, delayed by the
    model's dynamics); measured on independently generated data with the friction on the piston,
    that internal form barely helps (held-out NRMSE 0.063 -> 0.060, issue 16), while this one
    removes the step at every reversal of :math:`\\dot d`.

    When a joint backlash is already applied, the piston velocity is the backlash state's rate
    (:func:`piston_path`). Both :math:`F_c \\ge 0` (in the convention where the damper force is
    positive with the velocity) and the switching velocity :math:`\\varepsilon` (input units / s) are
    fitted. The measured output is unchanged by it in the Lyapunov argument (an output term).

    Initial guess: :math:`\\varepsilon = 0.02\\max|\\dot d|`; :math:`F_c` by least squares of the residual on
    :math:`[1, \\tanh(\\dot d/\\varepsilon)]` (at least 0).
    """

    name: str = "seal-friction"
    prefix: str = "seal_"
    physics: str = (
        "piston seal friction: a force of constant magnitude opposing the piston velocity d', added to "
        "the measured force (on the piston, not inside the fluid model; see coulomb-friction)"
    )
    signature: str = (
        "step of the residual at every reversal of the piston velocity d', flat in between "
        "(odd in d', independent of the force level)"
    )
    form: str = "y += seal_F * tanh(d_dot / seal_eps)"
    guess: str = "eps = 2 % of max|d'|; F = least squares of the residual on [1, tanh(d'/eps)], >= 0"

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec(
                f"{self.prefix}F",
                "F_{c}",
                0.0,
                0.0,
                1e9,
                unit="output unit",
                scale=0.1,
                description="seal friction force",
            ),
            ParamSpec(
                f"{self.prefix}eps",
                r"\varepsilon_{s}",
                0.1,
                1e-6,
                1e9,
                unit="input unit / s",
                scale=0.1,
                description="piston velocity at which the friction is 76 % developed (tanh 1)",
            ),
        )

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        _piston(self, model, 1)
        _, v = piston_path(model)
        F, eps = self.parameters()
        return model.extend(effect=self.name, params=(F, eps), output_add=F.symbol * sp.tanh(v / eps.symbol))

    def initial_guess(self, record, y_model) -> dict[str, float]:
        r = residual(record, y_model)
        v = np.asarray(record.velocity(), dtype=float)
        eps = SEAL_EPS_FRACTION * (float(np.max(np.abs(v))) or 1.0)
        _, c = lstsq_coeffs(r, np.ones_like(v), np.tanh(v / eps))
        return {
            f"{self.prefix}F": self._clip(f"{self.prefix}F", max(c, 0.0)),
            f"{self.prefix}eps": self._clip(f"{self.prefix}eps", eps),
        }

    def base_output(self, y, record, params):
        v = np.asarray(record.velocity(), dtype=float)
        return y - params[f"{self.prefix}F"] * np.tanh(v / params[f"{self.prefix}eps"])

    def record_bounds(self, record) -> dict[str, tuple[float, float]]:
        """``seal_eps`` between ``SEAL_EPS_RANGE`` of the record's largest piston speed: above it the tanh is
        a straight line over the record (a viscous term, which ``parallel-damping`` is), below it a step
        sharper than the sampling resolves; ``seal_eps`` can then not run off (5e7 on a real seal record)."""
        vmax = float(np.max(np.abs(np.asarray(record.velocity(), dtype=float)))) or 1.0
        lo, hi = SEAL_EPS_RANGE
        return {f"{self.prefix}eps": (lo * vmax, hi * vmax)}

    def record_scales(self, record) -> dict[str, float]:
        """``seal_F``: a tenth of the force's spread. On the Dyke slice (840 N RMS) the fixed scale 0.1 put the
        fitted 333 N at 3300 in the NLP, and the candidate took 73 s to the optimum it reaches in 7 s scaled. The
        switching velocity keeps its fixed scale: scaled to the record's speeds (a fiftieth of the largest), the
        fit of an independent O(1) record took 186 IPOPT iterations instead of 34, to the same optimum."""
        spread = float(np.std(np.asarray(record.y, dtype=float))) or 1.0
        return {f"{self.prefix}F": 0.1 * spread}

    def activity(self, record, params, stderr=None) -> str:
        v = np.asarray(record.velocity(), dtype=float)
        F, eps = float(params[f"{self.prefix}F"]), float(params[f"{self.prefix}eps"])
        why = switch_inactivity(record, F * np.tanh(v / eps), f"{self.prefix}eps", eps, "a friction")
        return why or _not_significant(f"{self.prefix}F", params, stderr or {})


def switch_inactivity(record, force: np.ndarray, eps_name: str, eps: float, kind: str) -> str:
    """Why a force that switches with the piston velocity (``tanh(d'/eps)``) does nothing on ``record``: its RMS
    below :data:`NEGLIGIBLE` of the measured force's spread, or its switch flat over the record (``eps`` at least
    half the largest piston speed: a viscous term rather than ``kind``); "" otherwise."""
    size = float(np.sqrt(np.mean(np.asarray(force, dtype=float) ** 2)))
    scale = float(np.std(np.asarray(record.y, dtype=float))) or 1.0
    if size < NEGLIGIBLE * scale:
        return f"its force is negligible (RMS {size:.3g}, {100 * size / scale:.2g} % of the force's spread)"
    vmax = float(np.max(np.abs(np.asarray(record.velocity(), dtype=float)))) or 1.0
    if eps >= 0.5 * vmax:
        return (
            f"its switch is flat over the record ({eps_name} = {eps:.3g} against max|d'| = {vmax:.3g}): "
            f"the tanh is nearly linear there, a viscous term rather than {kind}"
        )
    return ""


@dataclass(frozen=True)
class PressureForce(Effect):
    """The force of a measured pressure on the piston: :math:`y \\leftarrow y + A_p\\,p` with ``p`` the record's
    ``pressure`` column (its command history) and :math:`A_p` the effective piston area (force per pressure unit).

    Where it acts: on the piston, beside the seal friction the element describes; a pneumatic actuator's load cell
    measures the chamber pressure's force plus the friction. Passive in the sense of the certificate: a force that
    does not depend on the motion adds no state and no energy term (the element's Lyapunov argument is unchanged;
    the equilibrium only shifts with the pressure).

    Outside the catalogue (it needs a pressure column, and every ladder would otherwise try it): used with
    ``apply_effects`` and by campaign fits over pressures (``benchmarks/bench_seal_campaign.py``).

    Initial guess: least squares of the residual on the pressure (with a constant).
    """

    name: str = "pressure-force"
    prefix: str = "pf_"
    physics: str = "force of the measured chamber pressure on the piston area (pneumatic actuator)"
    signature: str = "the force level shifts with the pressure from record to record"
    form: str = "y += pf_A p"
    guess: str = "pf_A = least squares of the residual on the pressure"

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec(
                f"{self.prefix}A",
                "A_{p}",
                0.0,
                -1e12,
                1e12,
                unit="output unit per pressure unit",
                scale=1.0,
                description="effective piston area (force per unit pressure)",
            ),
        )

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        (a,) = self.parameters()
        ch = InputChannel("command", 0)
        extra = () if ch.symbol in {c.symbol for c in model.inputs} else (ch,)
        return model.extend(effect=self.name, params=(a,), inputs=extra, output_add=a.symbol * ch.symbol)

    def initial_guess(self, record, y_model) -> dict[str, float]:
        r = residual(record, y_model)
        p = np.asarray(record.command_signal(), dtype=float)
        _, c = lstsq_coeffs(r, np.ones_like(p), p)
        return {f"{self.prefix}A": self._clip(f"{self.prefix}A", c)}

    def base_output(self, y, record, params):
        return y - params[f"{self.prefix}A"] * np.asarray(record.command_signal(), dtype=float)
