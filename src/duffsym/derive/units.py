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

from duffsym.derive.symmetry import coefficient_equations
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
    state_scales : the factor of each state (``a``, ``b`` or 1: the mechanics with the input or the output,
        an effect's state with the input, the output or neither, e.g. a lagged force or a filtered command).
    same_units : derived for ``a = b`` only (the model needs the input and output in one unit).
    """

    model: SymbolicModel
    exists: bool
    mapping: dict[str, sp.Expr]
    factors: dict[str, sp.Expr]
    state_scales: tuple
    text: str
    same_units: bool = False

    @property
    def diagonal(self) -> bool:
        return self.exists and len(self.factors) == len(self.model.param_names)

    def applies(self, a: float, b: float) -> bool:
        """Whether the map exists for these factors (``same_units`` needs ``a == b``)."""
        return self.exists and (not self.same_units or a == b)

    def factor(self, name: str, a: float, b: float) -> float:
        """The numeric factor of parameter ``name`` (a diagonal map)."""
        return float(self.factors[name].xreplace({A: sp.Float(a, 17), B: sp.Float(b, 17)}))

    def state_factors(self, a: float, b: float) -> tuple[float, ...]:
        """The numeric factor of each state."""
        return tuple(float(sp.sympify(f).xreplace({A: sp.Float(a, 17), B: sp.Float(b, 17)})) for f in self.state_scales)

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
        states = ", ".join(f"{x} x {f}" for x, f in zip(self.model.states, self.state_scales))
        lines = [f"unit scaling of {self.model.name}: input x a, output x b, states {states}, with"]
        lines += [f"  {k} -> {sp.sstr(e)}" for k, e in self.mapping.items() if e != self.model.param(k).symbol]
        return "\n".join(lines + ["  " + self.text])


def _equations(model: SymbolicModel, scales: tuple, b, new: dict) -> list[sp.Expr]:
    """The coefficient equations of the map with the states scaled by ``scales`` (non-polynomial factors
    matched by their arguments, as in :func:`duffsym.derive.symmetry.find_scaling_symmetry`)."""
    states = tuple(model.states)
    signals = states + tuple(model.input_symbols)
    scale = {x: f * x for x, f in zip(states, scales)}
    scale.update({ch.symbol: channel_scale(ch.signal, A, b) * ch.symbol for ch in model.inputs})
    pairs = [(e.xreplace(new).xreplace(scale), f * e) for f, e in zip(scales, model.rhs)]
    pairs.append((model.output.xreplace(new).xreplace(scale), b * model.output))
    return coefficient_equations(pairs, list(new.values()), signals)


def _solve(model: SymbolicModel, scales: tuple, b) -> dict[str, sp.Expr] | None:
    """The unique map ``{name: expression}`` with the states scaled by ``scales``, or None."""
    new = {p.symbol: sp.Symbol(p.name + "_new", real=True) for p in model.params}
    unknowns = list(new.values())
    equations = _equations(model, scales, b, new)
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


def _state_choices(model: SymbolicModel, b) -> list[tuple]:
    """The state scalings tried, in order: the mechanics with the input (``a``) or the output (``b``); every
    other state with the mechanics first, then each with 1 or the other factor."""
    states = tuple(model.states)
    mech = tuple(s for s in (model.position, model.velocity) if s is not None) or states
    out = []
    for sigma in dict.fromkeys((A, b)):
        options = [(sigma, 1, b if sigma == A else A) if x not in mech else (sigma,) for x in states]
        out += [c for c in itertools.product(*options) if c not in out]
    return out


@functools.lru_cache(maxsize=64)
def find_unit_scaling(model: SymbolicModel) -> UnitScaling:
    """Derive the parameter map of a change of units (input x a, output x b) for ``model``.

    The states are tried scaled as :func:`_state_choices` lists (a displacement-driven damper's mechanics
    with the input, an oscillator whose output is its position with the output); a map that multiplies
    each parameter by a factor is preferred to one that mixes them. When none exists, the same with
    ``a = b``. Models with symbolic powers (``n`` not a number) have none here.
    """
    if any(isinstance(v, sp.Symbol) for _, v in model.structural):
        return UnitScaling(model, False, {}, {}, (), "the model's powers are symbolic; give n a value")
    for same in (False, True):
        b = A if same else B
        mixed = None
        for scales in _state_choices(model, b):
            mapping = _solve(model, scales, b)
            if mapping is None:
                continue
            factors = _factors(model, mapping)
            kind = "each parameter scales by a factor" if factors else "the map mixes parameters"
            text = f"exact for any a, b > 0 ({kind})" if not same else f"exact when a = b only ({kind})"
            found = UnitScaling(model, True, mapping, factors, scales, text, same_units=same)
            if factors:
                return found
            mixed = mixed or found
        if mixed is not None:
            return mixed
    return UnitScaling(
        model,
        False,
        {},
        {},
        (),
        "no parameter change reproduces the record in other units: some term fixes the units of the input "
        "or output (a smoothing width written into the equation, e.g. tanh(1000 d_dot) or sqrt(d_dot^2 + 1e-6), "
        "or an input that enters with a fixed unit gain while the output is the state itself)",
    )
