"""Candidate terms of the velocity equation, generated from the symbolic model.

The library is the union of three families, each a SymPy expression in the model's states and
inputs (never typed in by hand for a given model):

- ``model``: the monomials of the model's own velocity equation. Each carries its coefficient as
  a SymPy expression of the parameters, read off the expanded right-hand side (for Eq. 12:
  :math:`\\dot x \\to -(c_1+c_2)`, :math:`\\dot x^5 \\to -c_3`, :math:`d \\to k_1`, ...).
- ``effect:<name>``: the terms an effect of :data:`duffsym.effects.CATALOGUE` adds to the velocity
  equation (e.g. :math:`-\\mu\\tanh(\\dot x/\\varepsilon)` for ``coulomb-friction``). Effects that act
  on the output or add a state (``force-offset``, ``output-lag``) put no term there and are listed
  in :attr:`CandidateLibrary.not_visible` instead.
- ``generic``: odd powers of position and velocity up to ``max_power`` and the quadratic damping
  :math:`\\dot x|\\dot x|`, plus (optionally) even powers.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from duffsym.derive import split_terms
from duffsym.errors import ModelError
from duffsym.sindy import sparse


@dataclass(frozen=True)
class Term:
    """One candidate term of the velocity equation.

    name : short text name (``"x_dot^5"``). expr : the SymPy expression in states and inputs.
    source : ``"model"``, ``"effect:<name>"`` or ``"generic"``.
    coefficient : SymPy expression in the model's (or the effect's) parameters, None for generic terms.
    effect : the catalogue effect the term belongs to (for ``effect:`` terms), else None.
    """

    name: str
    expr: sp.Expr
    source: str
    coefficient: sp.Expr | None = None
    effect: str | None = None

    @property
    def in_model(self) -> bool:
        return self.source == "model"


def _velocity_index(model) -> int:
    if model.position is None or model.velocity is None:
        raise ModelError(
            f"the SINDy cross-check needs a mechanical model (position and velocity states); "
            f"model {model.name} has none"
        )
    return model.states.index(model.velocity)


def _coefficients(expr: sp.Expr, variables: Sequence[sp.Symbol]) -> dict[sp.Expr, sp.Expr]:
    """Each basis function of ``expr`` (in ``variables``) and its coefficient, simplified
    (:func:`duffsym.derive.split_terms`)."""
    return split_terms(expr, variables, form=sp.simplify)


def _name(expr: sp.Expr, names: Mapping[sp.Symbol, str]) -> str:
    text = str(expr.xreplace({s: sp.Symbol(n) for s, n in names.items()}))
    return text.replace("**", "^").replace(" ", "")


@dataclass(frozen=True)
class CandidateLibrary:
    """The candidate terms and how to evaluate them on states and inputs.

    Attributes
    ----------
    model : the base model. terms : the candidates, model terms first.
    variables : ordered symbols the terms are functions of (the states, then the inputs).
    not_visible : catalogue effects that add no term to the velocity equation, with the reason.
    """

    model: object
    terms: tuple[Term, ...]
    variables: tuple[sp.Symbol, ...]
    not_visible: dict = field(default_factory=dict)

    @property
    def names(self) -> list[str]:
        return [t.name for t in self.terms]

    @property
    def n_terms(self) -> int:
        return len(self.terms)

    def index(self, name: str) -> int:
        return self.names.index(name)

    def evaluate(self, states: np.ndarray, inputs: np.ndarray) -> np.ndarray:
        """Library matrix ``(n_times, n_terms)`` from states ``(n_times, n_states)`` and inputs ``(n_times, n_inputs)``:
        the terms as a pysindy ``CustomLibrary`` (:func:`duffsym.sindy.sparse.expression_library`)."""
        return sparse.evaluate(_pysindy_library(self), np.column_stack([states, inputs]))

    def coefficients(self, params: Mapping[str, float]) -> np.ndarray:
        """The coefficient of every term implied by the model's parameter values (0 for terms the model lacks)."""
        syms = {str(s): s for t in self.terms if t.coefficient is not None for s in t.coefficient.free_symbols}
        subs = {syms[k]: float(v) for k, v in params.items() if k in syms}
        out = np.zeros(self.n_terms)
        for j, t in enumerate(self.terms):
            if t.in_model:
                assert t.coefficient is not None  # a model term always has its coefficient
                val = sp.sympify(t.coefficient.xreplace(subs))
                out[j] = float(val) if not val.free_symbols else np.nan
        return out

    def coefficient_gradients(self, params: Mapping[str, float], names: Sequence[str]) -> np.ndarray:
        """``(n_terms, len(names))`` derivatives of each term's coefficient by the named parameters."""
        syms = {str(s): s for t in self.terms if t.coefficient is not None for s in t.coefficient.free_symbols}
        subs = {syms[k]: float(v) for k, v in params.items() if k in syms}
        out = np.zeros((self.n_terms, len(names)))
        for j, t in enumerate(self.terms):
            if not t.in_model:
                continue
            for i, n in enumerate(names):
                if n in syms:
                    out[j, i] = float(sp.diff(t.coefficient, syms[n]).xreplace(subs))
        return out


