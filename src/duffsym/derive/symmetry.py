r"""The scaling symmetry of a model's states, found from its equations.

The hidden state is never measured, so scaling it, :math:`\mathbf x \to s\mathbf x`, changes
nothing observable if some new parameters :math:`\theta'` satisfy, identically in the states and
inputs,

.. math:: \mathbf{rhs}(s\mathbf x, \mathbf u, \theta') = s\,\mathbf{rhs}(\mathbf x, \mathbf u, \theta),
          \qquad h(s\mathbf x, \mathbf u, \theta') = h(\mathbf x, \mathbf u, \theta).

The states and inputs are substituted, the coefficients of each monomial (or other state/input
dependent factor) are matched, and the resulting equations are solved for :math:`\theta'`. For the
MR damper this gives :math:`c_1' = sc_1`, :math:`c_2' = c_1 + c_2 - sc_1`, :math:`k_1' = sk_1`,
:math:`k_2' = k_1 + k_2 - sk_1`, :math:`c_3' = c_3s^{1-n}`, :math:`k_3' = k_3s^{1-n}`,
:math:`A_f' = A_f/s`: a one-parameter family of parameter sets with the same input–output
behaviour, so one parameter must be fixed (the paper fixes :math:`A_f = \max|y|`).
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

#: The scale factor symbol (positive: a sign flip x -> -x is a separate, discrete symmetry).
S = sp.Symbol("s", positive=True)


@dataclass(frozen=True)
class ScalingSymmetry:
    """A one-parameter family :math:`\\theta \\to \\theta'(s)` leaving the output unchanged under
    :math:`\\mathbf x \\to s\\mathbf x`.

    Attributes
    ----------
    model : the model it was found for.
    exists : whether a non-trivial family was found.
    mapping : ``{parameter name: expression in s and the old parameters}`` (empty if none).
    tangent : ``{name: d theta'/ds at s = 1}``: the parameter direction the output cannot see.
    scaled_states : the states that scale by s (all of them for the paper's models).
    text : explanation for people (what was found, or why there is none).
    """

    model: SymbolicModel
    exists: bool
    mapping: dict[str, sp.Expr]
    tangent: dict[str, sp.Expr]
    text: str
    scaled_states: tuple[sp.Symbol, ...] = ()

    def apply(self, params: Mapping[str, float], s: float) -> dict[str, float]:
        """Parameters transformed with scale factor ``s`` (> 0); the states scale by ``s``.

        Raises
        ------
        ModelError
            If no symmetry exists, ``s`` is not positive and finite, or a parameter is missing.
        """
        if not self.exists:
            raise ModelError(f"model {self.model.name} has no scaling symmetry to apply: {self.text}")
        if not (isinstance(s, (int, float)) and math.isfinite(s) and s > 0):
            raise ModelError(f"scale factor s must be a positive finite number; got {s!r}")
        vec = self.model.param_vector(params)
        values = {p.symbol: sp.Float(v, 17) for p, v in zip(self.model.params, vec)}
        values[S] = sp.Float(s, 17)
        structural = {v: 0 for _, v in self.model.structural if isinstance(v, sp.Symbol)}
        if structural:
            raise ModelError("apply() needs numeric powers; build the model with an integer n")
        return {name: float(self.mapping[name].xreplace(values)) for name in self.model.param_names}

    def summary(self) -> str:
        if not self.exists:
            return f"scaling symmetry of {self.model.name}: none ({self.text})"
        lines = [f"scaling symmetry of {self.model.name}: x -> s*x with"]
        for k, e in self.mapping.items():
            if sp.simplify(e - self.model.param(k).symbol) != 0:
                lines.append(f"  {k} -> {sp.sstr(e)}")
        lines.append("  " + self.text)
        return "\n".join(lines)


def _atoms_with(expr: sp.Expr, symbols) -> list[sp.Expr]:
    """Function applications in ``expr`` that involve any of ``symbols`` (non-polynomial factors)."""
    return [a for a in expr.atoms(sp.Function) if a.has(*symbols)]


def coefficient_equations(pairs, unknowns, signals) -> list[sp.Expr]:
    """The equations on ``unknowns`` that make each ``(lhs, rhs)`` pair equal for all ``signals``: non-polynomial
    factors first (f(arg') must equal f(arg), so their arguments are matched identically and solved for), then the
    coefficients of every term in the signals; tidied, without zeros."""
    arg_eqs: list[sp.Expr] = []
    for lhs, rhs in pairs:
        for atom in _atoms_with(lhs, unknowns):
            for cand in rhs.atoms(sp.Function):
                if cand.func == atom.func and len(cand.args) == len(atom.args):
                    for a_new, a_old in zip(atom.args, cand.args):
                        num = sp.together(a_new - a_old).as_numer_denom()[0]
                        arg_eqs += list(split_terms(num, signals).values())
    equations: list[sp.Expr] = list(arg_eqs)
    if arg_eqs:
        try:
            arg_sol = sp.solve(arg_eqs, unknowns, dict=True)
        except NotImplementedError:
            arg_sol = []
        if arg_sol:
            pairs = [(lhs.subs(arg_sol[0]), rhs) for lhs, rhs in pairs]
    for lhs, rhs in pairs:
        equations += list(split_terms(lhs - rhs, signals).values())
    return [e for e in {tidy(e) for e in equations} if e != 0]


def _solve_scaling(model: SymbolicModel, scaled: tuple[sp.Symbol, ...]):
    """Solutions theta'(s) for the states in ``scaled`` scaled by s (the others fixed), or []."""
    states = tuple(model.states)
    signals = states + tuple(model.input_symbols)
    new = {p.symbol: sp.Symbol(p.name + "_new", real=True) for p in model.params}
    unknowns = list(new.values())
    scale = {x: S * x for x in scaled}
    pairs = [(e.xreplace(new).xreplace(scale), (S if x in scaled else 1) * e) for x, e in zip(states, model.rhs)]
    pairs.append((model.output.xreplace(new).xreplace(scale), model.output))
    equations = coefficient_equations(pairs, unknowns, signals)
    # an equation without unknowns (e.g. 1 - s from an output that sees the state) must hold by itself
    if any(not e.has(*unknowns) for e in equations):
        return [], new
    try:
        return sp.solve(equations, unknowns, dict=True), new
    except NotImplementedError:
        return [], new


@functools.lru_cache(maxsize=64)
def find_scaling_symmetry(model: SymbolicModel) -> ScalingSymmetry:
    """Find the parameter map that compensates the state scaling :math:`\\mathbf x \\to s\\mathbf x`.

    All states are scaled first; if that has no solution, states added by effects are tried
    unscaled in turn (an output filter state, say, need not scale with the hidden mechanics).
    Non-polynomial factors (``tanh(x2/eps)``) are matched by their arguments; structural powers
    (``n``) stay fixed.
    """
    states = tuple(model.states)
    mech_pair = tuple(s for s in (model.position, model.velocity) if s is not None) or states
    extra = [x for x in states if x not in mech_pair]
    choices = []
    for k in range(len(extra) + 1):
        for fixed in itertools.combinations(extra, k):
            choices.append(tuple(x for x in states if x not in fixed))
    sol, new, scaled = None, None, states
    for scaled in choices:
        sols, new = _solve_scaling(model, scaled)
        nontrivial = [so for so in sols if any(sp.diff(e, S) != 0 for e in so.values())]
        if nontrivial:
            sol = nontrivial[0]
            break
    names = model.param_names
    if sol is None:
        return ScalingSymmetry(
            model=model,
            exists=False,
            mapping={},
            tangent={},
            scaled_states=(),
            text="no parameter change compensates x -> s*x: some term or the output "
            "fixes the scale of the states (e.g. the output is the state itself, an "
            "input enters without a parameter, or a term like tanh(x'/eps) with fixed eps)",
        )
    assert new is not None  # set in the loop with sol
    back = {v: k for k, v in new.items()}
    unknowns = list(new.values())
    mapping: dict[str, sp.Expr] = {}
    for p, u in zip(model.params, unknowns):
        mapping[p.name] = sp.powsimp(sp.expand(sol[u]), combine="exp") if u in sol else p.symbol
    # unknowns left free belong to a further symmetry: hold those parameters at their old values
    free = sorted({str(back[u]) for u in unknowns if u not in sol or any(e.has(u) for e in mapping.values())})
    mapping = {k: e.xreplace(back) for k, e in mapping.items()}
    tangent = {k: sp.simplify(sp.diff(e, S).subs(S, 1)) for k, e in mapping.items()}
    moved = [k for k in names if tangent[k] != 0]
    fix = "the paper fixes A_f = max|y|" if "A_f" in moved else "fix one of them"
    text = (
        f"the output is unchanged along this one-parameter family, so {', '.join(moved)} cannot all be "
        f"identified from input-output data ({fix})"
    )
    unscaled = [str(x) for x in states if x not in scaled]
    if unscaled:
        text += f"; states {', '.join(unscaled)} are not scaled"
    if free:
        text += (
            f"; the solution is not unique ({', '.join(free)} held at their old values): the model has a "
            "further symmetry, e.g. the mass scaling of Eq. 11"
        )
    return ScalingSymmetry(
        model=model, exists=True, mapping=mapping, tangent=tangent, text=text, scaled_states=tuple(scaled)
    )


def normalize_af(model: SymbolicModel, params: Mapping[str, float], A_f_target: float) -> dict[str, float]:
    """Move ``params`` along the scaling symmetry until ``A_f`` equals ``A_f_target``.

    The output is unchanged (the hidden states scale by ``s``); ``s`` is solved from the found
    map of ``A_f``.

    Raises
    ------
    ModelError
        If the model has no ``A_f`` or no symmetry, or the target has the wrong sign or is not finite.
    """
    sym = find_scaling_symmetry(model)
    if "A_f" not in model.param_names:
        raise ModelError(f"model {model.name} has no parameter A_f; normalize_af applies to Eq. 5/14 models")
    if not sym.exists:
        raise ModelError(f"model {model.name} has no scaling symmetry: {sym.text}")
    target = float(A_f_target)
    current = float(model.param_vector(params)[model.param_names.index("A_f")])
    if not (math.isfinite(target) and target != 0 and current != 0 and (target > 0) == (current > 0)):
        raise ModelError(
            f"A_f_target must be finite, non-zero and of the same sign as the current A_f = {current:g}; "
            f"got {A_f_target!r} (a positive scale s cannot flip the sign)"
        )
    af = model.param("A_f").symbol
    s_sol = sp.solve(sp.Eq(sym.mapping["A_f"].xreplace({af: sp.Float(current, 17)}), sp.Float(target, 17)), S)
    if len(s_sol) != 1:
        raise ModelError(f"could not solve A_f'(s) = {target:g} for a unique s > 0 (got {s_sol})")
    return sym.apply(params, float(s_sol[0]))
