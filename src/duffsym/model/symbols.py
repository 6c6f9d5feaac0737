"""Symbols of the models: parameter specifications and the shared symbol table.

The symbol table maps a code name to its LaTeX form and unit. Formula-heavy code may use the
short names (``c1``, ``k3``, ``A_f``) because they are the paper's names and are listed here.

=========  ==================  =======================================================
code name  LaTeX               meaning
=========  ==================  =======================================================
x1, x2     x_1, x_2            fluid-mass displacement x and velocity x' (Eq. 4, 13)
d, d_dot   d, \\dot{d}          piston displacement and velocity (the input)
F          F                   driving force of the Duffing equation (Eq. 1)
gamma      \\gamma              linear damping (Eq. 1, 3)
alpha      \\alpha              linear stiffness (Eq. 1, 3)
beta       \\beta               cubic / n-th power stiffness (Eq. 1, 3)
delta      \\delta              n-th power damping (Eq. 3)
k1, c1     k_1, c_1            input spring and damper (Eq. 3, 11)
k2, c2     k_2, c_2            ground spring and damper (Eq. 11)
k3, c3     k_3, c_3            n-th power ground spring and damper (Eq. 11)
m          m                   suspended fluid mass (Eq. 11)
A_f        A_f                 output gain, y = A_f x' (Eq. 5, 14)
=========  ==================  =======================================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import sympy as sp

from duffsym.errors import ModelError


@dataclass(frozen=True)
class ParamSpec:
    """Specification of one model parameter.

    Parameters
    ----------
    name : code name (a valid Python identifier), e.g. ``"c1"``.
    latex : LaTeX of the symbol, e.g. ``"c_1"``.
    default : a typical value (used as an initial guess and by examples).
    lower, upper : bounds used by identification and priors (``lower < upper``).
    unit : physical unit, or ``"1"`` for the normalized model's dimensionless constants.
    scale : typical magnitude; identification divides by it so decision variables are O(1).
    description : one line for people.
    held : if not empty, the reason the fit holds this parameter at its default unless it is listed in
        ``free`` (a scaling symmetry makes it redundant, e.g. Spencer's A against alpha).
    """

    name: str
    latex: str
    default: float
    lower: float = -math.inf
    upper: float = math.inf
    unit: str = "1"
    scale: float | None = None
    description: str = ""
    held: str = ""
    symbol: sp.Symbol = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise ModelError(f"parameter name {self.name!r} is not a valid identifier; use letters, digits and _")
        if not (self.lower < self.upper):
            raise ModelError(
                f"parameter {self.name}: bounds must satisfy lower < upper, got [{self.lower}, {self.upper}]; "
                "swap or widen them"
            )
        if not math.isfinite(self.default):
            raise ModelError(f"parameter {self.name}: default must be finite, got {self.default}")
        object.__setattr__(self, "symbol", param_symbol(self.name, self.latex))

    @property
    def typical_scale(self) -> float:
        """Magnitude used to scale this parameter to O(1) in optimisation."""
        if self.scale is not None:
            return float(self.scale)
        return max(abs(self.default), 1e-3)


_SYMBOL_CACHE: dict[tuple[str, str], sp.Symbol] = {}


def param_symbol(name: str, latex: str | None = None) -> sp.Symbol:
    """The SymPy symbol of a parameter: real, and printed with its LaTeX name."""
    key = (name, latex or name)
    if key not in _SYMBOL_CACHE:
        _SYMBOL_CACHE[key] = sp.Symbol(name, real=True)
    return _SYMBOL_CACHE[key]


def state_symbol(name: str) -> sp.Symbol:
    """The SymPy symbol of a state or input signal (real)."""
    return sp.Symbol(name, real=True)


# LaTeX names of the signals and parameters, used by the LaTeX printer.
LATEX_NAMES: dict[str, str] = {
    "x1": "x_{1}",
    "x2": "x_{2}",
    "x": "x",
    "x_dot": r"\dot{x}",
    "x_ddot": r"\ddot{x}",
    "d": "d",
    "d_dot": r"\dot{d}",
    "d_ddot": r"\ddot{d}",
    "F": "F",
    "gamma": r"\gamma",
    "alpha": r"\alpha",
    "beta": r"\beta",
    "delta": r"\delta",
    "c1": "c_{1}",
    "c2": "c_{2}",
    "c3": "c_{3}",
    "k1": "k_{1}",
    "k2": "k_{2}",
    "k3": "k_{3}",
    "m": "m",
    "A_f": "A_{f}",
    "y": "y",
    "q1": "q_{1}",
    "q2": "q_{2}",
    "q": "q",
    "q_dot": r"\dot{q}",
    "q_ddot": r"\ddot{q}",
    "H": "H",
    "command": "i",
    "u_field": "u",
    "eta": r"\eta",
}
