r"""The unit-scaling symmetry of a model: the parameters that reproduce a record in other units.

A record whose input is multiplied by :math:`a` and output by :math:`b` (a change of units) is
reproduced exactly by the same model if some parameters :math:`\theta'(\theta, a, b)` satisfy,
identically in the states and inputs, with the states scaled by :math:`\sigma` (:math:`a` or :math:`b`),

.. math:: \mathbf{rhs}(\sigma\mathbf x, S\mathbf u, \theta') = \sigma\,\mathbf{rhs}(\mathbf x, \mathbf u, \theta),
          \qquad h(\sigma\mathbf x, S\mathbf u, \theta') = b\,h(\mathbf x, \mathbf u, \theta),

where :math:`S` scales each input channel by its unit: the record's input ``d`` (or ``F``) and its
derivatives by :math:`a`, the dissipated energy by :math:`ab`, time and the command not at all. For the
MR damper (states scaled by :math:`a`): :math:`c_1, c_2, k_1, k_2` unchanged,
:math:`c_3' = c_3 a^{1-n}`, :math:`k_3' = k_3 a^{1-n}`, :math:`A_f' = A_f\,b/a`. For ``duffing-gain``
(output :math:`x`, states scaled by :math:`b`): :math:`\beta' = \beta/b^2`, :math:`g' = g\,b/a`. The plain
``duffing`` (unit input gain, output the state itself) has none unless :math:`a = b`.

The fit (:func:`duffsym.identify.fit`) uses it to fit a record normalised to O(1) units and map the
parameters back, so that the answer does not depend on the units the record was written in.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass

import sympy as sp

from duffsym.derive._mechanics import split_terms, tidy
from duffsym.errors import ModelError
from duffsym.model.core import SymbolicModel

#: The input and output unit factors.
A = sp.Symbol("a", positive=True)
B = sp.Symbol("b", positive=True)

#: Input signals that carry the record's input unit (``d`` for the damper, ``F`` for the oscillators).
INPUT_SIGNALS = ("d", "F")


def channel_scale(signal: str, a, b):
    """The factor of an input channel of ``signal`` when the input is scaled by ``a``, the output by ``b``."""
    if signal in INPUT_SIGNALS:
        return a
    if signal == "energy":  # the integral of y * d'
        return a * b
    return 1  # time, the command


@dataclass(frozen=True)
class UnitScaling:
    """The parameter map :math:`\\theta \\to \\theta'(\\theta, a, b)` of a change of units (input x a, output x b).

    Attributes
    ----------
    model : the model it was derived for.
    exists : whether a map was found; ``text`` says what was found or why there is none.
    mapping : ``{parameter: expression in the old parameters, a and b}``.
    factors : ``{parameter: expression in a and b}`` when the map multiplies each parameter by a
        factor (``diagonal``); empty otherwise.
    state_scale : the factor of every state (``a`` or ``b``) but ``unscaled_states`` (an effect's state
        that keeps its units, e.g. a filtered command).
    same_units : derived for ``a = b`` only (the model needs the input and output in one unit).
    """

    model: SymbolicModel
    exists: bool
    mapping: dict[str, sp.Expr]
    factors: dict[str, sp.Expr]
    state_scale: sp.Expr
    text: str
    same_units: bool = False
    unscaled_states: tuple = ()

    @property
    def diagonal(self) -> bool:
        return self.exists and len(self.factors) == len(self.model.param_names)

    def applies(self, a: float, b: float) -> bool:
        """Whether the map exists for these factors (``same_units`` needs ``a == b``)."""
        return self.exists and (not self.same_units or a == b)

    def factor(self, name: str, a: float, b: float) -> float:
        """The numeric factor of parameter ``name`` (a diagonal map)."""
        return float(self.factors[name].xreplace({A: sp.Float(a, 17), B: sp.Float(b, 17)}))

    def state_factor(self, a: float, b: float) -> float:
        return float(sp.sympify(self.state_scale).xreplace({A: sp.Float(a, 17), B: sp.Float(b, 17)}))

    def apply(self, params: Mapping[str, float], a: float, b: float) -> dict[str, float]:
        """The parameters in the new units (input x ``a``, output x ``b``; both > 0).

        Raises
        ------
        ModelError
            If there is no map (for these factors), or a factor is not positive and finite.
        """
        if not self.applies(a, b):
            raise ModelError(f"model {self.model.name} has no unit-scaling map for a = {a:g}, b = {b:g}: {self.text}")
        for k, v in (("a", a), ("b", b)):
            if not (math.isfinite(v) and v > 0):
                raise ModelError(f"unit factor {k} must be a positive finite number; got {v!r}")
        vec = self.model.param_vector(params)
        values = {p.symbol: sp.Float(v, 17) for p, v in zip(self.model.params, vec)}
        values[A], values[B] = sp.Float(a, 17), sp.Float(b, 17)
        return {name: float(self.mapping[name].xreplace(values)) for name in self.model.param_names}

    def summary(self) -> str:
        if not self.exists:
            return f"unit scaling of {self.model.name}: none ({self.text})"
        lines = [f"unit scaling of {self.model.name}: input x a, output x b, states x {self.state_scale} with"]
        lines += [f"  {k} -> {sp.sstr(e)}" for k, e in self.mapping.items() if e != self.model.param(k).symbol]
        return "\n".join(lines + ["  " + self.text])


def _equations(model: SymbolicModel, sigma, b, new: dict, fixed: tuple = ()) -> list[sp.Expr]:
    """The coefficient equations of the map with the states scaled by ``sigma`` except those in ``fixed``
    (non-polynomial factors matched by their arguments, as in
    :func:`duffsym.derive.symmetry.find_scaling_symmetry`)."""
    states = tuple(model.states)
    signals = states + tuple(model.input_symbols)
    scale = {x: (1 if x in fixed else sigma) * x for x in states}
    scale.update({ch.symbol: channel_scale(ch.signal, A, b) * ch.symbol for ch in model.inputs})
    pairs = [(e.xreplace(new).xreplace(scale), (1 if x in fixed else sigma) * e) for x, e in zip(states, model.rhs)]
    pairs.append((model.output.xreplace(new).xreplace(scale), b * model.output))
    unknowns = list(new.values())
    arg_eqs: list[sp.Expr] = []
    for lhs, rhs in pairs:
        for atom in (f for f in lhs.atoms(sp.Function) if f.has(*unknowns)):
            for cand in rhs.atoms(sp.Function):
                if cand.func == atom.func and len(cand.args) == len(atom.args):
                    for a_new, a_old in zip(atom.args, cand.args):
                        num = sp.together(a_new - a_old).as_numer_denom()[0]
                        arg_eqs += list(split_terms(num, signals).values())
    if arg_eqs:
        try:
            arg_sol = sp.solve(arg_eqs, unknowns, dict=True)
        except NotImplementedError:
            arg_sol = []
        if arg_sol:
            pairs = [(lhs.subs(arg_sol[0]), rhs) for lhs, rhs in pairs]
    equations = list(arg_eqs)
    for lhs, rhs in pairs:
        equations += list(split_terms(lhs - rhs, signals).values())
    return [e for e in {tidy(e) for e in equations} if e != 0]


def _solve(model: SymbolicModel, sigma, b, fixed: tuple = ()) -> dict[str, sp.Expr] | None:
    """The unique map ``{name: expression}`` with the states scaled by ``sigma`` (but ``fixed``), or None."""
    new = {p.symbol: sp.Symbol(p.name + "_new", real=True) for p in model.params}
    unknowns = list(new.values())
    equations = _equations(model, sigma, b, new, fixed)
    if any(not e.has(*unknowns) for e in equations):  # e.g. a - b from an output that is the state
        return None
    try:
        sols = sp.solve(equations, unknowns, dict=True)
    except NotImplementedError:
        return None
    if len(sols) != 1 or any(u not in sols[0] for u in unknowns):  # not unique: a further symmetry
        return None
    back = {v: k for k, v in new.items()}
    sol = sols[0]
    if any(e.has(*unknowns) for e in sol.values()):
        return None
    return {p.name: sp.powsimp(sp.expand(sol[new[p.symbol]].xreplace(back)), combine="exp") for p in model.params}


def _factors(model: SymbolicModel, mapping: dict[str, sp.Expr]) -> dict[str, sp.Expr]:
    """``{name: factor}`` when every parameter is multiplied by a factor of ``a, b`` only, else {}."""
    out = {}
    syms = model.param_symbols
    for p in model.params:
        f = sp.simplify(mapping[p.name] / p.symbol)
        if f.has(*syms) or f == 0:
            return {}
        out[p.name] = f
    return out


@functools.lru_cache(maxsize=64)
def find_unit_scaling(model: SymbolicModel) -> UnitScaling:
    """Derive the parameter map of a change of units (input x a, output x b) for ``model``.

    The states are tried scaled with the input (``a``: a displacement-driven damper) and then with the
    output (``b``: an oscillator whose output is its position); when neither gives a unique map, the
    same with ``a = b``. Models with symbolic powers (``n`` not a number) have none here.
    """
    if any(isinstance(v, sp.Symbol) for _, v in model.structural):
        return UnitScaling(model, False, {}, {}, sp.Integer(1), "the model's powers are symbolic; give n a value")
    states = tuple(model.states)
    mech = tuple(s for s in (model.position, model.velocity) if s is not None) or states
    extra = [x for x in states if x not in mech]
    unscaled = [c for k in range(len(extra) + 1) for c in itertools.combinations(extra, k)]
    for same in (False, True):
        b = A if same else B
        for sigma, fixed in ((s, f) for s in (A, b) for f in unscaled):
            mapping = _solve(model, sigma, b, fixed)
            if mapping is not None:
                factors = _factors(model, mapping)
                kind = "each parameter scales by a factor" if factors else "the map mixes parameters"
                text = f"exact for any a, b > 0 ({kind})" if not same else f"exact when a = b only ({kind})"
                if fixed:
                    text += f"; states {', '.join(map(str, fixed))} keep their units"
                return UnitScaling(model, True, mapping, factors, sigma, text, same_units=same, unscaled_states=fixed)
    return UnitScaling(
        model,
        False,
        {},
        {},
        sp.Integer(1),
        "no parameter change reproduces the record in other units: some term fixes the units of the input "
        "or output (e.g. an input that enters with a fixed unit gain while the output is the state itself)",
    )
