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

from collections.abc import Mapping
from dataclasses import replace

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


def _parts(model) -> dict:
    """The parts of a composed model (the functions below are called for composed models only)."""
    comp = composition(model)
    assert comp is not None, f"{model.name} is not a composed model"
    return comp


def element_model(model):
    """The element model of a composed model (None for a single model)."""
    comp = composition(model)
    return None if comp is None else comp["element_model"]


def structure_initial_states(model, record, params: np.ndarray) -> np.ndarray:
    """Data-based state guess ``(n_times, n_states)`` of a composed model: (q, q') measured and
    differentiated, the element's (x, x') simulated from them; states added by effects start at 0."""
    from duffsym.simulate import simulate

    comp = _parts(model)
    L = comp["length_unit"]
    v, _ = _rates(record)
    X = np.zeros((record.n_times, model.n_states))
    X[:, 0], X[:, 1] = record.y, v
    pd = dict(zip(model.param_names, map(float, params)))
    j = 2
    for el in comp.get("elements", (comp["element_model"],)):
        chans = {"d": np.asarray(record.y) / L, "d_dot": v / L}
        chans = {c.name: chans[c.name] for c in el.inputs}
        tr = simulate(el, {n: pd[n] for n in el.param_names}, np.asarray(record.t), chans, on_failure="return")
        if tr.success:
            X[:, j : j + el.n_states] = tr.x
        j += el.n_states
    return X


def structure_columns(model, q, v, a) -> tuple[list[str], np.ndarray]:
    r"""The structure's parameters that enter its equation linearly, and their regressor columns
    :math:`\partial(\mathrm{lhs}-\mathrm{rhs})/\partial p` evaluated on the data (q, q', q'')."""
    import sympy as sp

    from duffsym.model.structure import FORCE_SYMBOL, Q_DDOT, Q_DOT, H, Q

    comp = _parts(model)
    eq = comp["equation"]
    expr = sp.expand(eq.lhs - eq.rhs)
    names, cols = [], []
    for spec in model.params[: comp["n_structure_params"]]:
        col = sp.diff(expr, spec.symbol)
        if col.free_symbols & ({H, FORCE_SYMBOL} | set(model.param_symbols)) or col == 0:
            continue  # not linear in this parameter (or not in the equation): left at its default
        fn = sp.lambdify((Q, Q_DOT, Q_DDOT), col, "numpy")
        names.append(spec.name)
        cols.append(np.broadcast_to(np.asarray(fn(q, v, a), dtype=float), np.shape(q)))
    return names, np.column_stack(cols)


def structure_initial_guess(record, model, fixed: Mapping[str, float] | None = None, *, skip: int = 20) -> dict:
    """Start values: m, c, k of the default structure by least squares on the equation error
    :math:`m\\ddot q + c\\dot q + k q \\approx F` (edges of ``skip`` samples left out); the element's
    and any other parameters at their defaults (fixed values kept)."""
    fixed = dict(fixed or {})
    values = {**model.defaults(), **fixed}
    v, a = _rates(record)
    sl = slice(skip, record.n_times - skip)
    names, A = structure_columns(model, np.asarray(record.y), v, a)
    coef, *_ = np.linalg.lstsq(A[sl], np.asarray(record.d)[sl], rcond=None)
    for name, value in zip(names, coef):
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


