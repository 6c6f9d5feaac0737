"""Split a model's acceleration into restoring, dissipative, forcing and coupling forces.

Every derivation in :mod:`duffsym.derive` starts here. The model's velocity equation
:math:`\\dot x_2 = a(x_1, x_2, \\mathbf z, \\mathbf u)` (``z``: states added by effects, ``u``: inputs)
is split, without any knowledge of the paper's parameter names, into

.. math::
    a = -R(x_1) - D(x_1, x_2) + F(\\ldots, \\mathbf u) + K(x_1, x_2, \\mathbf z)

with :math:`R(x) = -a(x, 0, 0, 0)` (restoring force), :math:`D = -(a(x, \\dot x, 0, 0) - a(x, 0, 0, 0))`
(dissipative force, zero at rest), :math:`F = a - a|_{\\mathbf u = 0}` (forcing by the inputs) and
:math:`K = a|_{\\mathbf u=0} - a|_{\\mathbf u = 0, \\mathbf z = 0}` (coupling to extra states).
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from functools import lru_cache

import sympy as sp
from sympy.printing.str import StrPrinter

from duffsym.errors import ModelError
from duffsym.model.core import SymbolicModel


def tidy(expr: sp.Expr) -> sp.Expr:
    """Expanded form with powers of one base merged (``x*x**n -> x**(n+1)``)."""
    return sp.powsimp(sp.expand(expr), combine="exp")


@dataclass(frozen=True)
class Mechanics:
    """The mechanical pair of a model and the forces acting on it (per unit mass)."""

    model: SymbolicModel
    x: sp.Symbol
    v: sp.Symbol
    acceleration: sp.Expr
    restoring: sp.Expr
    dissipative: sp.Expr
    forcing: sp.Expr
    coupling: sp.Expr
    extra_states: tuple[sp.Symbol, ...]
    inputs: tuple[sp.Symbol, ...]

    @property
    def signals(self) -> tuple[sp.Symbol, ...]:
        return tuple(self.model.states) + self.inputs

    @property
    def structural_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(v for _, v in self.model.structural if isinstance(v, sp.Symbol))


def _is_zero(expr: sp.Expr) -> bool:
    """Whether ``expr`` is identically zero. A value clearly off zero at a point (30 digits, all symbols at
    0.3-1.7) disproves it at once; only an expression that vanishes there is simplified to prove it. (An
    effect that changed the kinematics made ``simplify`` run for minutes on the play's switches, to the
    same answer.)"""
    if expr == 0:
        return True
    rng = random.Random(0)
    point = {s: sp.Float(rng.uniform(0.3, 1.7), 30) for s in sorted(expr.free_symbols, key=str)}
    value = sp.N(expr.xreplace(point), 30)
    if value.is_number and value.is_comparable and abs(value) > 1e-20:
        return False
    return sp.simplify(expr) == 0


@lru_cache(maxsize=64)
def mechanics(model: SymbolicModel) -> Mechanics:
    """The force decomposition of ``model``'s velocity equation.

    Raises
    ------
    ModelError
        If the model has no mechanical pair, or its position equation is not :math:`\\dot x_1 = x_2`.
    """
    if model.position is None or model.velocity is None:
        raise ModelError(
            f"model {model.name} has no mechanical pair (position, velocity); the Lyapunov and energy "
            "derivations need one: build the model with from_second_order or set position/velocity"
        )
    x, v = model.position, model.velocity
    states = list(model.states)
    if not _is_zero(model.rhs[states.index(x)] - v):
        raise ModelError(
            f"model {model.name}: the position equation is d{x}/dt = {model.rhs[states.index(x)]}, not {v}; "
            "the derivations assume x' = v (an effect must not change the kinematics)"
        )
    acc = model.rhs[states.index(v)]
    inputs = tuple(model.input_symbols)
    extra = tuple(s for s in states if s not in (x, v))
    zero_u = {u: sp.Integer(0) for u in inputs}
    zero_z = {z: sp.Integer(0) for z in extra}
    unforced = acc.xreplace(zero_u)
    base = unforced.xreplace(zero_z)
    at_rest = base.xreplace({v: sp.Integer(0)})
    return Mechanics(
        model=model,
        x=x,
        v=v,
        acceleration=acc,
        restoring=tidy(-at_rest),
        dissipative=tidy(-(base - at_rest)),
        forcing=tidy(acc - unforced),
        coupling=tidy(unforced - base),
        extra_states=extra,
        inputs=inputs,
    )


def split_terms(expr: sp.Expr, variables, *, form=sp.factor_terms) -> dict[sp.Expr, sp.Expr]:
    """``{monomial: coefficient}`` of an expression: each term's factor that depends on ``variables``
    (the monomial, 1 for constants) and its coefficient free of them, like terms summed, zero ones dropped.

    ``form`` writes each coefficient: ``-(c1 + c2)*x2 - c3*x2**5 + k1*d`` in ``(x2, d)`` ->
    ``{x2: -(c1 + c2), x2**5: -c3, d: k1}`` with the default :func:`sympy.factor_terms`, ``{x2: -c1 - c2, ...}``
    with :func:`sympy.simplify` (the SINDy candidate library's form). The one term splitter of the package
    (derivations and the SINDy candidate library).
    """
    out: dict[sp.Expr, sp.Expr] = {}
    for term in sp.Add.make_args(tidy(expr)):
        coeff, dep = term.as_independent(*variables, as_Add=False)
        out[dep] = out.get(dep, sp.Integer(0)) + coeff
    return {k: form(c) for k, c in out.items() if sp.simplify(c) != 0}


def power_of(monomial: sp.Expr, var: sp.Symbol):
    """Exponent e when ``monomial`` is ``var**e`` (or 1 -> 0, var -> 1), else None."""
    if monomial == 1:
        return sp.Integer(0)
    if monomial == var:
        return sp.Integer(1)
    if isinstance(monomial, sp.Pow) and monomial.base == var and not monomial.exp.has(var):
        return monomial.exp
    return None


class _LogicTextPrinter(StrPrinter):
    """Conditions for people: ``a != 0 or b != 0`` instead of ``Ne(a, 0) | Ne(b, 0)`` (text output only;
    JSON keeps SymPy's parseable form)."""

    def _print_Unequality(self, expr):
        return f"{self._print(expr.lhs)} != {self._print(expr.rhs)}"

    def _print_Equality(self, expr):
        return f"{self._print(expr.lhs)} = {self._print(expr.rhs)}"

    def _join(self, expr, word):
        parts = [self._print(a) for a in expr.args]
        return f" {word} ".join(f"({p})" if (" and " in p or " or " in p) else p for p in parts)

    def _print_And(self, expr):
        return self._join(expr, "and")

    def _print_Or(self, expr):
        return self._join(expr, "or")


def condition_text(expr) -> str:
    """Plain-text form of a SymPy condition (relations joined by and/or)."""
    return _LogicTextPrinter().doprint(expr)