_CACHE: dict = {}


def _pysindy_library(lib: CandidateLibrary):
    key = (id(lib), lib.model.key if hasattr(lib.model, "key") else None)
    if key not in _CACHE:
        _CACHE[key] = sparse.expression_library([t.expr for t in lib.terms], lib.variables, lib.names)
    return _CACHE[key]


def candidate_library(
    model, *, effects: Mapping | None = None, max_power: int = 7, even: bool = False, generic: bool = True
) -> CandidateLibrary:
    """The candidate terms for the velocity equation of ``model``.

    Parameters
    ----------
    model : a mechanical :class:`~duffsym.model.SymbolicModel` (position and velocity states).
    effects : catalogue to draw effect terms from (default :data:`duffsym.effects.CATALOGUE`).
    max_power : highest power of position and velocity among the generic terms (odd powers 3..max_power).
    even : also add even powers 2..max_power of position and velocity (asymmetric behaviour).
    generic : add the generic terms at all.

    Raises
    ------
    ModelError
        If the model has no position/velocity pair, or ``max_power`` < 1.
    """
    if int(max_power) < 1:
        raise ModelError(f"max_power must be a positive integer; got {max_power}")
    iv = _velocity_index(model)
    x, v = model.position, model.velocity
    variables = tuple(model.states) + tuple(model.input_symbols)
    names = dict(zip(model.states, model.state_names))
    names[x], names[v] = "x", "x_dot"
    names.update({c.symbol: c.name for c in model.inputs})
    terms: list[Term] = []
    seen: set = set()

    def add(expr, source, coefficient=None, effect=None):
        expr = sp.sympify(expr)
        if expr in seen:
            return
        seen.add(expr)
        terms.append(Term(_name(expr, names), expr, source, coefficient, effect))

    def order(item):  # position terms, velocity terms, then inputs; by degree within each
        basis = item[0]
        first = min((variables.index(s) if s in variables else len(variables) for s in basis.free_symbols), default=-1)
        return first, sp.Poly(basis, *variables).total_degree() if basis.is_polynomial(*variables) else 99

    for basis, coeff in sorted(_coefficients(model.rhs[iv], variables).items(), key=order):
        add(basis, "model", coeff)
    not_visible: dict[str, str] = {}
    if effects is None:
        from duffsym.effects import CATALOGUE

        effects = CATALOGUE
    for ename, effect in effects.items():
        if ename in model.effects:
            continue
        try:
            extended = effect.apply(model)
        except ModelError as exc:
            not_visible[ename] = str(exc)
            continue
        if extended.n_states != model.n_states or extended.n_inputs != model.n_inputs:
            not_visible[ename] = "adds a state or an input: no term of the velocity equation in (x, x', d, d')"
            continue
        new = sp.expand(extended.rhs[iv] - model.rhs[iv])
        if new == 0:
            not_visible[ename] = "acts on the output, not on the velocity equation"
            continue
        for basis, coeff in _coefficients(new, variables).items():
            add(basis, f"effect:{ename}", coeff, ename)
    if generic:
        powers = range(2 if even else 3, int(max_power) + 1)
        for k in powers:
            if k % 2 == 1 or even:
                add(x**k, "generic")
        for k in powers:
            if k % 2 == 1 or even:
                add(v**k, "generic")
        add(v * sp.Abs(v), "generic")
    return CandidateLibrary(model=model, terms=tuple(terms), variables=variables, not_visible=not_visible)
