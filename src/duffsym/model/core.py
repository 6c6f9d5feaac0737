"""The symbolic model: the single source of truth from which every numeric form is generated."""

from __future__ import annotations

import hashlib
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
import sympy as sp

from duffsym.errors import ModelError
from duffsym.model.symbols import LATEX_NAMES, ParamSpec, state_symbol


@dataclass(frozen=True)
class InputChannel:
    """One column of the model's input vector: a signal or one of its time derivatives.

    ``InputChannel("d", 1)`` is the piston velocity :math:`\\dot d`.
    """

    signal: str
    order: int = 0

    @property
    def name(self) -> str:
        return self.signal + ("", "_dot", "_ddot", "_dddot")[self.order]

    @property
    def symbol(self) -> sp.Symbol:
        return state_symbol(self.name)


@dataclass(frozen=True, eq=False)
class SymbolicModel:
    """A continuous-time input–output model held as SymPy expressions.

    The state equation is :math:`\\dot{\\mathbf x} = \\mathbf{rhs}(\\mathbf x, \\mathbf u, \\theta)` and
    the output :math:`y = h(\\mathbf x, \\mathbf u, \\theta)`. Symbols are kept in explicit, ordered
    tuples: generated code takes ``(x, u, p)`` in exactly this order.

    Parameters
    ----------
    name : model name used by the CLI (``duffsym models``).
    states : ordered state symbols.
    inputs : ordered input channels (a signal and its derivatives, e.g. ``d`` and ``d_dot``).
    params : ordered parameter specifications.
    rhs : time derivative of each state.
    output : output expression; ``output_name`` names it (``"y"`` for the force).
    structural : structural integers (e.g. ``{"n_x": 5, "n_v": 5}``), not identified.
    position, velocity : the mechanical state pair (x, x') used by the Lyapunov derivations.
    equation : the defining second-order equation in ``x, x_dot, x_ddot`` (for display), if any.
    effects : names of the effects applied to the base model, in order (the effect objects, with their
        settings, are :attr:`effect_objects`; the model before them :attr:`base_model`).
    composition : the parts of a composed model (:func:`duffsym.model.structure.structure`), else empty.
    lineage : set by :meth:`duffsym.effects.Effect.apply` on the model it builds: ``(key, parent, effect)``,
        the model's own equation hash, the model the effect was applied to and the effect object. A copy
        whose equations differ (``dataclasses.replace`` with new equations) no longer matches its key, so
        its lineage is ignored; a copy with new parameter defaults (:meth:`with_params`) keeps it.
    """

    name: str
    states: tuple[sp.Symbol, ...]
    inputs: tuple[InputChannel, ...]
    params: tuple[ParamSpec, ...]
    rhs: tuple[sp.Expr, ...]
    output: sp.Expr
    output_name: str = "y"
    structural: tuple[tuple[str, int | sp.Symbol], ...] = ()
    position: sp.Symbol | None = None
    velocity: sp.Symbol | None = None
    equation: sp.Eq | None = None
    effects: tuple[str, ...] = ()
    description: str = ""
    composition: tuple = ()  # (key, value) pairs of a composed model (duffsym.model.structure), else ()
    lineage: tuple = field(default=(), repr=False, compare=False)  # (key, parent model, effect object) or ()
    _key: str = field(init=False, repr=False, compare=False, default="")

    def __hash__(self) -> int:  # the equations' hash, cheap: generated code is cached per model
        return hash(self._key)

    def __eq__(self, other) -> bool:
        return isinstance(other, SymbolicModel) and self._key == other._key and self.params == other.params

    def __post_init__(self) -> None:
        if len(self.rhs) != len(self.states):
            raise ModelError(
                f"model {self.name}: {len(self.rhs)} state equations for {len(self.states)} states; give one each"
            )
        names = [p.name for p in self.params]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ModelError(f"model {self.name}: parameter names repeated: {sorted(dup)}; prefix effect parameters")
        object.__setattr__(self, "rhs", tuple(sp.sympify(e) for e in self.rhs))
        object.__setattr__(self, "output", sp.sympify(self.output))
        known = set(self.states) | {c.symbol for c in self.inputs} | {p.symbol for p in self.params}
        known |= {v for _, v in self.structural if isinstance(v, sp.Symbol)}
        for i, expr in enumerate((*self.rhs, self.output)):
            stray = expr.free_symbols - known
            if stray:
                where = f"equation of state {self.states[i]}" if i < len(self.rhs) else "output"
                raise ModelError(
                    f"model {self.name}: unknown symbol(s) {sorted(map(str, stray))} in the {where}; "
                    "declare them as states, inputs or parameters"
                )
        text = sp.srepr((self.states, tuple(c.name for c in self.inputs), tuple(names), self.rhs, self.output))
        object.__setattr__(self, "_key", hashlib.sha1(text.encode()).hexdigest()[:16])

    # ------------------------------------------------------------------ names and lookups
    @property
    def key(self) -> str:
        """Stable hash of the equations; generated code is cached under it."""
        return self._key

    @cached_property
    def param_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.params)

    @cached_property
    def param_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(p.symbol for p in self.params)

    @cached_property
    def input_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(c.symbol for c in self.inputs)

    @cached_property
    def state_names(self) -> tuple[str, ...]:
        return tuple(str(s) for s in self.states)

    @property
    def n_states(self) -> int:
        return len(self.states)

    @property
    def n_inputs(self) -> int:
        return len(self.inputs)

    @property
    def n_params(self) -> int:
        return len(self.params)

    @property
    def signals(self) -> dict[str, int]:
        """Input signals and the highest derivative order the model uses of each."""
        out: dict[str, int] = {}
        for c in self.inputs:
            out[c.signal] = max(out.get(c.signal, 0), c.order)
        return out

    def structural_value(self, name: str):
        return dict(self.structural)[name]

    def param(self, name: str) -> ParamSpec:
        for p in self.params:
            if p.name == name:
                return p
        raise ModelError(f"unknown parameter {name!r} for model {self.name}; known: {', '.join(self.param_names)}")

    def defaults(self) -> dict[str, float]:
        return {p.name: p.default for p in self.params}

    def param_vector(
        self, values: Mapping[str, float] | Sequence[float] | np.ndarray | None = None, *, fill_defaults: bool = False
    ) -> np.ndarray:
        """Ordered parameter vector from a mapping (checked) or a sequence (checked for length).

        Raises
        ------
        ModelError
            For an unknown name, a missing name (unless ``fill_defaults``), or a non-finite value.
        """
        if values is None:
            values = {}
        if isinstance(values, Mapping):
            unknown = set(values) - set(self.param_names)
            if unknown:
                raise ModelError(
                    f"unknown parameter(s) {sorted(unknown)} for model {self.name}; "
                    f"known: {', '.join(self.param_names)}"
                )
            missing = [n for n in self.param_names if n not in values]
            if missing and not fill_defaults:
                raise ModelError(f"model {self.name}: missing value(s) for {missing}; give them or use the defaults")
            merged = {**self.defaults(), **values}
            vec = np.array([float(merged[n]) for n in self.param_names])
        else:
            vec = np.asarray(values, dtype=float).reshape(-1)
            if vec.size != self.n_params:
                raise ModelError(
                    f"model {self.name} has {self.n_params} parameters ({', '.join(self.param_names)}); "
                    f"got a vector of length {vec.size}"
                )
        bad = [n for n, v in zip(self.param_names, vec) if not math.isfinite(v)]
        if bad:
            raise ModelError(f"model {self.name}: parameter(s) {bad} are not finite; give finite values")
        return vec

    def param_dict(self, vector: Sequence[float]) -> dict[str, float]:
        vec = self.param_vector(vector)
        return dict(zip(self.param_names, map(float, vec)))

    # ------------------------------------------------------------------ effects held as objects
    @property
    def applied(self) -> tuple[SymbolicModel, object] | None:
        """``(parent, effect)``: the model the last effect was applied to and that effect object; None when
        the model was not built by :meth:`duffsym.effects.Effect.apply` (or its equations changed since)."""
        if len(self.lineage) == 3 and self.lineage[0] == self._key:
            return self.lineage[1], self.lineage[2]
        return None

    def effect_steps(self) -> tuple[tuple[object, SymbolicModel], ...] | None:
        """Each effect object applied, in order, with the model after it; None if a step is not known."""
        steps, m = [], self
        while m.effects:
            step = m.applied
            if step is None:
                return None
            steps.append((step[1], m))
            m = step[0]
        return tuple(steps[::-1])

    @property
    def base_model(self) -> SymbolicModel | None:
        """The model before every effect (``self`` when it has none); None if the chain is not known."""
        m = self
        while m.effects:
            step = m.applied
            if step is None:
                return None
            m = step[0]
        return m

    @property
    def effect_objects(self) -> tuple | None:
        """The effect objects applied to :attr:`base_model`, in order (with their settings); None if unknown."""
        steps = self.effect_steps()
        return None if steps is None else tuple(e for e, _ in steps)

    # ------------------------------------------------------------------ composition
    def extend(
        self,
        *,
        effect: str,
        params: Iterable[ParamSpec] = (),
        states: Iterable[tuple[sp.Symbol, sp.Expr]] = (),
        inputs: Iterable[InputChannel] = (),
        rhs_add: Mapping[sp.Symbol, sp.Expr] | None = None,
        substitute: Mapping[sp.Symbol, sp.Expr] | None = None,
        output: sp.Expr | None = None,
        output_add: sp.Expr = sp.S.Zero,
    ) -> SymbolicModel:
        """A new model with an effect's terms, states and parameters added.

        Parameters
        ----------
        effect : the effect's name, appended to ``effects``.
        params : new parameters (their names must not clash).
        states : new ``(symbol, rhs)`` pairs appended to the state vector.
        inputs : new input channels (e.g. ``InputChannel("d", 2)`` for the piston acceleration).
        rhs_add : terms added to the equation of an existing state, keyed by the state symbol.
        substitute : replacements made in every existing equation and the output
            (e.g. the input ``d`` replaced by a backlash state).
        output : a replacement output expression, applied after ``substitute``.
        output_add : a term added to the output.
        """
        subs = dict(substitute or {})
        rhs = [e.xreplace(subs) if subs else e for e in self.rhs]
        for sym, term in (rhs_add or {}).items():
            if sym not in self.states:
                raise ModelError(f"effect {effect}: {sym} is not a state of model {self.name}")
            i = self.states.index(sym)
            rhs[i] = rhs[i] + term
        new_states = list(self.states)
        for sym, expr in states:
            new_states.append(sym)
            rhs.append(sp.sympify(expr))
        out = self.output.xreplace(subs) if subs else self.output
        if output is not None:
            out = sp.sympify(output)
        out = out + output_add
        new_inputs = list(self.inputs)
        for ch in inputs:
            if ch not in new_inputs:
                new_inputs.append(ch)
        return replace(
            self,
            states=tuple(new_states),
            inputs=tuple(new_inputs),
            params=self.params + tuple(params),
            rhs=tuple(rhs),
            output=out,
            effects=self.effects + (effect,),
            name=self.name,
            lineage=(),  # Effect.apply records the parent and the effect object
        )

    def with_params(self, **values: float) -> SymbolicModel:
        """A copy whose parameter defaults are replaced (the equations are unchanged)."""
        for k in values:
            self.param(k)
        params = tuple(replace(p, default=float(values[p.name])) if p.name in values else p for p in self.params)
        return replace(self, params=params)

    def substitute_params(self, values: Mapping[str, float | sp.Expr]) -> tuple[list[sp.Expr], sp.Expr]:
        """The state equations and output with some parameters replaced by numbers or expressions."""
        subs = {self.param(k).symbol: sp.sympify(v) for k, v in values.items()}
        return [e.xreplace(subs) for e in self.rhs], self.output.xreplace(subs)

    # ------------------------------------------------------------------ display
    def latex_symbol_names(self) -> dict[sp.Symbol, str]:
        names = {s: LATEX_NAMES.get(str(s), str(s)) for s in self.states}
        names.update({c.symbol: LATEX_NAMES.get(c.name, c.name) for c in self.inputs})
        names.update({p.symbol: p.latex for p in self.params})
        for _k, v in self.structural:
            if isinstance(v, sp.Symbol):
                names[v] = str(v)
        return names

    def latex(self, expr: sp.Expr) -> str:
        """LaTeX of an expression of this model, with the paper's symbol names."""
        return sp.latex(expr, symbol_names=self.latex_symbol_names())

    def summary(self) -> str:
        lines = [f"model {self.name}" + (f" + {', '.join(self.effects)}" if self.effects else "")]
        if self.description:
            lines.append(f"  {self.description}")
        lines.append(f"  states:  {', '.join(self.state_names)}")
        lines.append(f"  inputs:  {', '.join(c.name for c in self.inputs)}")
        lines.append(f"  params:  {', '.join(self.param_names)}")
        for k, v in self.structural:
            lines.append(f"  {k} = {v}")
        for s, e in zip(self.states, self.rhs):
            lines.append(f"  d{s}/dt = {e}")
        lines.append(f"  {self.output_name} = {self.output}")
        return "\n".join(lines)
