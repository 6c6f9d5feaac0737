r"""Lyapunov functions of the Duffing-like models (Eq. 6–9 of the paper), derived from the model.

Two routes give the paper's function, and both are computed here from the symbolic model:

* **state-based** (Eq. 6): from the state-space form (Eq. 4 or 13). The damping is removed from
  ``A`` (the velocity-feedback entry) and ``f`` (the part vanishing at rest); the remaining
  conservative linear part has a quadratic first integral :math:`\tfrac12\mathbf x^\top P\mathbf x`
  whose ``P`` solves :math:`PA_c + A_c^\top P = 0` (normalised to :math:`P_{22} = 1`), and the
  conservative nonlinear part adds :math:`-\int_0^{x_1} f_2(s, 0)\,ds`.
* **energy-based** (Eq. 8): kinetic plus potential energy,
  :math:`\tfrac12\dot x^2 + \int_0^x R(s)\,ds`, with the restoring force :math:`R(x)` read off the
  equation of motion.

The time derivative along the model's own right-hand side (chain rule) gives Eq. 7/9.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from duffsym.derive._mechanics import Mechanics, mechanics, split_terms, tidy
from duffsym.model.core import SymbolicModel
from duffsym.model.statespace import state_space


@dataclass(frozen=True)
class DissipationTerm:
    """One additive term of the dissipative force and its share of :math:`\\dot V`.

    Attributes
    ----------
    force : the term of :math:`D(x, \\dot x)` (the acceleration contains ``-force``).
    contribution : its contribution ``-v * force`` to :math:`\\dot V`.
    coefficient : the parameter factor ``c`` of ``force = c * shape``.
    shape_nonnegative : whether ``v * shape`` is >= 0 for every state (None: undecided).
    assumptions : parameters assumed positive inside ``shape`` to decide it.
    condition : sufficient condition for ``contribution <= 0`` (``c >= 0``) or None.
    """

    force: sp.Expr
    contribution: sp.Expr
    coefficient: sp.Expr
    shape_nonnegative: bool | None
    assumptions: tuple[sp.Symbol, ...] = ()
    condition: sp.Basic | None = None

    def text(self) -> str:
        if self.shape_nonnegative is None:
            return f"{sp.sstr(self.contribution)}: sign not decided"
        if self.shape_nonnegative is False:
            return f"{sp.sstr(self.contribution)}: changes sign with the state"
        extra = ""
        if self.assumptions:
            extra = " (taking " + ", ".join(f"{a} > 0" for a in self.assumptions) + ")"
        return f"{sp.sstr(self.contribution)} <= 0 when {sp.sstr(self.condition)}{extra}"


@dataclass(frozen=True)
class LyapunovAnalysis:
    """The paper's Lyapunov functions for one model and their time derivatives.

    Attributes
    ----------
    model : the analysed model.
    x, v : position and velocity symbols (the paper's :math:`x, \\dot x`).
    restoring : :math:`R(x)`, the restoring force per unit mass.
    dissipative : :math:`D(x, \\dot x)`, the dissipative force (zero at rest).
    forcing : :math:`F`, the input force (``k1*d + c1*d_dot`` for Eq. 3 and 12).
    coupling : force from states added by effects (0 for the paper's models).
    P : the 2x2 matrix of the quadratic part of the state-based function.
    v_state : Eq. 6, from the state-space form.
    v_energy : Eq. 8, kinetic plus potential energy.
    identical : whether Eq. 6 and Eq. 8 simplify to the same expression.
    v_dot : :math:`\\dot V` along the unforced dynamics (Eq. 7/9).
    v_dot_forced : :math:`\\dot V` along the forced dynamics (adds ``F * v``).
    dissipation_terms : the per-term contributions to :math:`\\dot V`.
    """

    model: SymbolicModel
    x: sp.Symbol
    v: sp.Symbol
    restoring: sp.Expr
    dissipative: sp.Expr
    forcing: sp.Expr
    coupling: sp.Expr
    P: sp.Matrix
    v_state: sp.Expr
    v_energy: sp.Expr
    identical: bool
    v_dot: sp.Expr
    v_dot_forced: sp.Expr
    dissipation_terms: tuple[DissipationTerm, ...] = field(default=())

    @property
    def potential(self) -> sp.Expr:
        """:math:`\\int_0^x R(s)\\,ds`."""
        return tidy(self.v_energy - self.v**2 / 2)

    def summary(self) -> str:
        lines = [
            f"Lyapunov analysis of model {self.model.name}",
            f"  restoring force R(x)      = {sp.sstr(self.restoring)}",
            f"  dissipative force D(x,x') = {sp.sstr(self.dissipative)}",
            f"  input force F             = {sp.sstr(self.forcing)}",
        ]
        if self.coupling != 0:
            lines.append(f"  coupling to extra states  = {sp.sstr(self.coupling)}")
        lines += [
            f"  Eq. 6 (state-based)  V = {sp.sstr(self.v_state)}",
            f"  Eq. 8 (energy-based) V = {sp.sstr(self.v_energy)}",
            f"  identical: {self.identical}",
            f"  Eq. 7/9 dV/dt (unforced) = {sp.sstr(self.v_dot)}",
            f"  dV/dt (forced)           = {sp.sstr(self.v_dot_forced)}",
        ]
        lines += [f"    term {t.text()}" for t in self.dissipation_terms]
        return "\n".join(lines)


def _integrate_from_zero(expr: sp.Expr, x: sp.Symbol) -> sp.Expr:
    s = sp.Dummy("s", real=True)
    out = sp.integrate(expr.xreplace({x: s}), (s, 0, x))
    if isinstance(out, sp.Piecewise):  # symbolic powers: n is a positive integer, drop the n = -1 branch
        out = out.args[0][0]
    return tidy(out)


def state_based_lyapunov(model: SymbolicModel) -> tuple[sp.Expr, sp.Matrix]:
    r"""Eq. 6 from the state-space form: :math:`V = \tfrac12\mathbf x^\top P\mathbf x - \int_0^{x_1} f_2(s,0)\,ds`.

    Returns
    -------
    (V, P) : the function of ``(x1, x2)`` and the 2x2 matrix of its quadratic part.
    """
    mech = mechanics(model)
    ss = state_space(model)
    states = list(model.states)
    i, j = states.index(mech.x), states.index(mech.v)
    # the conservative linear part: drop the velocity feedback (the linear damping) of the velocity row
    A_c = sp.Matrix([[ss.A[i, i], ss.A[i, j]], [ss.A[j, i], 0]])
    p11, p12 = sp.symbols("p11 p12")
    P = sp.Matrix([[p11, p12], [p12, 1]])
    eqs = [e for e in (P * A_c + A_c.T * P) if e != 0]
    sol = sp.solve(eqs, [p11, p12], dict=True)
    P = P.subs(sol[0]) if sol else P
    # the conservative nonlinear part: f at rest (no velocity, inputs, extra states)
    rest = {mech.v: 0, **dict.fromkeys(mech.inputs, 0), **dict.fromkeys(mech.extra_states, 0)}
    f2 = ss.f[j].xreplace(rest)
    xv = sp.Matrix([mech.x, mech.v])
    V = (xv.T * P * xv)[0] / 2 - _integrate_from_zero(f2, mech.x)
    return tidy(V), P


def energy_lyapunov(model: SymbolicModel) -> sp.Expr:
    r"""Eq. 8: :math:`V = \tfrac12\dot x^2 + \int_0^x R(s)\,ds` with R read off the equation of motion."""
    mech = mechanics(model)
    return tidy(mech.v**2 / 2 + _integrate_from_zero(mech.restoring, mech.x))


def time_derivative(model: SymbolicModel, V: sp.Expr, *, forced: bool = False) -> sp.Expr:
    r""":math:`\dot V = \nabla V\cdot\mathbf{rhs}` along the model's dynamics (inputs zero unless ``forced``)."""
    mech = mechanics(model)
    zero_u = {} if forced else {u: sp.Integer(0) for u in mech.inputs}
    total = sum((sp.diff(V, s) * e.xreplace(zero_u) for s, e in zip(model.states, model.rhs)), sp.Integer(0))
    return tidy(total)


def _classify(mech: Mechanics, term: sp.Expr) -> DissipationTerm:
    v = mech.v
    coeff, shape = term.as_independent(*mech.signals, as_Add=False)
    power = tidy(v * shape)
    pos = sp.Dummy("p", positive=True)
    assumed: tuple[sp.Symbol, ...] = ()
    decided = None
    for attempt in range(2):
        expr = power
        if attempt == 1:
            params = tuple(sorted((power.free_symbols - set(mech.signals) - set(mech.structural_symbols)), key=str))
            if not params:
                break
            expr = power.xreplace({p: sp.Dummy(str(p), positive=True) for p in params})
            assumed = params
        others = {s: sp.Dummy(str(s), real=True) for s in expr.free_symbols if s in mech.signals and s != v}
        e = expr.xreplace(others)
        at_pos, at_neg = e.xreplace({v: pos}), e.xreplace({v: -pos})
        if at_pos.is_nonnegative and at_neg.is_nonnegative:
            decided = True
            break
        if (at_pos.is_negative or at_neg.is_negative) and at_pos.is_nonnegative is not None:
            decided = False
            break
    if decided is not True:
        assumed = ()
    return DissipationTerm(
        force=term,
        contribution=sp.Mul(-1, coeff, power),
        coefficient=coeff,
        shape_nonnegative=decided,
        assumptions=assumed,
        condition=(coeff >= 0) if decided else None,
    )


def lyapunov_analysis(model: SymbolicModel) -> LyapunovAnalysis:
    """Both Lyapunov functions (Eq. 6, 8) of ``model`` and their time derivatives (Eq. 7, 9).

    Works for integer powers and for the symbolic odd power ``N_SYMBOL``, and for models extended
    by effects (the analysis is on the mechanical pair; extra forces appear as extra terms of
    :math:`\\dot V`).
    """
    mech = mechanics(model)
    v_state, P = state_based_lyapunov(model)
    v_energy = energy_lyapunov(model)
    identical = sp.simplify(v_state - v_energy) == 0
    v_dot = time_derivative(model, v_energy)
    v_dot_forced = time_derivative(model, v_energy, forced=True)
    terms = tuple(_classify(mech, c * m) for m, c in split_terms(mech.dissipative, mech.signals).items())
    return LyapunovAnalysis(
        model=model,
        x=mech.x,
        v=mech.v,
        restoring=mech.restoring,
        dissipative=mech.dissipative,
        forcing=mech.forcing,
        coupling=mech.coupling,
        P=P,
        v_state=v_state,
        v_energy=v_energy,
        identical=bool(identical),
        v_dot=v_dot,
        v_dot_forced=v_dot_forced,
        dissipation_terms=terms,
    )
