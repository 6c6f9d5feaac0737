r"""Identification of a composed structure model (:mod:`duffsym.model.structure`): starts from the data.

The element's state is not measured, and a structure's displacement may be 1e-4 m. Three things make
the collocation fit work anyway:

- **States from the data.** The structure's states are the measured displacement q and its
  band-limited derivative; the element is driven by the structure's own motion, which *is* measured,
  so its states are started by simulating the element alone on (q, q') of the record.
- **Parameters from an equation error.** With :math:`\ddot q` from the band-limited derivative, the
  linear structure :math:`m\ddot q + c\dot q + k q = F` is fitted by least squares (the element's
  force, not yet known, is left in the residual); its m, c, k start the fit, and set the scale of
  each parameter (so every decision variable is O(1) whatever the units). The element's parameters
  start at their defaults; ``fit(n_starts=...)`` adds random starts around them.
- **Scaling.** Parameters enter the NLP divided by the magnitude of their start (ParamSpec scales
  rebuilt from the start), states by the magnitude of their data-based guess.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Mapping

import numpy as np

from duffsym.model.structure import composition


def bandlimited_derivative(u, dt: float, half: int = 15) -> np.ndarray:
    """Derivative of a band-limited sampled signal: the ideal differentiator ``(-1)^n / (n dt)``
    truncated to ``2 half + 1`` taps with a Blackman window (gain within 0.1 % of the exact
    derivative up to 0.8 of the Nyquist frequency; the ends use zero padding)."""
    n = np.arange(-half, half + 1)
    h = np.zeros(n.size)
    nz = n != 0
    h[nz] = (-1.0) ** n[nz] / n[nz]
    h *= np.blackman(n.size + 2)[1:-1]
    h /= np.sum(-n * h)  # unit slope at low frequency
    return np.convolve(np.asarray(u, dtype=float), h, mode="same") / dt


def _rates(record) -> tuple[np.ndarray, np.ndarray]:
    dt = float(np.median(np.diff(record.t)))
    v = bandlimited_derivative(record.y, dt)
    return v, bandlimited_derivative(v, dt)


def element_model(model):
    """The element model of a composed model (None for a single model)."""
    comp = composition(model)
    return None if comp is None else comp["element_model"]


def structure_initial_states(model, record, params: np.ndarray) -> np.ndarray:
    """Data-based state guess ``(n_times, n_states)`` of a composed model: (q, q') measured and
    differentiated, the element's (x, x') simulated from them; states added by effects start at 0."""
    from duffsym.simulate import simulate

    comp = composition(model)
    el = comp["element_model"]
    L = comp["length_unit"]
    v, _ = _rates(record)
    X = np.zeros((record.n_times, model.n_states))
    X[:, 0], X[:, 1] = record.y, v
    pd = dict(zip(model.param_names, map(float, params)))
    chans = {"d": np.asarray(record.y) / L, "d_dot": v / L}
    chans = {c.name: chans[c.name] for c in el.inputs}
    tr = simulate(el, {n: pd[n] for n in el.param_names}, np.asarray(record.t), chans, on_failure="return")
    if tr.success:
        X[:, 2:4] = tr.x
    return X


def structure_initial_guess(record, model, fixed: Mapping[str, float] | None = None, *, skip: int = 20) -> dict:
    """Start values: m, c, k of the default structure by least squares on the equation error
    :math:`m\\ddot q + c\\dot q + k q \\approx F` (edges of ``skip`` samples left out); the element's
    and any other parameters at their defaults (fixed values kept)."""
    fixed = dict(fixed or {})
    values = {**model.defaults(), **fixed}
    v, a = _rates(record)
    sl = slice(skip, record.n_times - skip)
    A = np.column_stack([a[sl], v[sl], np.asarray(record.y)[sl]])
    coef, *_ = np.linalg.lstsq(A, np.asarray(record.d)[sl], rcond=None)
    for name, value in zip(("m", "c", "k"), coef):
        if name in model.param_names and name not in fixed and np.isfinite(value):
            spec = model.param(name)
            values[name] = float(np.clip(value, spec.lower, spec.upper))
    return {k: float(v) for k, v in values.items()}


def scaled_to(model, values: Mapping[str, float]):
    """``model`` whose parameter defaults are ``values`` and whose optimisation scales are their
    magnitudes (zeros keep their scale): every decision variable O(1) whatever the units."""
    params = []
    for p in model.params:
        v = float(values.get(p.name, p.default))
        scale = abs(v) if v != 0 else p.typical_scale
        params.append(replace(p, default=v, scale=scale))
    return replace(model, params=tuple(params))
