"""The states' starts of a fit: a data-based guess of every state trajectory of a record.

The collocation fit (:mod:`duffsym.identify.collocation`) starts its state variables here, not at a
simulation from the parameter guess: for the models with output :math:`y = A_f x_2`,
:math:`x_2 = y / A_f` and :math:`x_1` its cumulative integral with its linear drift removed. Starting
the states at the data is what makes the fit insensitive to the parameter guess. States driven by the
inputs alone (the field of ``mr-damper-current``) are integrated exactly from the inputs
(:func:`driven_states`); other models start from a free run at the parameters.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, cast

import numpy as np
import sympy as sp

if TYPE_CHECKING:
    from duffsym.data.record import Record


#: (model key, driven states) -> :func:`_output_gain`'s answer (a fit's starts ask for it once per start; each
#: answer costs a SymPy simplification and lambdify, ~15 ms).
_OUTPUT_GAINS: dict = {}


def _output_gain(model, driven=()):
    """:func:`_derived_output_gain`, derived once per model and driven states."""
    key = (model.key, tuple(driven))
    if key not in _OUTPUT_GAINS:
        _OUTPUT_GAINS[key] = _derived_output_gain(model, driven)
    return _OUTPUT_GAINS[key]


def _derived_output_gain(model, driven=()):
    """If the output is ``g * x_i`` for one state i, with ``g`` a function of the parameters and of the
    ``driven`` states (those the inputs alone determine): ``(i, g as a function of (params, driven))``, with
    a third item, the output's term of the inputs as a function of ``(params, driven, inputs)``, when the
    output has one (e.g. a viscous force ``c0 d_dot``); else None."""
    out = model.output
    driven = tuple(driven)
    states = [s for s in model.states if s in out.free_symbols and s not in driven]
    if len(states) != 1:
        return None
    s = states[0]
    g = sp.simplify(sp.diff(out, s))
    offset = sp.simplify(out - g * s)  # an output term of the inputs (e.g. a viscous force c0 d_dot), else 0
    if s in g.free_symbols or s in offset.free_symbols or any(c.symbol in g.free_symbols for c in model.inputs):
        return None
    args = [*model.param_symbols, *driven]
    fn = sp.lambdify(args, g, "numpy")
    if offset == 0:
        return model.states.index(s), fn
    off = sp.lambdify([*args, *model.input_symbols], offset, "numpy")
    return model.states.index(s), fn, off


def initial_states(model, record, params: np.ndarray) -> np.ndarray:
    """Data-based guess of the state trajectory ``(n_times, n_states)``.

    For a two-state mechanical model whose output is a gain times one state: that state is
    ``y / gain`` and the other its integral (drift and mean removed) or its derivative. A model
    extended by catalogued effects starts its base states this way from the measured output with
    the effects' output terms removed, and each added state from its effect's guess
    (:func:`duffsym.effects.initial_states_with_effects`). Other models (an output read from several states,
    e.g. Spencer's model) start from a free run at ``params`` (the driven states at their equilibrium, the
    others at 0; RK4), or from zeros where it fails.
    """
    if getattr(model, "composition", ()):
        from duffsym.identify.structure import structure_initial_states

        return structure_initial_states(model, record, params)
    if model.effects:
        from duffsym.effects import initial_states_with_effects

        X = initial_states_with_effects(model, record, params, initial_states)
        if X is not None:
            return X
    X = np.zeros((record.n_times, model.n_states))
    driven = driven_states(model, record, params)
    for j, traj in driven.items():
        X[:, j] = traj
    info = _output_gain(model, [model.states[j] for j in driven])
    if info is None:
        return _free_run_states(model, record, params, X)
    i, gain_fn = info[:2]
    gain = np.broadcast_to(np.asarray(gain_fn(*params, *driven.values()), dtype=float), (record.n_times,))
    if np.any(gain == 0) or not np.all(np.isfinite(gain)):
        return X
    y = np.asarray(record.y, dtype=float)
    if len(info) == 3:  # the output's input term (e.g. c0 d_dot) removed first
        chans = record.inputs_for(model)
        y = y - np.broadcast_to(
            np.asarray(
                info[2](*params, *driven.values(), *[np.asarray(chans[c.name], dtype=float) for c in model.inputs]),
                dtype=float,
            ),
            y.shape,
        )
    xi = y / gain
    X[:, i] = xi
    if model.n_states - len(driven) == 2 and model.position is not None and model.velocity is not None:
        ip = model.states.index(model.position)
        iv = model.states.index(model.velocity)
        t = np.asarray(record.t)
        if i == iv:
            X[:, ip] = _remove_drift(_cumulative_trapezoid(xi * _position_rate(model, record, params), t), t, record)
        elif i == ip:
            X[:, iv] = np.gradient(xi, t)
    return X


def _free_run_states(model, record, params: np.ndarray, X: np.ndarray) -> np.ndarray:
    """The states of a free run at ``params`` from ``X[0]``, or ``X`` unchanged if it fails or blows up."""
    from duffsym.simulate import simulate_record

    if model.n_states == len(driven_states(model, record, params)) or not np.all(np.isfinite(params)):
        return X
    # simulate_record's signature does not list ndarray (which it takes) yet
    p = cast("Sequence[float]", np.asarray(params, dtype=float))
    tr = simulate_record(model, p, record, x0=X[0], method="rk4", on_failure="return")
    return tr.x if tr.success and np.all(np.isfinite(tr.x)) else X


def _position_rate(model, record, params: np.ndarray) -> np.ndarray | float:
    """``dx1/dt / x2``: 1 for a clock-time element, the path rate rho(d_dot) of a path-time one
    (:func:`duffsym.model.library.path_time`); 1 when it is not a function of the inputs and parameters."""
    ip = model.states.index(model.position)
    rate = sp.simplify(model.rhs[ip] / model.velocity)
    if rate == 1 or rate.free_symbols & set(model.states):
        return 1.0
    chans = record.inputs_for(model)
    fn = sp.lambdify([*model.param_symbols, *model.input_symbols], rate, "numpy")
    out = np.asarray(
        fn(*[float(v) for v in params], *[np.asarray(chans[c.name], dtype=float) for c in model.inputs]), dtype=float
    )
    return out if np.all(np.isfinite(out)) else 1.0


def driven_states(model, record, params: np.ndarray) -> dict[int, np.ndarray]:
    """Trajectories of the states driven by the inputs alone (e.g. the field of ``mr-damper-current``).

    A state whose equation is ``a * s + b`` with ``a``, ``b`` free of the other states (functions of the
    inputs and parameters) is integrated exactly over each sample (``a``, ``b`` held), from its
    equilibrium ``-b/a`` at the first sample. Returns ``{state index: (n_times,) trajectory}``.
    """
    out: dict[int, np.ndarray] = {}
    t = np.asarray(record.t, dtype=float)
    chans = None
    for j, (s, rhs) in enumerate(zip(model.states, model.rhs)):
        if s in (model.position, model.velocity) or (rhs.free_symbols & set(model.states)) != {s}:
            continue
        a_expr = sp.diff(rhs, s)
        if s in a_expr.free_symbols:
            continue
        b_expr = sp.expand(rhs - a_expr * s)
        if chans is None:
            chans = record.inputs_for(model)
        args = [*model.input_symbols, *model.param_symbols]
        vals = [np.asarray(chans[c.name], dtype=float) for c in model.inputs] + [float(v) for v in params]
        a = np.broadcast_to(np.asarray(sp.lambdify(args, a_expr, "numpy")(*vals), dtype=float), t.shape)
        b = np.broadcast_to(np.asarray(sp.lambdify(args, b_expr, "numpy")(*vals), dtype=float), t.shape)
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))) or np.any(a >= 0):
            continue
        x = np.empty_like(t)
        x[0] = -b[0] / a[0]
        decay = np.exp(a[:-1] * np.diff(t))
        target = -b[:-1] / a[:-1]
        for k in range(t.size - 1):
            x[k + 1] = target[k] + (x[k] - target[k]) * decay[k]
        out[j] = x
    return out


def _remove_drift(x: np.ndarray, t: np.ndarray, record) -> np.ndarray:
    """Remove the drift and mean of an integrated signal, without biting into its periodic part.

    The integral of a noisy or offset velocity drifts; the fluid mass does not. A straight-line
    fit would also remove part of a sine (a sine over whole periods correlates with t), so the
    slope is taken from the means over the first and the last input period, and the mean over
    whole periods is removed.
    """
    try:
        period = record.period
    except (IndexError, ZeroDivisionError, ValueError):
        period = t[-1] - t[0]
    n_p = int(np.searchsorted(t, t[0] + period))
    if 0 < n_p and 2 * n_p <= t.size:
        slope = (np.mean(x[-n_p:]) - np.mean(x[:n_p])) / (np.mean(t[-n_p:]) - np.mean(t[:n_p]))
        x = x - slope * (t - t[0])
        n_whole = max(1, int((t[-1] - t[0]) // period)) * n_p
        return x - np.mean(x[: min(n_whole, t.size)])
    return x - np.mean(x)


def _cumulative_trapezoid(values: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Running trapezoid integral from 0 (written out, so the command line need not import scipy.integrate)."""
    return np.concatenate(([0.0], np.cumsum(0.5 * (values[1:] + values[:-1]) * np.diff(t))))


