"""Terms found outside the catalogue, as a model extension: :class:`DiscoveredEffect`.

``y += Σ c_i·term_i`` with terms in the piston motion ``d, d', d''`` and the model's mechanical states
``x, x'``, found by :func:`duffsym.diagnose.discover.discover_term` (sparse regression of what a fitted
model misses). Like every effect it is a model extension and imports no fitting code; its name,
``"discovered: +0.3019·tanh(d'/0.27) on the output"``, says the term in words and is enough to
rebuild it (:func:`from_name`, used when a saved fit is read back).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from duffsym.effects.base import Effect
from duffsym.errors import ModelError
from duffsym.model.core import InputChannel, SymbolicModel
from duffsym.model.symbols import ParamSpec, state_symbol

PREFIX = "discovered: "
SUFFIX = " on the output"

D, DD, DDD = state_symbol("d"), state_symbol("d_dot"), state_symbol("d_ddot")
COMMAND = state_symbol("command")
#: how the signals are printed in words and in LaTeX
_WORDS = {"d": "d", "d_dot": "d'", "d_ddot": "d''", "x": "x", "x_dot": "x'", "command": "command"}
_TEX = {"d": "d", "d_dot": r"\dot{d}", "d_ddot": r"\ddot{d}", "x": "x", "x_dot": r"\dot{x}", "command": "i"}


# ---------------------------------------------------------------------------------------------- the effect
#: input signals a record provides that are not its input column (a measured command, a drift signal)
_NOT_DRIVING = ("command", "time", "energy")


def driving_signal(model: SymbolicModel) -> str:
    """The name the model gives the record's input column: its first input signal that is not a command or a
    drift signal (``d`` for a damper, ``F`` for duffing-gain); ``d`` when it has none."""
    return next((ch.signal for ch in model.inputs if ch.signal not in _NOT_DRIVING), "d")


@dataclass(frozen=True)
class DiscoveredEffect(Effect):
    """``y += Σ c_i·term_i``: terms found by :func:`duffsym.diagnose.discover.discover_term`, coefficients
    ``disc{index}_c{i}`` (terms in SymPy's canonical order).

    Acts on the output (the measured force), like the catalogue's output effects; the terms are
    functions of the model's states and the piston motion. ``coefs`` are the starting values (from
    the regression, or the fitted values when rebuilt with them) and appear in the name.
    """

    terms: tuple = ()
    coefs: tuple = ()
    index: int = 1
    name: str = field(default="", init=False)
    prefix: str = field(default="", init=False)
    physics: str = field(default="", init=False)
    form: str = field(default="", init=False)

    def __post_init__(self):
        # a canonical term order, so that the parameter names follow from the terms (see from_name)
        pairs = sorted(zip(self.terms, self.coefs), key=lambda tc: sp.default_sort_key(tc[0]))
        object.__setattr__(self, "terms", tuple(t for t, _ in pairs))
        object.__setattr__(self, "coefs", tuple(float(c) for _, c in pairs))
        object.__setattr__(self, "prefix", f"disc{self.index}_")
        object.__setattr__(self, "name", "discovered: " + term_words(self.expression(self.coefs)) + " on the output")
        object.__setattr__(self, "physics", "; ".join(resembles(t) or describe(t) for t in self.terms))
        object.__setattr__(self, "form", "y += " + str(self.expression()))

    def parameters(self) -> tuple[ParamSpec, ...]:
        return tuple(
            ParamSpec(
                f"{self.prefix}c{i + 1}",
                f"c_{{d{self.index},{i + 1}}}",
                float(c),
                -1e9,
                1e9,
                unit="output unit / term unit",
                scale=max(abs(float(c)), 1e-6),
                description=f"coefficient of {term_words(t)} (discovered)",
            )
            for i, (t, c) in enumerate(zip(self.terms, self.coefs))
        )

    def expression(self, values=None) -> sp.Expr:
        """``Σ c_i·term_i`` with the parameter symbols, or with ``values`` (numbers) in their place."""
        cs = [p.symbol for p in self.parameters()] if values is None else [sp.Float(v, 4) for v in values]
        return sp.Add(*[c * t for c, t in zip(cs, self.terms)])

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        # the library's x, x' are the model's mechanical states (position, velocity); its d, d', d'' are the record's
        # input column and its derivatives, which the model calls by its driving signal's name (F for a force-driven
        # oscillator such as duffing-gain on Silverbox)
        subs = {state_symbol(k): s for k, s in (("x", model.position), ("x_dot", model.velocity)) if s is not None}
        drive = driving_signal(model)
        channels = [InputChannel(drive, order) for order in range(3)]
        subs |= {lib: ch.symbol for lib, ch in zip((D, DD, DDD), channels)}
        expr = self.expression().xreplace(subs)
        known = {c.symbol for c in model.inputs} | set(model.states) | {p.symbol for p in self.parameters()}
        extra = tuple(ch for ch in channels if ch.symbol in expr.free_symbols and ch.symbol not in known)
        known |= {ch.symbol for ch in extra}
        if COMMAND in expr.free_symbols and COMMAND not in known:  # a measured command (current, pressure)
            extra += (InputChannel("command", 0),)
            known |= {COMMAND}
        missing = expr.free_symbols - known
        if missing:
            raise ModelError(f"{self.name}: model {model.name} has no signal(s) {sorted(map(str, missing))}")
        return model.extend(effect=self.name, params=self.parameters(), inputs=extra, output_add=expr)

    def base_output(self, y, record, params):
        cols = _record_signals(record)
        if any(str(s) not in cols for t in self.terms for s in t.free_symbols):
            return y  # a term on the model's states: not known before the fit
        out = np.asarray(y, dtype=float).copy()
        for p, t in zip(self.parameters(), self.terms):
            out -= params[p.name] * _evaluate(t, cols)
        return out


def _record_signals(record) -> dict[str, np.ndarray]:
    return {
        "d": np.asarray(record.d, float),
        "d_dot": np.asarray(record.velocity(), float),
        "d_ddot": np.asarray(record.acceleration(), float),
    }


def _evaluate(term: sp.Expr, cols: Mapping[str, np.ndarray]) -> np.ndarray:
    syms = sorted(term.free_symbols, key=str)
    f = sp.lambdify(syms, term, "numpy")
    n = len(next(iter(cols.values())))
    return np.broadcast_to(np.asarray(f(*[cols[str(s)] for s in syms]), float), (n,)).copy()


# ---------------------------------------------------------------------------------------------- words
def term_words(expr: sp.Expr) -> str:
    """``+0.156·tanh(d'/0.02) - 3.1·d`` — a SymPy expression printed with primes and a middle dot."""
    text = sp.sstr(expr, full_prec=False)
    for key in ("d_ddot", "d_dot", "x_dot"):
        text = text.replace(key, _WORDS[key])
    text = re.sub(r"tanh\(([0-9.e+-]+)\*([a-z_']+)\)", lambda m: f"tanh({m[2]}/{1 / float(m[1]):.2g})", text)
    text = re.sub(
        r"exp\(-([0-9.e+-]+)\*([a-z_']+)\*\*2\)", lambda m: f"exp(-({m[2]}/{1 / float(m[1]) ** 0.5:.2g})**2)", text
    )
    text = text.replace("**", "^").replace("*", "·")
    return text if text.startswith("-") else "+" + text


def term_latex(expr: sp.Expr) -> str:
    return sp.latex(expr, symbol_names={state_symbol(k): v for k, v in _TEX.items()})


def _kind(term: sp.Expr) -> tuple[str | None, str]:
    """(signal key, shape) of a library term. Without a switch: constant, linear, square, cube (one signal)
    or product. With a switch of a velocity ``v`` (``tanh(v/ε)``, Stribeck ``exp(-(v/v_s)²)·tanh(v/ε)``):
    sign, abs (``v·tanh``), sabs (``v²·tanh``) or stribeck; times a polynomial in another signal ``s``:
    key ``"s|v"``, shape ``stroke-<shape>`` (e.g. ``d²·tanh(d'/ε)``: ``("d|d_dot", "stroke-sign")``), or
    stroke-direction when the factor is odd in ``s``."""
    syms = sorted(map(str, term.free_symbols))
    if not syms:
        return "1", "constant"
    factors = sp.Mul.make_args(term)
    switch = [a for a in factors if isinstance(a, (sp.tanh, sp.exp))]
    poly = sp.Mul(*[a for a in factors if not isinstance(a, (sp.tanh, sp.exp))])
    if not switch:
        if len(syms) != 1:
            return None, "product"
        deg = int(sp.degree(poly, state_symbol(syms[0])))
        return syms[0], {1: "linear", 2: "square", 3: "cube"}.get(deg, "power")
    vel = sorted({str(s) for a in switch for s in a.free_symbols})
    if len(vel) != 1:
        return None, "product"
    v = state_symbol(vel[0])
    deg = int(sp.degree(poly, v)) if poly.has(v) else 0
    shape = (
        "stribeck" if any(isinstance(a, sp.exp) for a in switch) else {0: "sign", 1: "abs", 2: "sabs"}.get(deg, "power")
    )
    others = sorted(map(str, poly.free_symbols - {v}))
    if not others:
        return vel[0], shape
    if len(others) == 1 and shape in ("sign", "stribeck"):
        k = int(sp.degree(poly, state_symbol(others[0])))
        level = k % 2 == 0 or others[0] == "command"  # a command's level is not a direction of the stroke
        return f"{others[0]}|{vel[0]}", ("stroke-" + shape) if level else "stroke-direction"
    return None, "stroke-direction"


_RESEMBLES = {
    ("d_dot", "sign"): "friction on the piston velocity (seal friction F_c·sign d'; the catalogue's "
    "coulomb-friction acts on the internal velocity x' instead)",
    ("d_dot", "stribeck"): (
        "Stribeck friction on the piston velocity: a static peak that decays with the sliding "
        "speed (the catalogue's seal-friction has one constant level)"
    ),
    ("d|d_dot", "stroke-sign"): (
        "seal friction whose level changes over the stroke (with d²: grows toward the "
        "stroke ends; the catalogue's seal-friction has one constant level)"
    ),
    ("d|d_dot", "stroke-stribeck"): "a Stribeck friction peak whose height changes over the stroke",
    ("command|d_dot", "stroke-sign"): (
        "a friction or yield force on the piston whose level follows the command (a seal pressed by the "
        "pressure, an MR fluid's yield growing with the current: the rate module's field-yield)"
    ),
    ("command|d_dot", "stroke-stribeck"): "a Stribeck friction peak whose height follows the command",
    ("command|x_dot", "stroke-sign"): "a friction on the internal velocity x' whose level follows the command",
    ("x_dot", "sign"): "coulomb-friction (dry friction on the internal velocity x')",
    (
        "x_dot",
        "stribeck",
    ): "a Stribeck-shaped friction on the internal velocity x' (coulomb-friction with a static peak)",
    ("x_dot", "abs"): "asymmetry (force level differs between compression and extension)",
    ("d_dot", "abs"): "asymmetry (an even-in-velocity force: compression vs extension)",
    ("d", "linear"): "gas-accumulator (stiffness on the piston displacement)",
    ("d", "square"): (
        "position-dependent stiffness on the piston (a nonlinear gas spring; the catalogue's "
        "gas-accumulator is linear in d)"
    ),
    ("d", "cube"): (
        "position-dependent stiffness on the piston (a hardening spring; the catalogue's "
        "gas-accumulator is linear in d)"
    ),
    ("d_ddot", "linear"): "inertia (force proportional to the piston acceleration)",
    ("d_dot", "linear"): "viscous damping on the piston velocity (the model's c1 term)",
    ("d_dot", "sabs"): "quadratic (orifice) damping on the piston velocity, d'|d'|",
    ("d_dot", "square"): "quadratic (orifice-like) force in the piston velocity, even in d'",
    ("x_dot", "cube"): "cubic-damping (here on the output rather than in the state equation)",
    ("x", "square"): "quadratic-stiffness (here on the output rather than in the state equation)",
    ("d_dot", "cube"): "a cubic damping on the piston velocity",
    ("1", "constant"): "force-offset (a constant force)",
    (None, "stroke-direction"): (
        "asymmetry that grows over the stroke (compression vs extension, displacement-dependent)"
    ),
}


def resembles(term: sp.Expr) -> str:
    """The catalogue effect (or known physics) a term resembles, '' if none."""
    return _RESEMBLES.get(_kind(term), "")


#: library term kinds (:func:`_kind`) that *are* a catalogued effect's term on the output, by effect
_SAME_AS: dict[tuple[str | None, str], tuple[str, ...]] = {
    ("1", "constant"): ("force-offset", "gas-accumulator"),
    ("d", "linear"): ("gas-accumulator",),
    ("d_ddot", "linear"): ("inertia",),
    ("d_dot", "linear"): ("parallel-damping",),
    ("d_dot", "sign"): ("seal-friction",),
}


def duplicates(term: sp.Expr, effects) -> str:
    """The effect among ``effects`` (names) whose output term ``term`` already is ('' if none): a library term
    that only repeats an added effect's term cannot be a new discovery, and a stability selection that keeps it
    hides the terms that could be."""
    return next((e for e in _SAME_AS.get(_kind(term), ()) if e in effects), "")


def describe(term: sp.Expr) -> str:
    key, shape = _kind(term)
    if key is None or "|" in key:
        return f"a product term {term_words(term).lstrip('+')}"
    return f"{shape} term in {_WORDS.get(key, key)}"


def from_name(name: str, index: int = 1) -> DiscoveredEffect:
    """The effect whose :attr:`DiscoveredEffect.name` is ``name`` (its terms and rounded coefficients)."""
    if not (name.startswith(PREFIX) and name.endswith(SUFFIX)):
        raise ModelError(f"{name!r} is not the name of a discovered term ('{PREFIX}... {SUFFIX.strip()}')")
    text = name[len(PREFIX) : -len(SUFFIX)]
    for key in ("d_ddot", "d_dot", "x_dot"):
        text = text.replace(_WORDS[key], key)
    text = text.replace("^", "**").replace("·", "*")
    syms = {k: state_symbol(k) for k in _WORDS}
    try:
        expr = sp.sympify(text, locals=syms)
    except (sp.SympifyError, SyntaxError, TypeError) as exc:
        raise ModelError(f"cannot read the discovered term {name!r}: {exc}") from None
    terms, coefs = [], []
    for arg in sp.Add.make_args(sp.expand(expr, deep=False)):
        c, t = arg.as_coeff_Mul()
        terms.append(t)
        coefs.append(float(c))
    eff = DiscoveredEffect(tuple(terms), tuple(coefs), index)
    if eff.name != name:
        raise ModelError(f"cannot rebuild the discovered term {name!r} (read back as {eff.name!r})")
    return eff
