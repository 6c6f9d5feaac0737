r"""A gap in the linkage between the actuator and a friction (or other hysteretic) element: the contact gap.

Where it acts: in series with the element, between it and the actuator. While the actuator crosses the gap
the linkage carries no force, so the measured force sits at zero over a stretch ``2h`` of actuator travel after
every reversal, and the element's force resumes on the other side of the gap.

Why it is not the catalogue's ``backlash``: :class:`~duffsym.effects.inputs.Backlash` holds the element's input
still while the actuator crosses the gap, so the element keeps whatever force it had: a viscous element (an MR
damper) then relaxes to zero force, but a rate-independent one (a friction brake, a Dahl or elasto-plastic
element) holds its sliding force over the gap. The real banded friction damper with linkage play
(``friction_damper_brfd_artslab``) shows the zero-force plateau in the middle of the steep branch after every
reversal: the force falls from its sliding level to zero, stays there for about 0.2 in of travel, and rises to the
opposite level. For a rigid linkage and an element whose branch after a reversal is elastic with stiffness
:math:`k_e`, the force of element and gap in series is the element's force passed through a deadzone of
half-width :math:`w = k_e h` in force:

.. math:: y \leftarrow \operatorname{dz}(y_e) = y_e + \tfrac12\Big(\sqrt{(y_e - w)^2 + \delta^2}
          - \sqrt{(y_e + w)^2 + \delta^2}\Big), \qquad \delta = w / s

a smooth deadzone (``s = 5``): odd, with slope between 0 and 1 (:math:`\delta^2/2w^2 \approx 0.02` at zero
force), equal to :math:`y_e \mp w` beyond the gap. The element then carries :math:`w` more than the measured
force, which its own parameters take up.

Certificate: the effect changes the output map only, so the state equations and the Lyapunov argument of
``duffsym derive`` are those of the base model; the output is bounded by the element's, :math:`|y| \le |y_e|`,
and has the element's sign, :math:`y\,y_e \ge 0`, so the gap takes no power from the linkage that the element
does not dissipate: :math:`\oint y\,\mathrm d d` over a cycle of a dissipative element stays positive.

The half-width in displacement is what the data show and what a user asks for; the deadzone is written in force
because :math:`k_e` is the element's, not a parameter of its own (``w`` and ``k_e h`` are one term). The
fitted model's zero-force stretch, measured as the data's (:func:`~duffsym.effects.inputs.plateau_half_width`
on its free run), gives ``h``: see :func:`gap_half_width`.

Initial guess: the plateau half-width the data show times the slope of the base model's force where it crosses
zero after a reversal (the branch the gap will split).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import sympy as sp

from duffsym.effects.base import Effect, _not_significant, residual
from duffsym.effects.inputs import plateau_half_width
from duffsym.model.core import SymbolicModel
from duffsym.model.symbols import ParamSpec

#: The diagnosis tries the contact gap only on records whose zero-force plateaus span at least this fraction of
#: the stroke (:meth:`ContactGap.relevance`).
MIN_PLATEAU = 0.01


def smooth_deadzone(y, w, delta, sqrt: Callable = np.sqrt):
    """The smooth deadzone of half-width ``w`` and corner width ``delta``: odd, slope in [0, 1], ``y -/+ w`` far
    outside the gap (``sqrt``: :func:`numpy.sqrt` for arrays, :func:`sympy.sqrt` for expressions)."""
    return y + (sqrt((y - w) ** 2 + delta**2) - sqrt((y + w) ** 2 + delta**2)) / 2


def _zero_crossing_slope(record, y_model) -> float:
    """Median slope ``|dy/dd|`` of ``y_model`` where it crosses the low-force band (``|y| < 0.3 max|y|``) while the
    actuator moves: the stiffness of the branch a gap would split (0 when it cannot be told)."""
    d = np.asarray(record.d, dtype=float)
    y = np.asarray(y_model, dtype=float)
    dy, dd = np.diff(y), np.diff(d)
    mid = 0.5 * (y[1:] + y[:-1])
    top = float(np.max(np.abs(y))) or 1.0
    ok = (np.abs(mid) < 0.3 * top) & (np.abs(dd) > 1e-9 * (float(np.ptp(d)) or 1.0))
    s = np.abs(dy[ok] / dd[ok])
    s = s[np.isfinite(s)]
    return float(np.median(s)) if s.size else 0.0


def gap_half_width(record, y_fit, w: float, w_se: float = math.nan) -> tuple[float, float]:
    """The play half-width ``h`` of a fitted contact gap, in input units, with its standard error.

    ``h`` is the half travel over the zero-force stretch after the reversals of the fitted model's free run
    ``y_fit``, measured exactly as on the data (:func:`~duffsym.effects.inputs.plateau_half_width`), so the two
    compare directly. Its standard error is first order in the gap force alone, ``h se(w)/w`` (the element's
    stiffness, which also sets ``h = w/k_e``, is held at its fitted value): a lower bound."""
    h = plateau_half_width(record.replace(y=np.asarray(y_fit, dtype=float)))
    se = h * w_se / w if w > 0 and math.isfinite(w_se) else math.nan
    return h, se


@dataclass(frozen=True)
class ContactGap(Effect):
    """A gap (play) in the linkage in series with the element: no force while the actuator crosses it.

    See the module docstring (:mod:`duffsym.effects.gap`) for the physics, the form, why it differs from
    ``backlash`` and its certificate.
    """

    name: str = "contact-gap"
    prefix: str = "gap_"
    physics: str = (
        "play in the linkage in series with the element: the force is zero while the actuator crosses the gap "
        "after each reversal (a friction brake behind a loose joint)"
    )
    signature: str = (
        "flat zero-force plateaus in the middle of the steep branch after each reversal, with the element's "
        "sliding force held on both sides; residual concentrated just after reversals"
    )
    form: str = "y -> dz(y) = y + (sqrt((y-gap_w)^2+delta^2) - sqrt((y+gap_w)^2+delta^2))/2, delta = gap_w/5"
    guess: str = "gap_w = the data's plateau half-width times the base model's slope dy/dd at zero force"
    sharpness: float = 5.0

    def parameters(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec(
                f"{self.prefix}w",
                "w_{g}",
                0.1,
                1e-9,
                1e9,
                unit="output unit",
                scale=0.1,
                description="the element's force over the half-gap (w = k_e h): the deadzone's half-width in force",
            ),
        )

    def _extend(self, model: SymbolicModel) -> SymbolicModel:
        (wp,) = self.parameters()
        w = wp.symbol
        out = smooth_deadzone(model.output, w, w / sp.Float(self.sharpness), sqrt=sp.sqrt)
        return model.extend(effect=self.name, params=(wp,), output=out)

    def initial_guess(self, record, y_model) -> dict[str, float]:
        residual(record, y_model)
        name = f"{self.prefix}w"
        top = float(np.max(np.abs(np.asarray(record.y, dtype=float)))) or 1.0
        w = plateau_half_width(record) * _zero_crossing_slope(record, y_model)
        return {name: self._clip(name, min(max(w, 0.02 * top), 0.8 * top))}

    def record_bounds(self, record) -> dict[str, tuple[float, float]]:
        """``gap_w`` between 1e-4 and 2 times the largest measured force (a gap force far beyond the force the
        element shows cannot be told from a wider element)."""
        top = float(np.max(np.abs(np.asarray(record.y, dtype=float)))) or 1.0
        return {f"{self.prefix}w": (1e-4 * top, 2.0 * top)}

    def relevance(self, record) -> str:
        """Why the diagnosis need not try the gap on ``record`` ("" when it should): no zero-force plateau of at
        least ``MIN_PLATEAU`` of the stroke after the reversals."""
        stroke = float(np.ptp(np.asarray(record.d, dtype=float))) or 1.0
        h = plateau_half_width(record)
        if h < MIN_PLATEAU * stroke:
            pct = 100 * h / stroke
            return f"no zero-force plateau after the reversals (half-width {h:.3g}, {pct:.2g} % of the stroke)"
        return ""

    def activity(self, record, params: Mapping[str, float], stderr=None) -> str:
        name = f"{self.prefix}w"
        top = float(np.max(np.abs(np.asarray(record.y, dtype=float)))) or 1.0
        w = float(params[name])
        if w < 0.01 * top:
            return f"its gap force is negligible ({name} = {w:.3g}, {100 * w / top:.2g} % of the largest force)"
        return _not_significant(name, params, dict(stderr or {}))

    def base_output(self, y, record, params) -> np.ndarray:
        """The element's force before the gap: ``y + w sign(y)`` (smoothed over a twentieth of ``w``)."""
        w = float(params[f"{self.prefix}w"])
        return np.asarray(y, dtype=float) + w * np.tanh(np.asarray(y, dtype=float) / (0.05 * w + 1e-300))