def start_state(model, p, record: Record) -> tuple[np.ndarray, str]:
    """The initial state of a free run of ``model`` with parameters ``p`` on ``record`` and a note ("" when
    none): started from the data as in the fit and refined over the first input period (see
    :func:`duffsym.identify.validation.validate`)."""
    from duffsym.identify.unitmap import normalised_run

    run = normalised_run(model, model.param_dict(np.asarray(p, dtype=float)), record)
    if run is not None:  # a record far from unit scale: estimated where the differences keep their digits
        p_n, rec_n, back = run
        x0_n, note = start_state(model, model.param_vector(p_n), rec_n)
        return back(x0_n), note
    X = initial_states(model, record, p)
    return _bounded_x0(_estimate_x0(model, p, record, X[0]), X)


#: The estimated initial state may lie this many times the range of the data-based states beyond that range.
X0_RANGE = 2.0


def _bounded_x0(x0, X) -> tuple[np.ndarray, str]:
    """``x0`` if every state lies within :data:`X0_RANGE` times the range of its data-based trajectory ``X``
    around it; else the data-based start ``X[0]`` and a note (an initial state far outside what the record's
    states span fits a level difference, not a start-up: measured, -5.7e6 made the prediction the flat mean)."""
    x0 = np.asarray(x0, dtype=float)
    lo, hi = np.min(X, axis=0), np.max(X, axis=0)
    span = hi - lo  # a state the data say nothing about (started at 0) is not bounded
    out = (span > 0) & ((x0 < lo - X0_RANGE * span) | (x0 > hi + X0_RANGE * span))
    if not np.any(out):
        return x0, ""
    return np.asarray(X[0], dtype=float), (
        f"the initial state estimated from the first period ({', '.join(f'{v:.3g}' for v in x0[out])}) "
        "lay far outside the range of the record's states (it would absorb a level difference): "
        "the free run starts from the data"
    )


