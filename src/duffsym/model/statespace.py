"""Extraction of the paper's state-space form (Eq. 4–5, 13–14) from a model's equations.

Each equation is split into additive terms. A term ``coefficient * s`` whose coefficient is free
of states and inputs and whose remaining factor is a single state (input) goes to A (B); every
other term goes to the nonlinear part f(x, u). The output is split the same way into C, D and h.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from duffsym.model.core import SymbolicModel


@dataclass(frozen=True)
class StateSpace:
    """:math:`\\dot{\\mathbf x} = A\\mathbf x + \\mathbf f(\\mathbf x, \\mathbf u) + B\\mathbf u`,
    :math:`y = C\\mathbf x + D\\mathbf u + h(\\mathbf x, \\mathbf u)`."""

    A: sp.Matrix
    f: sp.Matrix
    B: sp.Matrix
    C: sp.Matrix
    D: sp.Matrix
    h: sp.Expr
    x: sp.Matrix
    u: sp.Matrix

    def rhs(self) -> sp.Matrix:
        return self.A * self.x + self.f + self.B * self.u

    def output(self) -> sp.Expr:
        return (self.C * self.x)[0] + (self.D * self.u)[0] + self.h


def _split_linear(expr: sp.Expr, states, inputs):
    """(coefficients on states, coefficients on inputs, remainder) of one expression."""
    a = [sp.Integer(0)] * len(states)
    b = [sp.Integer(0)] * len(inputs)
    rest = sp.Integer(0)
    signals = tuple(states) + tuple(inputs)
    for term in sp.Add.make_args(sp.expand(expr)):
        coeff, dep = term.as_independent(*signals, as_Add=False)
        if dep in states:
            a[states.index(dep)] += coeff
        elif dep in inputs:
            b[inputs.index(dep)] += coeff
        else:
            rest += term
    return a, b, rest


def state_space(model: SymbolicModel) -> StateSpace:
    """The state-space matrices of ``model``, computed from its equations (never typed)."""
    states = list(model.states)
    inputs = list(model.input_symbols)
    rows_a, rows_b, f = [], [], []
    for expr in model.rhs:
        a, b, rest = _split_linear(expr, states, inputs)
        rows_a.append(a)
        rows_b.append(b)
        f.append(rest)
    c, d, h = _split_linear(model.output, states, inputs)
    return StateSpace(
        A=sp.Matrix(rows_a),
        f=sp.Matrix(f),
        B=sp.Matrix(rows_b),
        C=sp.Matrix([c]),
        D=sp.Matrix([d]),
        h=h,
        x=sp.Matrix(states),
        u=sp.Matrix(inputs),
    )