def equation_error_start(
    record,
    model,
    *,
    free_element=None,
    starts=None,
    skip: int = 100,
    max_nfev: int = 200,
    rng=0,
    n_random: int = 32,
    lowpass: float = 0.08,
    fixed=None,
    spread: float = 1000.0,
) -> dict:
    r"""Start values of every parameter of a composed model from the equation error (teacher forcing).

    The element is driven by the *measured* motion, so its force :math:`H(t;\theta_e)` is simulated from
    the data alone; the structure's m, c, k enter :math:`F - H = m\ddot q + c\dot q + k q` linearly and
    are eliminated by least squares for every :math:`\theta_e` (variable projection). The element's
    free parameters minimise the remaining equation error within their bounds (scipy ``least_squares`` from the defaults
    and ``n_random`` log-uniform random starts, half within a factor 10 and half within a factor
    ``spread``; the best is kept). ``A_f`` and
    ``k3`` stay at their fixed values. Cheap: each evaluation simulates the two-state element once.
    Both sides are low-passed (zero-phase Butterworth, order 4, cutoff ``lowpass`` times the sampling
    rate): the second derivative of sampled data is only trustworthy well below Nyquist (on the
    Bouc-Wen benchmark's data the unfiltered equation error with the true hysteretic force is 45 %
    of the force, low-passed at 0.08 fs 1.4 %, with m, c, k within 1 % of the truth).
    The wide default spread matters: on a record of an independent simulator whose element
    parameters lie 3 decades from the defaults, 4-16 starts within a factor 10 stopped at an equation
    error of 0.063-0.065, 16 starts within a factor 1000 reached the noise (0.010); on the
    Bouc-Wen benchmark the opposite held (the factor-10 starts found 0.141, the wide ones 0.230), hence both.
    Returns every parameter by name, plus ``"_equation_nrmse"``: the relative equation error left.
    """
    from scipy.optimize import least_squares
    from scipy.signal import butter, filtfilt

    from duffsym.simulate import simulate

    b_lp, a_lp = butter(4, 2 * lowpass)
    lp = lambda s: filtfilt(b_lp, a_lp, s)  # noqa: E731
    comp = _parts(model)
    elements = comp.get("elements", (comp["element_model"],))
    L = comp["length_unit"]
    v, a = _rates(record)
    q, F, t = np.asarray(record.y), np.asarray(record.d), np.asarray(record.t)
    sig = {"d": q / L, "d_dot": v / L}
    fixed = dict(fixed or {})
    free = list(
        free_element
        or [n for el in elements for n in el.param_names if not n.startswith(("A_f", "k3")) and n not in fixed]
    )
    base = {**model.defaults(), **fixed}
    sl = slice(skip, record.n_times - skip)
    s_names, A = structure_columns(model, q, v, a)
    A = np.column_stack([lp(col) for col in A.T])[sl]
    F_lp = lp(F)
    scale = np.array([max(abs(base[n]), 1e-3) for n in free])

    def force(values):
        total = np.zeros(t.size)
        for el in elements:
            tr = simulate(
                el,
                {n: values[n] for n in el.param_names},
                t,
                {ch.name: sig[ch.name] for ch in el.inputs},
                on_failure="return",
                max_substeps=200,
                method="rk4",
            )  # a start too stiff for 200 substeps is rejected, not rerun implicitly
            if not tr.success or not np.all(np.isfinite(tr.y)):
                return None
            total += tr.y
        return total

    def residual(z):
        H_ = force({**base, **dict(zip(free, z * scale))})
        if H_ is None:
            return np.full(A.shape[0], 1e3 * np.std(F))
        rhs = F_lp[sl] - lp(H_)[sl]
        coef, *_ = np.linalg.lstsq(A, rhs, rcond=None)
        return (rhs - A @ coef) / np.std(F_lp)

    inits = _scaled_starts(free, scale, n_random, spread, starts, rng)
    lo = np.array([model.param(n).lower for n in free]) / scale
    hi = np.array([model.param(n).upper for n in free]) / scale
    best = None
    for z0 in inits:
        z0 = np.clip(z0, lo + 1e-9 * np.abs(lo) + 1e-12, hi - 1e-9 * np.abs(hi) - 1e-12)
        sol = least_squares(residual, z0, max_nfev=max_nfev, x_scale="jac", bounds=(lo, hi))
        if best is None or sol.cost < best.cost:
            best = sol
    assert best is not None  # the starts include the defaults
    out = dict(base)
    out.update(dict(zip(free, best.x * scale)))
    H_ = force(out)
    coef, *_ = np.linalg.lstsq(A, F_lp[sl] - lp(H_)[sl], rcond=None)
    for k, v in zip(s_names, coef):
        if k not in fixed and np.isfinite(v):
            spec = model.param(k)
            out[k] = float(np.clip(v, spec.lower, spec.upper))
    out["_equation_nrmse"] = float(np.sqrt(2 * best.cost / A.shape[0]))
    return out


def _scaled_starts(free, scale, n_random, spread, starts, rng) -> list[np.ndarray]:
    """The starts of :func:`equation_error_start`, scaled: the given ``starts``, the defaults (ones), then
    ``n_random`` log-uniform factors, half within 10 and half within ``spread``."""
    gen = np.random.default_rng(rng)
    n_near = (n_random + 1) // 2  # half near the defaults (factor 10), half within the wide spread
    inits = [np.ones(len(free))] + [
        np.exp(gen.uniform(-np.log(f), np.log(f), len(free))) for f in [10.0] * n_near + [spread] * (n_random - n_near)
    ]
    if starts is not None:
        inits = [np.array([s[n] for n in free]) / scale for s in starts] + inits
    return inits


def rescaled_problem(problem, start: Mapping[str, float]):
    """A copy of ``problem`` whose composed model scales each parameter by the magnitude of its start
    (:func:`scaled_to`): the equations, hence the generated code, are the same."""
    import copy

    out = copy.copy(problem)
    object.__setattr__(out, "model", scaled_to(problem.model, {n.split("[")[0]: v for n, v in start.items()}))
    return out