def _estimate_x0(model, p, record, guess):
    """Initial state minimising the output error over the first input period."""
    from scipy.optimize import least_squares

    from duffsym.simulate import simulate

    try:
        period = record.period
    except (IndexError, ZeroDivisionError, ValueError):
        period = record.duration
    n = int(min(record.n_times, max(50, np.searchsorted(record.t, record.t[0] + period)), 1000))
    t = np.asarray(record.t[:n])
    U = record.input_matrix(model)
    chans = {c.name: U[:n, j] for j, c in enumerate(model.inputs)}
    y = np.asarray(record.y[:n])
    ref = simulate(model, p, t, chans, x0=guess, on_failure="return")
    if not ref.success:
        return np.asarray(guess, dtype=float)
    # fixed substeps: the discretisation must not change while differencing
    sub = int(min(max(int(ref.substeps.max()), 1) * 2, 200))
    scale = np.maximum(np.abs(guess), 1e-3 * max(1.0, float(np.max(np.abs(guess)))))

    def resid(z):
        tr = simulate(model, p, t, chans, x0=z * scale, substeps=sub, method=ref.method, on_failure="return")
        r = tr.y - y
        return np.where(np.isfinite(r), r, 1e6)

    keep = sorted(driven_states(model, record, p))  # input-driven states (the field) start at their equilibrium
    free = np.array([j for j in range(len(guess)) if j not in keep], dtype=int)
    z0 = np.asarray(guess, dtype=float) / scale

    def full(zf):
        z = z0.copy()
        z[free] = zf
        return z

    sol = least_squares(lambda zf: resid(full(zf)), z0[free], method="lm", max_nfev=200)
    sol.x = full(sol.x)
    x0 = sol.x * scale
    return x0 if np.sum(resid(sol.x) ** 2) <= np.sum(resid(np.asarray(guess) / scale) ** 2) else np.asarray(guess)
