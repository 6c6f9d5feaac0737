"""CasADi functions generated from a model (used by identification)."""

from __future__ import annotations

from functools import lru_cache

import sympy as sp

from duffsym.codegen._printing import check_numeric_structure
from duffsym.model.core import SymbolicModel


def _casadi_modules():
    import casadi as ca

    return {
        "sin": ca.sin,
        "cos": ca.cos,
        "tan": ca.tan,
        "exp": ca.exp,
        "log": ca.log,
        "sqrt": ca.sqrt,
        "tanh": ca.tanh,
        "sinh": ca.sinh,
        "cosh": ca.cosh,
        "atan": ca.atan,
        "arctan": ca.atan,
        "Abs": ca.fabs,
        "sign": ca.sign,
        "Max": ca.fmax,
        "Min": ca.fmin,
        "Heaviside": lambda z: ca.if_else(z > 0, 1, 0),
        "erf": ca.erf,
    }


def to_casadi(exprs, symbols, casadi_args):
    """Evaluate SymPy ``exprs`` with ``symbols`` replaced by CasADi symbols ``casadi_args``."""
    import casadi as ca

    fn = sp.lambdify(symbols, exprs, modules=[_casadi_modules()], cse=True)
    out = fn(*casadi_args)
    if isinstance(out, (list, tuple)):
        return ca.vertcat(*[ca.SX(o) if not isinstance(o, (ca.SX, ca.MX)) else o for o in out])
    return out


@lru_cache(maxsize=64)
def casadi_functions(model: SymbolicModel):
    """``(rhs, output)`` as CasADi Functions with named inputs ``x, u, p``.

    ``rhs(x, u, p) -> xdot`` and ``output(x, u, p) -> y``; vectors ordered as the model's tuples.
    """
    import casadi as ca

    check_numeric_structure(model)
    x = ca.SX.sym("x", model.n_states)
    u = ca.SX.sym("u", model.n_inputs)
    p = ca.SX.sym("p", model.n_params)
    symbols = [*model.states, *model.input_symbols, *model.param_symbols]
    cargs = [*ca.vertsplit(x), *ca.vertsplit(u), *ca.vertsplit(p)]
    xdot = to_casadi(list(model.rhs), symbols, cargs)
    y = to_casadi([model.output], symbols, cargs)
    rhs = ca.Function("rhs", [x, u, p], [xdot], ["x", "u", "p"], ["xdot"])
    out = ca.Function("output", [x, u, p], [y], ["x", "u", "p"], ["y"])
    return rhs, out
