"""A parameter that drifts over the record, following a slow signal: :class:`ParameterDrift`.

``p -> p·(1 - a·u/u_ref)`` in every equation and the output, where ``u`` is a slow signal of the
record (:meth:`duffsym.data.Record.drift_signal`): ``"time"`` since the start, or ``"energy"``, the
work done on the device since the start (a damper turns it into heat: its fluid warms and its
damping falls). ``u_ref`` is fixed when the effect is made (the signal's value at the end of the
fitting part), so ``a`` is the relative change of ``p`` over that stretch: ``a = 0.3`` means ``p`` has
fallen by 30 % when ``u = u_ref``. Found by :func:`duffsym.diagnose.discover.discover_drift` from
windowed refits; like every effect it imports no fitting code. Its name,
``"drift: c3·(1 - a·E/1.2e+03)"``, is enough to rebuild it (:func:`from_name`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import sympy as sp

from duffsym.effects.base import Effect
from duffsym.errors import ModelError
from duffsym.model.core import InputChannel, SymbolicModel
from duffsym.model.symbols import ParamSpec

PREFIX = "drift: "
#: the signals, their letter in the name and what they are, in words
SIGNALS = {
    "time": ("t", "time since the record's start"),
    "energy": ("E", "the energy dissipated since the record's start (the work done on the device)"),
}
_LETTER = {v[0]: k for k, v in SIGNALS.items()}


@dataclass(frozen=True)
class ParameterDrift(Effect):
    """``parameter -> parameter·(1 - drift_a·u/scale)`` with ``u`` the record's ``signal``
    (``"time"`` or ``"energy"``); ``drift_a`` is the relative change of the parameter at ``u = scale``."""

    parameter: str = "c3"
    signal: str = "energy"
    scale: float = 1.0
    start: float = 0.0  # the starting value of drift_a (from the windowed refits)
    name: str = field(default="", init=False)
    prefix: str = field(default="drift_", init=False)
    physics: str = field(default="", init=False)
    form: str = field(default="", init=False)

    def __post_init__(self):
        if self.signal not in SIGNALS:
            raise ModelError(f"drift signal must be one of {sorted(SIGNALS)}; got {self.signal!r}")
        if not self.scale > 0:
            raise ModelError(f"drift scale must be positive; got {self.scale}")
        letter = SIGNALS[self.signal][0]
        object.__setattr__(self, "scale", float(f"{self.scale:.3g}"))
        object.__setattr__(self, "name", f"{PREFIX}{self.parameter}·(1 - a·{letter}/{self.scale:.3g})")
        object.__setattr__(self, "physics", f"{self.parameter} changes in proportion to {SIGNALS[self.signal][1]}")
        object.__setattr__(
            self, "form", f"{self.parameter} -> {self.parameter}*(1 - drift_a*{self.signal}/{self.scale:.3g})"
        )

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec(
                "drift_a",
                "a_{drift}",
                0.0,
                -0.95,
                0.95,
                unit="1",
                scale=0.1,
                description=f"relative change of {self.parameter} when {self.signal} reaches {self.scale:.3g}",
            ),
        )

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        if self.parameter not in model.param_names:
            raise ModelError(f"{self.name}: model {model.name} has no parameter {self.parameter!r}")
        if any(e.startswith(PREFIX) for e in model.effects):
            raise ModelError(f"{self.name}: model {model.name} already has a drifting parameter")
        (a,) = self.parameters()
        ch = InputChannel(self.signal, 0)
        p = model.param(self.parameter).symbol
        factor = 1 - a.symbol * ch.symbol / sp.Float(self.scale)
        return model.extend(effect=self.name, params=(a,), inputs=(ch,), substitute={p: p * factor})

    def initial_guess(self, record, y_model) -> dict[str, float]:
        return {"drift_a": self._clip("drift_a", float(self.start))}

    def latex(self, a: float | None = None) -> str:
        """The drifting parameter in LaTeX, with ``a`` (a number) or the symbol."""
        letter = SIGNALS[self.signal][0]
        coef = r"a_{drift}" if a is None else f"{a:.3g}"
        return rf"{self.parameter} \to {self.parameter}\left(1 - {coef}\,{letter}/{self.scale:.3g}\right)"

    def sentence(self, a: float) -> str:
        """One sentence: how much the parameter changes and with what."""
        way = "falls" if a > 0 else "rises"
        return (
            f"{self.parameter} {way} by {100 * abs(a):.0f} % over the fitting part, in proportion to "
            f"{SIGNALS[self.signal][1]} ({self.parameter}·(1 - {a:.3g}·{SIGNALS[self.signal][0]}/{self.scale:.3g}))"
        )


def from_name(name: str) -> ParameterDrift:
    """The effect whose :attr:`ParameterDrift.name` is ``name``."""
    m = re.fullmatch(r"drift: (\w+)·\(1 - a·([tE])/([0-9.e+-]+)\)", name)
    if m is None:
        raise ModelError(f"{name!r} is not the name of a drifting parameter ('drift: p·(1 - a·E/scale)')")
    return ParameterDrift(m[1], _LETTER[m[2]], float(m[3]))
