"""Shared helpers to turn model expressions into code."""

from __future__ import annotations

import sympy as sp

from duffsym.model.core import SymbolicModel


def without_distributions(expr: sp.Expr) -> sp.Expr:
    """Replace DiracDelta (from differentiating sign/Heaviside) by 0: the derivative almost everywhere."""
    return expr.replace(lambda e: isinstance(e, sp.DiracDelta), lambda e: sp.Integer(0))


def state_jacobian(model: SymbolicModel) -> sp.Matrix:
    """:math:`\\partial\\,\\mathrm{rhs}/\\partial\\mathbf x`, generated from the model."""
    rhs = sp.Matrix(model.rhs)
    return rhs.jacobian(sp.Matrix(model.states)).applyfunc(without_distributions)


def param_jacobian(model: SymbolicModel) -> sp.Matrix:
    """:math:`\\partial\\,\\mathrm{rhs}/\\partial\\theta`, generated from the model."""
    rhs = sp.Matrix(model.rhs)
    return rhs.jacobian(sp.Matrix(model.param_symbols)).applyfunc(without_distributions)


def check_numeric_structure(model: SymbolicModel) -> None:
    """Numeric code needs every structural power to be a number."""
    from duffsym.errors import ModelError

    for name, value in model.structural:
        if isinstance(value, sp.Symbol):
            raise ModelError(
                f"model {model.name}: {name} is symbolic ({value}); numeric code needs a number, "
                "build the model with an integer power"
            )
