r"""Energy dissipated per cycle of the forced periodic steady state, and the loop area of the d–y plot.

Derived from the model (see :func:`energy_balance`):

1. Along the forced dynamics :math:`\dot V = -W(\dot x) + F\dot x` (``lyapunov.v_dot_forced``). Over one
   period T of a periodic steady state :math:`\oint\dot V\,dt = V(T) - V(0) = 0`, so

   .. math:: \oint F\dot x\,dt = \oint W\,dt = \oint(\gamma\dot x^2 + \delta\dot x^{n+1})\,dt \ge 0.

2. With :math:`F = k_1 d + c_1\dot d`, integration by parts (:math:`d\,x` is periodic) moves the
   derivative off x in the :math:`k_1 d\dot x` term:
   :math:`c_1\oint\dot x\dot d\,dt - k_1\oint x\dot d\,dt = \oint W\,dt`.
3. The loop area of the d–y plot is :math:`\oint y\,dd = A_f\oint\dot x\dot d\,dt`, hence
   :math:`\oint y\,dd = \tfrac{A_f}{c_1}\bigl(\oint W\,dt + k_1\oint x\dot d\,dt\bigr)`.
4. Linear limit (:math:`\beta = \delta = 0`), :math:`d = a\sin\omega t`: the steady state found by
   undetermined coefficients gives :math:`\oint y\,dd = A_f\pi a^2\omega\,\mathrm{Re}\,H(j\omega)`,
   :math:`H(s) = (c_1 s + k_1)/(s^2 + \gamma s + \alpha)`, the transfer function d -> x of the
   state-space form.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import sympy as sp

from duffsym._checks import require_increasing
from duffsym.derive._mechanics import mechanics, split_terms, tidy
from duffsym.derive.lyapunov import lyapunov_analysis
from duffsym.errors import DataError, ModelError
from duffsym.model.core import SymbolicModel
from duffsym.model.statespace import state_space
from duffsym.plot.loops import cycle_integral

TIME = sp.Symbol("t", real=True)
PERIOD = sp.Symbol("T", positive=True)
AMPLITUDE = sp.Symbol("a", positive=True)
OMEGA = sp.Symbol("omega", positive=True)


def _cycle(expr: sp.Expr) -> sp.Integral:
    return sp.Integral(expr, (TIME, 0, PERIOD))


@dataclass(frozen=True)
class EnergyBalance:
    """The per-cycle energy identities of a model, derived symbolically.

    Attributes
    ----------
    input_power : :math:`F\\dot x` in the model's symbols.
    dissipation : :math:`W`, with :math:`\\dot V = -W + F\\dot x`.
    balance : ``Eq(cycle integral of F x', cycle integral of W)`` (time functions x(t), d(t)).
    by_parts : ``[(coefficient, integrand)]``: :math:`\\oint F\\dot x\\,dt = \\sum c\\oint g\\,dt` after
        integration by parts (no derivative of x multiplies an undifferentiated input).
    by_parts_equation : ``Eq(sum of c * cycle integral of g, cycle integral of W)``.
    loop_area_integrand : :math:`y\\,\\dot d` (the loop area is its cycle integral).
    loop_area_equation : the loop area in terms of the other cycle integrals (None when the output
        is not proportional to a term of the by-parts sum).
    """

    model: SymbolicModel
    input_power: sp.Expr
    dissipation: sp.Expr
    balance: sp.Eq
    by_parts: tuple[tuple[sp.Expr, sp.Expr], ...]
    by_parts_equation: sp.Eq
    loop_area_integrand: sp.Expr
    loop_area_equation: sp.Eq | None

    def summary(self) -> str:
        lines = [
            f"energy per cycle of the periodic steady state, model {self.model.name}",
            f"  dV/dt = -W + F x',  W = {sp.sstr(self.dissipation)},  F x' = {sp.sstr(self.input_power)}",
            f"  cycle balance:   {sp.sstr(self.balance.lhs)} = {sp.sstr(self.balance.rhs)}",
            f"  by parts:        {sp.sstr(self.by_parts_equation.lhs)} = {sp.sstr(self.by_parts_equation.rhs)}",
        ]
        if self.loop_area_equation is not None:
            lines.append(
                f"  loop area:       {sp.sstr(self.loop_area_equation.lhs)} = {sp.sstr(self.loop_area_equation.rhs)}"
            )
        return "\n".join(lines)


def _as_time_functions(model: SymbolicModel):
    """Substitutions of the states and inputs by functions of time (inputs' derivatives as derivatives)."""
    mech = mechanics(model)
    xf = sp.Function("x", real=True)(TIME)
    subs = {mech.x: xf, mech.v: sp.diff(xf, TIME)}
    funcs: dict[str, sp.Expr] = {}
    for ch in model.inputs:
        f = funcs.setdefault(ch.signal, sp.Function(ch.signal, real=True)(TIME))
        subs[ch.symbol] = sp.diff(f, TIME, ch.order) if ch.order else f
    return subs, xf


def _by_parts(expr: sp.Expr, xf: sp.Expr) -> sp.Expr:
    r"""Integrate each term ``u * x'`` by parts over a period, where ``u`` has no derivative:
    :math:`\oint u\dot x\,dt = -\oint \dot u\,x\,dt` (the boundary term ``u x`` is periodic)."""
    xd = sp.diff(xf, TIME)
    out = sp.Integer(0)
    for term in sp.Add.make_args(sp.expand(expr)):
        rest = term / xd
        if term.has(xd) and not rest.has(xd) and not rest.has(sp.Derivative) and not rest.has(xf):
            out += -sp.diff(rest, TIME) * xf
        else:
            out += term
    return sp.expand(out)


def energy_balance(model: SymbolicModel) -> EnergyBalance:
    """Derive the per-cycle energy identities of ``model`` (see the module docs)."""
    lya = lyapunov_analysis(model)
    if lya.coupling != 0:
        raise ModelError(
            f"model {model.name} couples extra states into the mechanics ({lya.coupling}); the cycle energy "
            "balance of V covers the mechanical pair only: analyse the base model or include the extra energy"
        )
    v = lya.v
    W = tidy(v * lya.dissipative)
    Fv = tidy(v * lya.forcing)
    # check: the derived forced dV/dt is exactly -W + F v
    if tidy(lya.v_dot_forced - (-W + Fv)) != 0:  # pragma: no cover - guards the derivation
        raise ModelError(f"model {model.name}: dV/dt is not -W + F x' ({lya.v_dot_forced})")
    subs, xf = _as_time_functions(model)
    Fv_t, W_t = Fv.xreplace(subs), W.xreplace(subs)
    balance = sp.Eq(_cycle(Fv_t), _cycle(W_t))
    parts = _by_parts(Fv_t, xf)
    groups = split_terms(parts, tuple(a for a in parts.atoms(sp.Function, sp.Derivative)))
    by_parts = tuple((c, g) for g, c in groups.items())
    lhs = sum((c * _cycle(g) for c, g in by_parts), sp.Integer(0))
    by_parts_eq = sp.Eq(lhs, _cycle(W_t))
    # loop area: cycle integral of y dd = y * d'(t) dt, with the input signal's displacement channel
    disp = [ch for ch in model.inputs if ch.order == 0]
    loop_eq = None
    loop_integrand = sp.Integer(0)
    if disp:
        d_t = subs[disp[0].symbol]
        loop_integrand = tidy(model.output.xreplace(subs) * sp.diff(d_t, TIME))
        # the output as a multiple of one by-parts integrand: y d' = k * g  ->  loop = k * cycle g
        for c, g in by_parts:
            if c == 0:
                continue
            ratio = sp.simplify(loop_integrand / g)
            if not ratio.has(TIME) and ratio != 0:
                others = sum((c2 * _cycle(g2) for c2, g2 in by_parts if g2 is not g), sp.Integer(0))
                loop_eq = sp.Eq(_cycle(loop_integrand), ratio / c * (_cycle(W_t) - others))
                break
    return EnergyBalance(
        model=model,
        input_power=Fv,
        dissipation=W,
        balance=balance,
        by_parts=by_parts,
        by_parts_equation=by_parts_eq,
        loop_area_integrand=loop_integrand,
        loop_area_equation=loop_eq,
    )


@dataclass(frozen=True)
class LinearLoopArea:
    """Closed-form loop area of the linear limit under :math:`d = a\\sin\\omega t`.

    Attributes
    ----------
    transfer : H(s), input displacement -> x, from the state-space matrices.
    steady_state : x(t) found by undetermined coefficients.
    loop_area : the cycle integral of y dd, integrated symbolically from ``steady_state``.
    closed_form : :math:`A_f\\pi a^2\\omega\\,\\mathrm{Re}H(j\\omega)`; equal to ``loop_area``.
    equal : whether the two simplify to the same expression.
    """

    transfer: sp.Expr
    steady_state: sp.Expr
    loop_area: sp.Expr
    closed_form: sp.Expr
    equal: bool

    def summary(self) -> str:
        return (
            f"linear limit, d = a sin(omega t): H(s) = {sp.sstr(self.transfer)}\n"
            f"  loop area = {sp.sstr(self.loop_area)}\n"
            f"  A_f pi a^2 omega Re H(j omega) = {sp.sstr(self.closed_form)}  (equal: {self.equal})"
        )


def linear_loop_area(model: SymbolicModel) -> LinearLoopArea:
    """Derive the loop area of the model's linear limit (nonlinear part f of the state-space form dropped)."""
    mech = mechanics(model)
    if mech.extra_states:
        raise ModelError(f"linear_loop_area needs the plain second-order model; {model.name} has extra states")
    disp = [ch for ch in model.inputs if ch.order == 0]
    if not disp:
        raise ModelError(f"model {model.name} has no displacement input channel")
    ss = state_space(model)
    s = sp.Symbol("s")
    # transfer d -> x: inputs are d and its derivatives, so u = [s^order] * D(s)
    u_of_s = sp.Matrix([s**ch.order if ch.signal == disp[0].signal else 0 for ch in model.inputs])
    X = (s * sp.eye(ss.A.shape[0]) - ss.A).LUsolve(ss.B * u_of_s)
    H = sp.factor(sp.simplify(X[list(model.states).index(mech.x)]))
    # linear limit: drop the nonlinear part f; steady state by undetermined coefficients
    p, q = sp.symbols("p q", real=True)
    t, a, w = TIME, AMPLITUDE, OMEGA
    x_t = a * (p * sp.sin(w * t) + q * sp.cos(w * t))
    d_vals = {ch.symbol: sp.diff(a * sp.sin(w * t), t, ch.order) for ch in model.inputs}
    acc_lin = (ss.A * ss.x + ss.B * ss.u)[list(model.states).index(mech.v)]
    resid = sp.expand(sp.diff(x_t, t, 2) - acc_lin.xreplace({mech.x: x_t, mech.v: sp.diff(x_t, t), **d_vals}))
    eqs = [resid.coeff(sp.sin(w * t)), resid.coeff(sp.cos(w * t))]
    sol = sp.solve(eqs, [p, q], dict=True)[0]
    x_ss = x_t.subs(sol)
    y_t = (ss.C * ss.x)[0].xreplace({mech.x: x_ss, mech.v: sp.diff(x_ss, t)})
    area = sp.simplify(sp.integrate(sp.expand(y_t * sp.diff(a * sp.sin(w * t), t)), (t, 0, 2 * sp.pi / w)))
    gain = sp.simplify((ss.C * ss.x)[0].coeff(mech.v))  # A_f
    closed = gain * sp.pi * a**2 * w * sp.re(sp.expand_complex(H.subs(s, sp.I * w)))
    equal = sp.simplify(area - closed) == 0
    return LinearLoopArea(
        transfer=H, steady_state=sp.simplify(x_ss), loop_area=area, closed_form=sp.simplify(closed), equal=bool(equal)
    )


# ----------------------------------------------------------------------------- numeric functions
def loop_area(t, d, y) -> float:
    r"""Area of the d–y loop, :math:`\oint y\,dd`, by the trapezoid rule over one period.

    Parameters
    ----------
    t : (n_times,) sample times of one period, s (strictly increasing).
    d : (n_times,) input displacement.
    y : (n_times,) output (force).

    Returns
    -------
    float : the signed area, positive for a clockwise loop: the work done on the damper per cycle
        (the energy it absorbs) when y is the force applied to the piston. The loop is closed from
        the last sample back to the first.
    """
    arrays = []
    for name, a in (("t", t), ("d", d), ("y", y)):
        a = np.asarray(a, dtype=float)
        if a.ndim != 1:
            raise DataError(f"loop_area: {name} must be 1-D (one period of samples); got shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise DataError(f"loop_area: {name} has non-finite values at index {np.flatnonzero(~np.isfinite(a))[0]}")
        arrays.append(a)
    t, d, y = arrays
    if not (t.size == d.size == y.size) or t.size < 3:
        raise DataError(f"loop_area: t, d, y must have the same length >= 3; got {t.size}, {d.size}, {y.size}")
    require_increasing(t, "loop_area: t")
    return cycle_integral(d, y)


@dataclass(frozen=True)
class CycleEnergy:
    """Energy quantities over the last full period of a simulated trajectory.

    Attributes
    ----------
    period : s.
    input_work : :math:`\\oint F\\dot x\\,dt` (per unit mass).
    dissipated : :math:`\\oint W\\,dt` (>= 0 for a passive parameter set).
    delta_v : :math:`V(t_0 + T) - V(t_0)` (0 in an exact periodic steady state).
    balance_residual : ``input_work - dissipated - delta_v`` (quadrature error only).
    by_parts : :math:`\\sum c\\oint g\\,dt`, the by-parts form of ``input_work``.
    loop_area : :math:`\\oint y\\,dd`.
    loop_area_predicted : the loop area from the derived relation (None if none was derived).
    integrals : each by-parts cycle integral by its text.
    """

    period: float
    input_work: float
    dissipated: float
    delta_v: float
    balance_residual: float
    by_parts: float
    loop_area: float
    loop_area_predicted: float | None
    integrals: dict[str, float]

    def summary(self) -> str:
        lines = [
            f"cycle energy over T = {self.period:g} s:",
            f"  input work   {self.input_work:.6g}",
            f"  dissipated   {self.dissipated:.6g}",
            f"  V(T) - V(0)  {self.delta_v:.3g}",
            f"  residual     {self.balance_residual:.3g}",
            f"  by parts     {self.by_parts:.6g}",
            f"  loop area    {self.loop_area:.6g}",
        ]
        if self.loop_area_predicted is not None:
            lines.append(f"  loop area from the identity {self.loop_area_predicted:.6g}")
        return "\n".join(lines)


def _periodic_integral(t: np.ndarray, values: np.ndarray) -> float:
    """The trapezoid rule over the samples, written out as NumPy's ``trapezoid`` (``trapz`` before NumPy 2)
    computes it, so it runs on every supported NumPy."""
    y = np.asarray(values)
    return float((np.diff(t) * (y[1:] + y[:-1]) / 2.0).sum())


def cycle_energy(traj, period: float, model: SymbolicModel) -> CycleEnergy:
    """Evaluate the derived energy identities on the last full period of a simulated trajectory.

    Parameters
    ----------
    traj : a :class:`~duffsym.simulate.Trajectory` of ``model`` that has reached its periodic
        steady state (simulate several periods; the transient decays like exp(-gamma t / 2)).
    period : the excitation period, s; the trajectory must span more than one period.
    model : the model that produced ``traj``.
    """
    from duffsym.simulate import steady_cycle

    if not (np.isfinite(period) and period > 0):
        raise DataError(f"period must be a positive finite number of seconds; got {period!r}")
    if traj.t[-1] - traj.t[0] < period * (1 - 1e-9):
        raise DataError(
            f"the trajectory spans {traj.t[-1] - traj.t[0]:g} s, less than one period ({period:g} s); simulate longer"
        )
    if traj.x.shape[1] != model.n_states:
        raise DataError(
            f"traj has {traj.x.shape[1]} states, model {model.name} has {model.n_states}; "
            "pass the model that produced the trajectory"
        )
    eb = energy_balance(model)
    lya = lyapunov_analysis(model)
    sl = steady_cycle(traj, period)
    t = traj.t[sl]
    X, U, Y = traj.x[sl], traj.u[sl], traj.y[sl]
    p = model.param_vector(traj.params)
    args = (*model.states, *model.input_symbols, *model.param_symbols)

    def evaluate(expr):
        f = sp.lambdify(args, expr, "numpy")
        return np.broadcast_to(np.asarray(f(*X.T, *U.T, *p), dtype=float), t.shape)

    subs, xf = _as_time_functions(model)
    back = {v: k for k, v in subs.items()}
    # time functions back to states/inputs: derivatives first (x'(t) -> x2, d'(t) -> d_dot)
    derivs = {k: v for k, v in back.items() if isinstance(k, sp.Derivative)}
    plain = {k: v for k, v in back.items() if not isinstance(k, sp.Derivative)}

    def to_signals(expr):
        return expr.subs(derivs).subs(plain)

    input_work = _periodic_integral(t, evaluate(eb.input_power))
    dissipated = _periodic_integral(t, evaluate(eb.dissipation))
    V = evaluate(lya.v_energy)
    delta_v = float(V[-1] - V[0])
    integrals, by_parts = {}, 0.0
    for c, g in eb.by_parts:
        val = _periodic_integral(t, evaluate(to_signals(g)))
        integrals[sp.sstr(g)] = val
        by_parts += float(sp.sympify(c).subs(dict(zip(model.param_symbols, p)))) * val
    disp = [ch for ch in model.inputs if ch.order == 0]
    area = loop_area(t, U[:, model.inputs.index(disp[0])], Y) if disp else float("nan")
    predicted = None
    if eb.loop_area_equation is not None:
        rhs = eb.loop_area_equation.rhs
        vals = {}
        for integral in rhs.atoms(sp.Integral):
            vals[integral] = _periodic_integral(t, evaluate(to_signals(integral.function)))
        predicted = float(rhs.xreplace(vals).subs(dict(zip(model.param_symbols, p))))
    return CycleEnergy(
        period=float(period),
        input_work=input_work,
        dissipated=dissipated,
        delta_v=delta_v,
        balance_residual=input_work - dissipated - delta_v,
        by_parts=by_parts,
        loop_area=area,
        loop_area_predicted=predicted,
        integrals=integrals,
    )


def linear_loop_area_value(
    params: Mapping[str, float], model: SymbolicModel, amplitude: float, frequency: float
) -> float:
    """The closed-form loop area of the linear limit for numeric parameters (``d = a sin(2 pi f t)``)."""
    lla = linear_loop_area(model)
    vals = {p.symbol: float(v) for p, v in zip(model.params, model.param_vector(dict(params), fill_defaults=True))}
    vals.update({AMPLITUDE: float(amplitude), OMEGA: 2 * np.pi * float(frequency)})
    return float(lla.closed_form.subs(vals))
