"""The second-order form shared by the models, and the paper's MR-damper element (Eq. 11/12).

:func:`from_second_order` turns a second-order equation in :math:`x, \\dot x, \\ddot x` into a
state-space model; :func:`mr_damper` is the element that :mod:`duffsym.model.library` registers and
extends (path time, command, field) and that :mod:`duffsym.model.structure` drives by default. Both
build on this module; the public names stay importable from :mod:`duffsym.model.library`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import sympy as sp

from duffsym.errors import ModelError
from duffsym.model.core import InputChannel, SymbolicModel
from duffsym.model.symbols import ParamSpec, param_symbol, state_symbol

# Symbols of the second-order equations (the paper's x, x', x'').
X, X_DOT, X_DDOT = state_symbol("x"), state_symbol("x_dot"), state_symbol("x_ddot")
X1, X2 = state_symbol("x1"), state_symbol("x2")
D = InputChannel("d", 0)
D_DOT = InputChannel("d", 1)
FORCE = InputChannel("F", 0)

#: Symbol for a general power n in symbolic derivations (odd positive integer).
N_SYMBOL = sp.Symbol("n", integer=True, positive=True, odd=True)


#: Largest structural power accepted (``fit --n 99999`` used to get far into the fit before failing).
MAX_POWER = 25


def check_power(name: str, n, *, allow_even: bool = False) -> int | sp.Symbol:
    """Validate a structural power: an odd positive integer (or a SymPy symbol for derivations)."""
    if isinstance(n, sp.Symbol):
        return n
    if (
        isinstance(n, bool)
        or not isinstance(n, (int, sp.Integer))
        and not (isinstance(n, float) and float(n).is_integer())
    ):
        raise ModelError(f"{name} must be a positive odd integer (Eq. 3 of the paper); got {n!r}")
    n = int(n)
    if n < 1:
        raise ModelError(f"{name} must be a positive odd integer (Eq. 3 of the paper); got {n}")
    if n > MAX_POWER:
        raise ModelError(
            f"{name} = {n} is above the largest supported power {MAX_POWER} (x^n overflows double "
            f"precision beyond |x| = 2^(1024/n); the paper uses 3 and 5); choose n <= {MAX_POWER}"
        )
    if n % 2 == 0 and not allow_even:
        raise ModelError(
            f"{name} must be odd (Eq. 3: x^n and x'^n must keep the sign of x and x'); got {n}; "
            f"use {n - 1} or {n + 1}, or pass allow_even=True to study why even powers fail"
        )
    return n


def from_second_order(
    name: str,
    equation: sp.Eq,
    *,
    inputs: Sequence[InputChannel],
    params: Sequence[ParamSpec],
    output: Callable[[sp.Symbol, sp.Symbol], sp.Expr],
    output_name: str = "y",
    structural: Mapping[str, int | sp.Symbol] | None = None,
    description: str = "",
) -> SymbolicModel:
    """Build a state-space model from a second-order equation in ``x, x_dot, x_ddot``.

    The equation is solved for :math:`\\ddot x` (it must be linear in it with a non-zero
    coefficient); the states are :math:`x_1 = x, x_2 = \\dot x`.
    """
    expr = equation.lhs - equation.rhs
    coeff = sp.expand(expr).coeff(X_DDOT)
    rest = sp.expand(expr - coeff * X_DDOT)
    if coeff == 0 or X_DDOT in coeff.free_symbols or X_DDOT in rest.free_symbols:
        raise ModelError(f"model {name}: the equation must be linear in x'' with a non-zero coefficient")
    acceleration = sp.expand(-rest / coeff)
    acceleration = acceleration.xreplace({X: X1, X_DOT: X2})
    return SymbolicModel(
        name=name,
        states=(X1, X2),
        inputs=tuple(inputs),
        params=tuple(params),
        rhs=(X2, acceleration),
        output=output(X1, X2),
        output_name=output_name,
        structural=tuple((structural or {}).items()),
        position=X1,
        velocity=X2,
        equation=equation,
        description=description,
    )


def _p(name, latex, default, lower, upper, description, unit="1", scale=None) -> ParamSpec:
    return ParamSpec(
        name=name,
        latex=latex,
        default=default,
        lower=lower,
        upper=upper,
        unit=unit,
        scale=scale,
        description=description,
    )


def mr_damper_equation(n_x, n_v, m: sp.Expr = sp.S.One):
    """Eq. 11 as a SymPy equation, with the mass ``m`` (1 for the normalized form, Eq. 12)."""
    syms = {k: param_symbol(k) for k in ("c1", "c2", "c3", "k1", "k2", "k3")}
    c1, c2, c3, k1, k2, k3 = (syms[k] for k in ("c1", "c2", "c3", "k1", "k2", "k3"))
    d, dd = D.symbol, D_DOT.symbol
    return sp.Eq(
        m * X_DDOT + c2 * X_DOT + k2 * X + k3 * X**n_x + c3 * X_DOT**n_v,
        k1 * (d - X) + c1 * (dd - X_DOT),
    )


def mr_damper(
    n: int | sp.Symbol = 5,
    *,
    n_x: int | sp.Symbol | None = None,
    n_v: int | sp.Symbol | None = None,
    allow_even: bool = False,
    physical: bool = False,
) -> SymbolicModel:
    """The MR damper model, Eq. 11, normalized by the mass m (Eq. 12), with output Eq. 14.

    .. math:: m\\ddot x + c_2\\dot x + k_2 x + k_3 x^{n} + c_3\\dot x^{n} = k_1(d - x) + c_1(\\dot d - \\dot x),
              \\qquad y = F_{mr} = A_f \\dot x

    With ``physical=True`` the mass m stays a parameter (Eq. 11 as written); otherwise m = 1
    and the constants are dimensionless (Eq. 12). Defaults are Table 2's 0.4 V row.
    """
    n_x = check_power("n" if n_x is None else "n_x", n if n_x is None else n_x, allow_even=allow_even)
    n_v = check_power("n" if n_v is None else "n_v", n if n_v is None else n_v, allow_even=allow_even)
    params = [
        _p("c1", "c_{1}", 10.0, 1e-3, 1e4, "input (piston-side) damping", scale=10.0),
        _p("c2", "c_{2}", 10.0, -1e4, 1e4, "ground-side damping", scale=10.0),
        _p("c3", "c_{3}", 320.0, 0.0, 1e7, "n-th power damping (post-yield slope)", scale=300.0),
        _p("k1", "k_{1}", 34.0, 0.0, 1e5, "input (piston-side) stiffness", scale=30.0),
        _p("k2", "k_{2}", 480.0, -1e5, 1e5, "ground-side stiffness", scale=500.0),
        _p("k3", "k_{3}", 0.0, -1e8, 1e8, "n-th power ground stiffness", scale=100.0),
        _p("A_f", "A_{f}", 1.6, 1e-9, 1e9, "output gain, F_mr = A_f x'", unit="force unit", scale=1.0),
    ]
    m = sp.Integer(1)
    if physical:
        mass = _p("m", "m", 1.0, 1e-9, 1e9, "suspended fluid mass", unit="mass unit")
        params.insert(0, mass)
        m = mass.symbol
    eq = mr_damper_equation(n_x, n_v, m)
    af = params[-1].symbol
    return from_second_order(
        "mr-damper-physical" if physical else "mr-damper",
        eq,
        inputs=(D, D_DOT),
        params=params,
        output=lambda x1, x2: af * x2,
        output_name="y",
        structural={"n_x": n_x, "n_v": n_v},
        description="MR damper model, Eq. 11" + ("" if physical else " normalized by m (Eq. 12), output Eq. 14"),
    )
