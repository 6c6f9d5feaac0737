r"""A structure whose restoring force includes a Duffing-like hysteresis element: composition of two models.

The structure is the user's second-order equation in SymPy, in the displacement ``q`` of a mass, with
the element's force ``H`` on its left-hand side; the default is a mass on a spring and a damper,

.. math:: m\ddot q + c\dot q + k q + H = F .

The element is any existing two-state model of the library (default the paper's normalized MR
damper, Eq. 12, whose force is :math:`A_f\dot x`), possibly already extended by catalogued effects.
:func:`structure` composes them without typing either again: the element's input :math:`d,\dot d`
becomes the structure's own :math:`q/L,\ \dot q/L` (``L`` a fixed length unit, 1 by default), ``H``
becomes the element's output expression, and the structure's equation is solved for :math:`\ddot q`.
The composed model has the states :math:`(q_1, q_2, x_1, x_2) = (q, \dot q, x, \dot x)`, the input F,
the output q, and the parameters of both parts. Effects act on either part: on the element by
extending it before composition, on the structure by extending the composed model (its
``position``/``velocity`` are :math:`q_1, q_2`, its input is F).

``model.composition`` records the parts (read by the derivations, :mod:`duffsym.derive.coupled`,
and by the data-based state guess of the fit).
"""

from __future__ import annotations

from dataclasses import replace

import sympy as sp

from duffsym.errors import ModelError
from duffsym.model.core import InputChannel, SymbolicModel
from duffsym.model.elements import FORCE, mr_damper
from duffsym.model.symbols import ParamSpec, state_symbol

Q, Q_DOT, Q_DDOT = state_symbol("q"), state_symbol("q_dot"), state_symbol("q_ddot")
Q1, Q2 = state_symbol("q1"), state_symbol("q2")
#: The element's force in the structure's equation (replaced by the element's output).
H = sp.Symbol("H", real=True)
#: The structure's input force F.
FORCE_SYMBOL = FORCE.symbol


def _sp(name, latex, default, lower, upper, description, unit) -> ParamSpec:
    return ParamSpec(
        name=name, latex=latex, default=default, lower=lower, upper=upper, unit=unit, description=description
    )


def mass_spring_damper(powers: tuple[int, ...] = ()) -> tuple[sp.Eq, tuple[ParamSpec, ...]]:
    r"""The default structure: :math:`m\ddot q + c\dot q + k q + \sum_p k_{q,p} q^p + H = F` and its parameters
    (``powers`` adds a polynomial stiffness ``k_q<p> q^p`` for each p, e.g. ``(3,)`` a cubic spring)."""
    params = (
        _sp("m", "m", 1.0, 1e-12, 1e12, "mass of the structure", "force/(length/s^2)"),
        _sp("c", "c", 1.0, -1e12, 1e12, "viscous damping of the structure", "force/(length/s)"),
        _sp("k", "k", 1.0, -1e12, 1e12, "stiffness of the structure", "force/length"),
    ) + tuple(
        _sp(f"k_q{p}", f"k_{{q{p}}}", 0.0, -1e12, 1e12, f"stiffness of the structure in q^{p}", f"force/length^{p}")
        for p in powers
    )
    m, c, k = (p.symbol for p in params[:3])
    poly = sum((spec.symbol * Q**p for spec, p in zip(params[3:], powers)), sp.Integer(0))
    return sp.Eq(m * Q_DDOT + c * Q_DOT + k * Q + poly + H, FORCE.symbol), params


