"""The unit factors of a record and the maps between its units and the normalised ones (issue 24), the pieces
shared by the fit (:mod:`duffsym.identify.unitscale`) and the initial-state estimate of a free run
(:func:`duffsym.identify.states.start_state`). This module imports neither the problem nor the result.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

#: Input signals that carry the record's input unit (as :data:`duffsym.derive.units.INPUT_SIGNALS`) and the
#: dissipated energy (input x output units).
INPUT_SIGNALS = ("d", "F", "energy")

#: Peaks in [10^-1.5, 10^1.5) are left as they are (the fit is bit for bit the one in the record's units).
UNIT_BAND = (10**-1.5, 10**1.5)
#: Output factors within this band are not applied (see :func:`duffsym.identify.unitscale.record_factors`).
OUTPUT_BAND = (1e-3, 1e3)


def unit_factor(peak: float) -> float:
    """The power of 1000 nearest ``peak`` on a log scale (1.0 within :data:`UNIT_BAND`)."""
    if not (math.isfinite(peak) and peak > 0):
        return 1.0
    return float(1000.0 ** round(math.log10(peak) / 3))


def model_record_factors(model, records) -> tuple[float, float]:
    """``(a, b)`` of ``model`` on ``records``: :func:`duffsym.identify.unitscale.record_factors` without a problem."""
    uses_input = any(ch.signal in INPUT_SIGNALS for ch in model.inputs)
    a = unit_factor(max(float(np.max(np.abs(r.d))) for r in records)) if uses_input else 1.0
    b = unit_factor(max(float(np.max(np.abs(r.y))) for r in records))
    return a, (1.0 if OUTPUT_BAND[0] <= b <= OUTPUT_BAND[1] else b)


def normalised_run(model, params: Mapping[str, float], record):
    """``(parameters, record, states back)`` of a free run of ``model`` on ``record`` in the normalised units
    (as a fit would run it; the states back to the record's units with ``states back(x)``), or None when the
    record is at unit scale or the model has no map (the caller then works in the record's units).

    Used by the initial-state estimate of a free run (:func:`duffsym.identify.states.start_state`): its
    least-squares differences of a run in the record's units lose digits where the units make the
    parameters large and cancelling (``c1 + c2`` of ~1e13 each at an input in 1e-12 units)."""
    a, b = model_record_factors(model, [record])
    if (a == 1.0 and b == 1.0) or bool(getattr(model, "composition", ())):
        return None
    from duffsym.derive.units import find_unit_scaling

    scaling = find_unit_scaling(model)
    if not scaling.applies(a, b) or not scaling.diagonal:
        return None
    p = scaling.apply(params, 1 / a, 1 / b)  # the inverse map (each parameter times a factor)
    back = 1.0 / np.array(scaling.state_factors(1 / a, 1 / b))
    sym = state_symmetry(model)
    if "A_f" in model.param_names and sym.exists and sym.tangent.get("A_f", 0) != 0:
        try:  # the ratio A_f / max|y| kept, as in a fit
            s = gauge_factor(sym, "A_f", p, float(params["A_f"]) / b)
            p = sym.apply(p, s)
        except ValueError:  # no positive gauge factor (A_f <= 0): the record's units
            return None
        back = back / np.array([s if x in sym.scaled_states else 1.0 for x in model.states])
    rec = normalised_records([record], a, b)[0]
    return p, rec, lambda x: np.asarray(x, dtype=float) * back


def state_symmetry(model):
    """The model's state-scaling symmetry (:func:`duffsym.derive.symmetry.find_scaling_symmetry`, which keeps each
    model's), imported when first needed: SymPy is not loaded at start-up."""
    from duffsym.derive.symmetry import find_scaling_symmetry

    return find_scaling_symmetry(model)


def gauge_factor(sym, name: str, params: Mapping[str, float], target: float) -> float:
    """The scale ``s`` of the states' symmetry that moves parameter ``name`` from its value to ``target``."""
    import sympy as sp

    from duffsym.derive.symmetry import S

    expr = sym.mapping[name].xreplace({sym.model.param(name).symbol: sp.Float(params[name], 17)})
    sols = [float(v) for v in sp.solve(sp.Eq(expr, sp.Float(target, 17)), S) if v.is_real and v > 0]
    if len(sols) != 1:
        raise ValueError(f"no unique gauge factor for {name}")
    return sols[0]


def normalised_records(records, a: float, b: float):
    """The records with their input (and its velocity) divided by ``a`` and their output by ``b``."""
    return [
        r.replace(
            d=np.asarray(r.d) / a, y=np.asarray(r.y) / b, d_dot=None if r.d_dot is None else np.asarray(r.d_dot) / a
        )
        for r in records
    ]
