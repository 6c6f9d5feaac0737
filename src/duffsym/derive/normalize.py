r"""The normalisation of the MR damper equation (Eq. 11 -> Eq. 12), derived by coefficient matching.

Eq. 11 (with the fluid mass m) is divided by m and its coefficients are matched, monomial by
monomial in :math:`\ddot x, \dot x, x, x^n, \dot x^n, d, \dot d`, against the Duffing-like equation
(Eq. 3) with unknown :math:`\gamma, \alpha, \beta, \delta, k_1, c_1`. Solving gives the paper's
braces under Eq. 12 (with m = 1): :math:`\gamma = c_1 + c_2`, :math:`\alpha = k_1 + k_2`,
:math:`\beta = k_3`, :math:`\delta = c_3`, and :math:`k_1, c_1` unchanged.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import sympy as sp

from duffsym.derive._mechanics import split_terms
from duffsym.errors import ModelError
from duffsym.model.core import SymbolicModel
from duffsym.model.library import D_DOT, X_DDOT, X_DOT, D, X, duffing_like, mr_damper, mr_damper_equation
from duffsym.model.symbols import param_symbol


@dataclass(frozen=True)
class Normalization:
    """The derived map from the MR damper parameters (Eq. 11/12) to the Duffing-like ones (Eq. 3).

    Attributes
    ----------
    n : the power used in the derivation (an integer or ``N_SYMBOL``).
    physical : ``{duffing-like name: expression}`` with the mass m kept (Eq. 11 divided by m).
    mapping : the same with m = 1 (Eq. 12), including ``A_f`` (matched on the outputs).
    equation_11, equation_12 : the equations before and after normalisation.
    """

    n: int | sp.Symbol
    physical: dict[str, sp.Expr]
    mapping: dict[str, sp.Expr]
    equation_11: sp.Eq
    equation_12: sp.Eq

    def summary(self) -> str:
        lines = ["Eq. 11 -> Eq. 12 (divide by m, set m = 1, match with Eq. 3):"]
        for k, e in self.mapping.items():
            lines.append(f"  {k:6s} = {sp.sstr(e):12s}   (with mass m: {sp.sstr(self.physical.get(k, e))})")
        return "\n".join(lines)


def _match(lhs: sp.Expr, rhs: sp.Expr, unknowns, signals) -> dict:
    """Solve ``lhs == rhs`` identically in ``signals`` for ``unknowns`` (coefficient matching)."""
    diff = split_terms(lhs - rhs, signals)
    eqs = list(diff.values())
    sol = sp.solve(eqs, unknowns, dict=True)
    if len(sol) != 1:
        raise ModelError(f"coefficient matching gave {len(sol)} solutions for {unknowns}; expected exactly one")
    return sol[0]


def derive_normalization(n: int | sp.Symbol = 5) -> Normalization:
    """Derive the Eq. 11 -> Eq. 12 mapping for power ``n`` (an odd integer or ``N_SYMBOL``)."""
    m = param_symbol("m")
    eq11 = mr_damper_equation(n, n, m)
    target = duffing_like(n)
    assert target.equation is not None  # from_second_order keeps the equation
    # the Duffing-like parameters are unknowns: give them fresh names (k1, c1 clash with Eq. 11's)
    fresh = {p.symbol: sp.Symbol(p.name + "_dl", real=True) for p in target.params}
    eq3 = target.equation.xreplace(fresh)
    signals = (X, X_DOT, X_DDOT, D.symbol, D_DOT.symbol)
    lhs11 = sp.expand((eq11.lhs - eq11.rhs) / m)  # Eq. 11 divided by m, all on one side
    lhs3 = sp.expand(eq3.lhs - eq3.rhs)
    unknowns = [fresh[p.symbol] for p in target.params if p.name != "A_f"]
    sol = _match(lhs11, lhs3, unknowns, signals)
    # outputs: both are y = A_f x'; match them too (with the state pair identified)
    mr = mr_damper(n)
    af_new = fresh[target.param("A_f").symbol]
    sol_af = _match(mr.output, target.output.xreplace(fresh), [af_new], tuple(mr.states))
    back = {v: k for k, v in fresh.items()}
    physical = {str(back[u]): sp.factor_terms(sol[u]) for u in unknowns}
    physical["A_f"] = sol_af[af_new]
    mapping = {k: sp.factor_terms(e.subs(m, 1)) for k, e in physical.items()}
    eq12 = sp.Eq(
        sum(
            (
                e * mono
                for mono, e in split_terms(lhs11.subs(m, 1), signals).items()
                if not mono.has(D.symbol) and not mono.has(D_DOT.symbol)
            ),
            sp.Integer(0),
        ),
        -sum(
            (
                e * mono
                for mono, e in split_terms(lhs11.subs(m, 1), signals).items()
                if mono.has(D.symbol) or mono.has(D_DOT.symbol)
            ),
            sp.Integer(0),
        ),
    )
    return Normalization(n=n, physical=physical, mapping=mapping, equation_11=eq11, equation_12=eq12)


def to_duffing_like(params_mr: Mapping[str, float], *, n: int = 5) -> dict[str, float]:
    """Duffing-like parameters (Eq. 3) equivalent to MR damper parameters (Eq. 12).

    Parameters
    ----------
    params_mr : ``c1, c2, c3, k1, k2, k3, A_f`` by name (the normalized model, m = 1).
    n : the power; the map does not depend on it, but it is checked to be a valid odd power.

    Returns
    -------
    dict : ``gamma, alpha, beta, delta, k1, c1, A_f``.
    """
    model = mr_damper(n)
    vec = model.param_vector(params_mr)  # checks names and finiteness
    values = dict(zip((p.symbol for p in model.params), vec))
    mapping = _mapping_cached(n)
    return {k: float(e.xreplace(values)) for k, e in mapping.items()}


_CACHE: dict = {}


def _mapping_cached(n) -> dict[str, sp.Expr]:
    if n not in _CACHE:
        _CACHE[n] = derive_normalization(n).mapping
    return _CACHE[n]


def duffing_like_parameter_map(model: SymbolicModel) -> dict[str, sp.Expr] | None:
    """How a model's acceleration reads as Eq. 3: ``{gamma, alpha, beta, delta, k1, c1}`` in the
    model's parameters, by coefficient matching; None when the model does not have that form."""
    from duffsym.derive._mechanics import mechanics

    try:
        mech = mechanics(model)
    except ModelError:
        return None
    n_x = dict(model.structural).get("n_x")
    n_v = dict(model.structural).get("n_v")
    if n_x is None or n_v is None or len(model.inputs) != 2:
        return None
    target = duffing_like(n_x, n_x=n_x, n_v=n_v, allow_even=True)
    fresh = {p.symbol: sp.Symbol(p.name + "_dl", real=True) for p in target.params}
    acc_t = target.rhs[1].xreplace(fresh).xreplace(dict(zip(target.input_symbols, mech.inputs)))
    acc_t = acc_t.xreplace({target.states[0]: mech.x, target.states[1]: mech.v})
    unknowns = [fresh[p.symbol] for p in target.params if p.name != "A_f"]
    try:
        sol = _match(mech.acceleration, acc_t, unknowns, mech.signals)
    except (ModelError, NotImplementedError):
        return None
    back = {v: k for k, v in fresh.items()}
    out = {str(back[u]): sp.factor_terms(sol[u]) for u in unknowns}
    return out if all(not e.has(*fresh.values()) for e in out.values()) else None