def structure(
    element: SymbolicModel | None = None,
    *,
    equation: sp.Eq | None = None,
    params: tuple[ParamSpec, ...] | None = None,
    length_unit: float = 1.0,
    name: str = "structure",
    extra_elements: tuple = (),
) -> SymbolicModel:
    """Compose a structure (``equation`` in q, q', q'', the element force ``H`` and the input F) with
    a two-state hysteresis ``element`` driven by the structure's own motion.

    Parameters
    ----------
    element : a two-state model with inputs ``d`` (and ``d_dot``) and a force output (default
        :func:`~duffsym.model.library.mr_damper` with n = 3).
    equation, params : the structure's equation and its parameters (default
        :func:`mass_spring_damper`); the equation must contain ``H`` and be linear in q''.
    length_unit : the element sees :math:`d = q / L` (a fixed unit change, not identified), so an
        element written for O(1) strokes can drive a structure moving 1e-4 m.
    extra_elements : further elements in parallel (H is the sum of their forces); their states and
        parameters get the suffix ``_2``, ``_3``, ... (:func:`renamed`).
    """
    element = mr_damper(3) if element is None else element
    if equation is None:
        equation, params = mass_spring_damper()
    if params is None:
        raise ModelError("structure: give the parameters of a custom equation (params=...)")
    _check_element(element)
    extras = tuple(renamed(e, f"_{i + 2}") for i, e in enumerate(extra_elements))
    for e in extras:
        _check_element(e)
    all_names = [p.name for p in params] + [n for e in (element,) + extras for n in e.param_names]
    clash = sorted({n for n in all_names if all_names.count(n) > 1})
    if clash:
        raise ModelError(f"structure: parameter name(s) {clash} used by both the structure and the element; rename")
    expr = equation.lhs - equation.rhs
    if H not in expr.free_symbols:
        raise ModelError("structure: the structure's equation must contain the element force H")
    L = sp.nsimplify(length_unit) if float(length_unit) != 1.0 else sp.Integer(1)
    drive = {}
    for ch in element.inputs:
        drive[ch.symbol] = (Q1, Q2)[ch.order] / L
    force = sum((e.output.xreplace(drive) for e in (element,) + extras), sp.Integer(0))
    coeff = sp.expand(expr).coeff(Q_DDOT)
    if coeff == 0 or Q_DDOT in coeff.free_symbols:
        raise ModelError("structure: the equation must be linear in q'' with a non-zero coefficient")
    rest = sp.expand(expr - coeff * Q_DDOT)
    acc = (-rest / coeff).xreplace({Q: Q1, Q_DOT: Q2, H: force})
    el_rhs = tuple(e.xreplace(drive) for el in (element,) + extras for e in el.rhs)
    comp = (
        ("element", element.name),
        ("element_model", element),
        ("element_effects", element.effects),
        ("elements", (element,) + extras),
        ("element_states", element.states),
        ("structure_states", (Q1, Q2)),
        ("force", force),
        ("length_unit", float(length_unit)),
        ("equation", equation),
        ("n_structure_params", len(params)),
    )
    model = SymbolicModel(
        name=name,
        states=(Q1, Q2) + sum((e.states for e in (element,) + extras), ()),
        inputs=(FORCE,),
        params=tuple(params) + sum((e.params for e in (element,) + extras), ()),
        rhs=(Q2, acc) + el_rhs,
        output=Q1,
        output_name="q",
        structural=element.structural,
        position=Q1,
        velocity=Q2,
        equation=None,
        description=f"structure m q'' + c q' + k q + H = F with H the force of the {element.name} element "
        f"driven by (q, q'){'' if L == 1 else f' / {length_unit:g}'}",
    )
    return replace(model, composition=comp)


def renamed(model: SymbolicModel, suffix: str) -> SymbolicModel:
    """A copy of a two-state element whose states and parameters carry ``suffix`` (a second element in parallel)."""
    from duffsym.model.symbols import param_symbol

    specs = tuple(replace(p, name=p.name + suffix, latex=p.latex + suffix.replace("_", r"\,")) for p in model.params)
    sub = {p.symbol: q.symbol for p, q in zip(model.params, specs)}
    new_states = tuple(state_symbol(str(s) + suffix) for s in model.states)
    sub.update(dict(zip(model.states, new_states)))
    del param_symbol
    return replace(
        model,
        states=new_states,
        params=specs,
        rhs=tuple(e.xreplace(sub) for e in model.rhs),
        output=model.output.xreplace(sub),
        position=sub.get(model.position),
        velocity=sub.get(model.velocity),
        name=model.name + suffix,
    )


def _check_element(element: SymbolicModel) -> None:
    if element.n_states != 2 or element.position is None or element.velocity is None:
        raise ModelError(
            f"structure: the element must be a two-state mechanical model; {element.name} has "
            f"{element.n_states} state(s)"
        )
    bad = [c.name for c in element.inputs if c.signal != "d" or c.order > 1]
    if bad:
        raise ModelError(
            f"structure: the element may be driven by d and d_dot only (the structure's q, q'); "
            f"{element.name} also needs {bad}: apply that effect to the composed model instead"
        )
    if set(element.states) & {Q1, Q2}:
        raise ModelError("structure: the element's states must not be named q1, q2")


def composition(model: SymbolicModel) -> dict | None:
    """The parts of a composed model (see :func:`structure`), or None for a single model."""
    comp = getattr(model, "composition", ())
    return dict(comp) if comp else None


def is_structure(model: SymbolicModel) -> bool:
    return composition(model) is not None


def element_input_channels() -> tuple[InputChannel, ...]:
    return (InputChannel("d", 0), InputChannel("d", 1))
