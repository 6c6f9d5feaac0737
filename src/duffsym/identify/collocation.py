r"""Direct collocation + IPOPT: the optimal fit of a model's parameters to measured records.

The state trajectory of every record is a decision variable. Each sample interval
:math:`[t_k, t_{k+1}]` carries a Legendre collocation polynomial of degree 3 (Gauss points, A-stable,
so the stiff Table 2 dynamics need no substeps); the model's equations (generated from the
SymPy model as CasADi functions) hold at the collocation points, with the input reconstructed
linearly between samples, as in :func:`duffsym.simulate.simulate`. The objective is the weighted sum
of squared output residuals at the samples; masked samples leave the objective but their states
still obey the dynamics. Every record shares the parameters; each has its own free initial state.

Parameters enter scaled by ``ParamSpec.scale`` and states by the magnitude of their data-based
initial guess, so the decision variables are O(1). The states start from the data: for the
models with output :math:`y = A_f x_2`, :math:`x_2 = y / A_f` and :math:`x_1` its cumulative integral
with its linear drift removed. Starting the states at the data, not at a simulation from a guess,
is what makes the fit insensitive to the parameter guess.

References
----------
L. T. Biegler, Nonlinear Programming, SIAM 2010, ch. 10 (direct transcription), doi:10.1137/1.9780898719383.
A. Wächter and L. T. Biegler, Math. Program. 106 (2006) 25-57 (IPOPT), doi:10.1007/s10107-004-0559-y.
"""
from __future__ import annotations

import math
import time
import warnings
from dataclasses import replace
from typing import Callable, Mapping, Sequence

import numpy as np
import sympy as sp

from duffsym.errors import ConvergenceWarning, ModelError
from duffsym.identify.nlp import CollocationNLP, Run, ipopt_settings
from duffsym.identify.problem import Problem
from duffsym.identify.result import IdentificationResult
from duffsym.identify.result import nrmse as record_nrmse


#: Up to this many samples in total, ``fit(expand="auto")`` expands the NLP graph.
EXPAND_AUTO_SAMPLES = 1000

#: Samples sharing one copy of the free parameters in the NLP (see ``fit``).
PARAM_STRIDE = 8


def collocation_coefficients(degree: int = 3, scheme: str = "legendre"):
    """Collocation points ``tau`` (with 0 first), derivative matrix ``C`` and end weights ``D``.

    ``C[r, j]`` is the derivative at ``tau[j]`` of the Lagrange polynomial of ``tau[r]``, so that
    :math:`\\dot x(\\tau_j) h = \\sum_r C_{rj} x_r`; ``D[r]`` is its value at 1 (the interval end).
    """
    import casadi as ca

    tau = np.append(0.0, ca.collocation_points(degree, scheme))
    n = degree + 1
    C = np.zeros((n, n))
    D = np.zeros(n)
    for r in range(n):
        coeff = np.poly1d([1.0])
        for s in range(n):
            if s != r:
                coeff *= np.poly1d([1.0, -tau[s]]) / (tau[r] - tau[s])
        D[r] = coeff(1.0)
        dp = np.polyder(coeff)
        for j in range(n):
            C[r, j] = dp(tau[j])
    return tau, C, D


def _output_gain(model, driven=()):
    """If the output is ``g * x_i`` for one state i, with ``g`` a function of the parameters and of the
    ``driven`` states (those the inputs alone determine): ``(i, g as a function of (params, driven))``; else None."""
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
        y = y - np.broadcast_to(np.asarray(info[2](*params, *driven.values(),
                                                   *[np.asarray(chans[c.name], dtype=float) for c in model.inputs]),
                                           dtype=float), y.shape)
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
    from duffsym.simulate import simulate

    if model.n_states == len(driven_states(model, record, params)) or not np.all(np.isfinite(params)):
        return X
    tr = simulate(model, np.asarray(params, dtype=float), np.asarray(record.t), _input_matrix(model, record),
                  x0=X[0], method="rk4", on_failure="return")
    return tr.x if tr.success and np.all(np.isfinite(tr.x)) else X


def _position_rate(model, record, params: np.ndarray) -> np.ndarray | float:
    """``dx1/dt / x2``: 1 for a clock-time element, the path rate rho(d_dot) of a path-time one
    (:func:`duffsym.model.library.path_time`); 1 when it is not a function of the inputs and parameters."""
    ip, iv = model.states.index(model.position), model.states.index(model.velocity)
    rate = sp.simplify(model.rhs[ip] / model.velocity)
    if rate == 1 or rate.free_symbols & set(model.states):
        return 1.0
    chans = record.inputs_for(model)
    fn = sp.lambdify([*model.param_symbols, *model.input_symbols], rate, "numpy")
    out = np.asarray(fn(*[float(v) for v in params], *[np.asarray(chans[c.name], dtype=float) for c in model.inputs]),
                     dtype=float)
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
    """Running trapezoid integral from 0 (written out: importing scipy.integrate costs ~0.5 s per CLI run)."""
    return np.concatenate(([0.0], np.cumsum(0.5 * (values[1:] + values[:-1]) * np.diff(t))))


def _input_matrix(model, record) -> np.ndarray:
    from duffsym.simulate import input_matrix

    return input_matrix(model, np.asarray(record.t), record.inputs_for(model))


def fit(
    problem: Problem,
    x0: Mapping[str, float] | Sequence[float] | None = None,
    *,
    tol: float = 1e-10,
    acceptable_tol: float = 1e-7,
    max_iter: int = 500,
    linear_solver: str = "mumps",
    degree: int = 3,
    print_level: int = 0,
    expand: bool | str = "auto",
    compute_stderr: bool = True,
    n_starts: int = 1,
    start_spread: float = 10.0,
    rng: np.random.Generator | int | None = None,
    ipopt_options: Mapping[str, object] | None = None,
    derivatives: str = "structured",
    param_stride: int = PARAM_STRIDE,
    bound_restart: bool = True,
    progress: Callable[[str], None] | None = None,
    flags: bool = True,
    max_wall_time: float | None = None,
) -> IdentificationResult:
    r"""Identify the free parameters of ``problem`` by direct collocation and IPOPT.

    Parameters
    ----------
    problem : the :class:`Problem` (model, records, free/fixed parameters, bounds, weights, mask).
    x0 : initial values of the free parameters (by name, or ordered as ``problem.free``); missing
        names, or None, take :func:`~duffsym.identify.initial_guess` on the first record.
    tol, acceptable_tol, max_iter : IPOPT's ``tol``, ``acceptable_tol`` and ``max_iter``.
    linear_solver : IPOPT's linear solver (``"mumps"`` ships with CasADi).
    degree : degree of the Legendre collocation polynomial in each sample interval.
    print_level : IPOPT verbosity (0 silent).
    expand : (``derivatives="casadi"`` only) expand the CasADi graph to scalar form: evaluation per
        iteration ~10x faster, build ~5x slower (about 1 ms per sample). ``"auto"`` expands only for multistart fits (``n_starts >= 3``)
        of up to ``EXPAND_AUTO_SAMPLES`` samples in total, where the faster iterations repay the
        build (a single 400-sample fit: 0.47 s unexpanded, 0.82 s expanded); otherwise it keeps the
        mapped graph, whose build is linear in N.
    compute_stderr : compute standard errors (Laplace) after the fit.
    n_starts : number of IPOPT runs on the same NLP (built once): the first from ``x0``, the others
        from random parameter starts; the converged run with the lowest cost is kept. The states
        always start from the data.
    start_spread : the random starts multiply ``x0`` by log-uniform factors in
        ``[1/start_spread, start_spread]`` (clipped inside the bounds).
    rng : seed or Generator for the random starts.
    ipopt_options : extra IPOPT options.
    derivatives : ``"structured"`` (default): the constraint Jacobian and the Hessian of the
        Lagrangian are assembled from the derivatives of one interval (generated once, symbolically)
        evaluated on every interval and scattered into the global sparse matrices, so the build and
        each evaluation are linear in N with a small constant; ``"casadi"``: CasADi's automatic
        differentiation of the whole NLP graph (the reference; ~10x slower to build and evaluate on
        long records, ``expand`` applies to it only).
    param_stride : the NLP carries one copy of the free parameters per ``param_stride`` samples,
        chained by equality constraints (the same solution for any value; it only changes the
        sparsity of the KKT system: 8 needs ~30 % less time than 1 on long records).
    flags : compute the result's ``flags`` (default); False leaves them empty, for callers that judge
        the fit themselves (a diagnosis's candidates: the first fit of each extended model would derive
        its stability conditions, ~0.5 s each, for flags nobody reads).
    bound_restart : (single-start fits; with ``n_starts > 1`` the other starts do this job) when the
        run ends with a free parameter on a bound it did not start on,
        run IPOPT once more from its end parameters with those back at their start values (the
        states from the data, as for every start), and keep the restart if it lowers the cost (``settings["bound_restart"]`` says what
        happened). A path can be pushed onto a bound by its first steps, far from the data's optimum.
    progress : a callable taking one line of text (e.g. ``print`` to stderr), or None: the stage
        (building, solving) and, every ``nlp.PROGRESS_EVERY`` seconds of a solve, its IPOPT iteration,
        elapsed time, the last iteration's time and, when it is ill-conditioned, IPOPT's Hessian
        regularisation (from IPOPT's intermediate callback).
    max_wall_time : seconds the solves may take in all (None: no limit). When the budget runs out, IPOPT
        stops at its next iteration: during the first run(s) the result is not a success and its message
        names the phase and what to try; during a bound restart the converged run it started from is kept.
        ``settings["iterations"]`` gives each run's iteration times and regularisation either way.

    Returns
    -------
    IdentificationResult
        A solver failure is reported in ``status``/``success``/``message``, never raised. ``success``
        means a usable model (:func:`~duffsym.identify.quality.usability`): IPOPT converged, the free
        run is finite and better than predicting the mean (R² >= 0), and A_f > 0. Doubtful but usable
        results carry ``flags`` (:func:`~duffsym.identify.quality.fit_flags`): parameters on a bound,
        a set outside the derived stability certificate, R² < 0.5.

    Raises
    ------
    FitInterrupted
        (a :class:`KeyboardInterrupt`) when Ctrl-C stops the IPOPT solve; nothing is returned.

    The pipeline: :func:`parameter_start` -> :class:`~duffsym.identify.nlp.CollocationNLP` (built
    once) -> :meth:`~duffsym.identify.nlp.CollocationNLP.solve` per start -> :func:`best_run` and
    :func:`bound_restart_policy` -> free run and :func:`laplace_covariance` -> the result.

    Notes
    -----
    Standard errors use the Laplace (Gauss–Newton) approximation of the least-squares objective
    around the optimum: with :math:`J` the sensitivity of the free-run outputs at the samples in the
    objective to the free parameters and the initial states of each record (central differences of
    :func:`duffsym.simulate.simulate` with a fixed substep count),
    :math:`\Sigma = \sigma^2 (J^\top W J)^{-1}`, :math:`\sigma^2 = \mathrm{SSR}/(N - p)`, ``p``
    counting the free parameters and the initial states; the parameter block of :math:`\Sigma`
    is reported (the initial states are marginalised).
    """
    t_build = time.perf_counter()
    n_starts, expand = _checked_options(problem, n_starts=n_starts, start_spread=start_spread, expand=expand,
                                        derivatives=derivatives, degree=degree, max_iter=max_iter, tol=tol)
    say = progress or _silent
    start = parameter_start(problem, x0)
    if getattr(problem.model, "composition", ()):  # a structure with an element: O(1) variables whatever the units
        from duffsym.identify.structure import rescaled_problem

        problem = rescaled_problem(problem, start)
    say(f"building the collocation NLP ({sum(r.n_times for r in problem.records)} samples, "
        f"{len(problem.slot_names)} free parameters)")
    nlp = CollocationNLP(problem, start, degree=degree, derivatives=derivatives, expand=expand,
                         param_stride=param_stride,
                         solver_options=ipopt_settings(tol=tol, acceptable_tol=acceptable_tol, max_iter=max_iter,
                                                       print_level=print_level, linear_solver=linear_solver,
                                                       ipopt_options=ipopt_options))
    build = time.perf_counter() - t_build

    t_solve = time.perf_counter()
    deadline = None if max_wall_time is None else t_solve + float(max_wall_time)
    starts = [nlp.th0] + _random_starts(nlp.th0, nlp.lo, nlp.hi, nlp.p_scale, n_starts - 1, start_spread, rng)
    say(f"built in {build:.1f} s; solving" + (f" from {n_starts} starts" if n_starts > 1 else ""))
    runs = [nlp.solve(th, max_iter=max_iter, progress=progress, deadline=deadline,
                      label=f"start {i + 1}/{n_starts}" if n_starts > 1 else "")
            for i, th in enumerate(starts)]
    runs = [_timed_out(r, "the IPOPT solve" + (f" of start {i + 1}/{n_starts}" if n_starts > 1 else ""),
                       max_wall_time, problem) for i, r in enumerate(runs)]
    i_best = best_run(runs)
    best, bound_note = runs[i_best], None
    if bound_restart and n_starts == 1 and best.success:
        best, bound_note = bound_restart_policy(nlp, best, starts[i_best], max_iter=max_iter, progress=progress,
                                                deadline=deadline)
    n_ok = sum(r.success for r in runs)
    if n_starts > 1:
        best = replace(best, message=best.message + f"; best of {n_starts} starts ({n_ok} converged)")
    solve = time.perf_counter() - t_solve
    say(f"solved in {solve:.1f} s: {best.status}, {best.n_iter} iterations" + _iteration_note(runs, bound_note)
        + "; free run and standard errors")

    slot_values, x0s = nlp.unscale(best.w)
    # a solve the time limit stopped is not an optimum: no standard errors (they would cost more time)
    fitted = _evaluate(problem, nlp, slot_values, x0s, compute_stderr and best.status != "Wall_Time_Exceeded")
    settings = {"method": "direct collocation", "scheme": "legendre", "degree": int(degree),
                "expand": bool(expand) and derivatives == "casadi", "derivatives": derivatives,
                "param_stride": nlp.stride, "tol": tol, "acceptable_tol": acceptable_tol, "max_iter": int(max_iter),
                "linear_solver": linear_solver, "start": start,
                "n_starts": n_starts, "starts_converged": n_ok, "constraints": nlp.constraints,
                "bound_restart": bound_note,
                "start_costs": [r.cost * 2 * nlp.y_norm**2 for r in runs], "y_norm": nlp.y_norm,
                "max_wall_time": max_wall_time, "iterations": [r.iterations for r in runs]
                + ([bound_note["iterations"]] if bound_note and bound_note.get("iterations") else []),
                "integrator": fitted["integrator"]}
    return _result(problem, nlp, best, fitted, slot_values, x0s, settings, {"build": build, "solve": solve},
                   flags=flags)


def _silent(msg: str) -> None:
    return None


def _timed_out(run: Run, phase: str, budget, problem) -> Run:
    """A run the wall-clock budget stopped: not a success, with a message naming the phase and what to try."""
    if run.stopped != "time":
        return run
    n = sum(r.n_times for r in problem.records)
    info = run.iterations or {}
    return replace(run, status="Wall_Time_Exceeded", success=False, message=(
        f"stopped by the time limit ({budget:g} s) in {phase} after {run.n_iter} iterations (slowest iteration "
        f"{info.get('seconds_max', 0):.1f} s, Hessian regularisation up to {info.get('regularisation_max', 0):.1e}); "
        f"try: check the units of the record (a time column in ms, signals far from O(1)), a start closer to the "
        f"data (--fix or x0), fewer samples ({n} now: decimate or cut the record), or a larger time limit"))


def _iteration_note(runs, bound_note) -> str:
    """`` (iterations median X s, max Y s at iteration k[; N ill-conditioned])`` of the runs of a fit."""
    infos = [r.iterations for r in runs if r.iterations] + ([bound_note["iterations"]]
                                                              if bound_note and bound_note.get("iterations") else [])
    if not infos or not sum(i["n"] for i in infos):
        return ""
    worst = max(infos, key=lambda i: i["seconds_max"])
    med = float(np.median([i["seconds_median"] for i in infos if i["n"]]))
    bad = sum(i["ill_conditioned"] for i in infos)
    return (f" (iteration median {med:.2g} s, slowest {worst['seconds_max']:.2g} s"
            + (f"; {bad} ill-conditioned iterations, Hessian regularisation up to "
               f"{max(i['regularisation_max'] for i in infos):.1e}" if bad else "") + ")")


def _checked_options(problem, *, n_starts, start_spread, expand, derivatives, degree, max_iter, tol):
    """The solver options checked; ``(n_starts, expand)`` resolved."""
    if int(n_starts) != n_starts or n_starts < 1 or not start_spread >= 1:
        raise ModelError(f"n_starts must be a positive integer and start_spread >= 1; got {n_starts}, {start_spread}")
    n_starts = int(n_starts)
    if expand == "auto":
        expand = sum(r.n_times for r in problem.records) <= EXPAND_AUTO_SAMPLES and n_starts >= 3
    elif not isinstance(expand, bool):
        raise ModelError(f"expand must be True, False or 'auto'; got {expand!r}")
    if derivatives not in ("structured", "casadi"):
        raise ModelError(f"derivatives must be 'structured' or 'casadi'; got {derivatives!r}")
    if degree < 1 or int(degree) != degree:
        raise ModelError(f"degree must be a positive integer; got {degree}")
    if max_iter < 0 or tol <= 0:
        raise ModelError(f"max_iter must be >= 0 and tol > 0; got max_iter={max_iter}, tol={tol}")
    return n_starts, expand


def parameter_start(problem: Problem, x0: Mapping[str, float] | Sequence[float] | None = None) -> dict[str, float]:
    """The start value of every parameter slot: ``x0`` where given (by name, or ordered as
    ``problem.slot_names``), else :func:`~duffsym.identify.initial_guess` on the slot's first record;
    checked finite and inside the bounds."""
    from duffsym.identify.initial import initial_guess

    model, slots, slot_names = problem.model, problem.slots, problem.slot_names
    start: dict[str, float] = {}
    if x0 is not None:
        if isinstance(x0, Mapping):
            unknown = sorted(set(x0) - set(model.param_names) - set(slot_names))
            if unknown:
                raise ModelError(f"x0: unknown parameter(s) {unknown}; known: {list(model.param_names)}")
            for sn, (n, lab) in zip(slot_names, slots):
                if sn in x0:
                    start[sn] = float(x0[sn])
                elif n in x0:
                    start[sn] = float(x0[n])
        else:
            vals = np.asarray(x0, dtype=float).reshape(-1)
            if vals.size != len(slots):
                raise ModelError(f"x0 must give {len(slots)} values ordered as {list(slot_names)}; got {vals.size}")
            start = dict(zip(slot_names, map(float, vals)))
    if len(start) < len(slots):
        guesses = {}
        for sn, (n, lab) in zip(slot_names, slots):
            if sn in start:
                continue
            i = problem.labels.index(lab) if lab is not None else 0
            if i not in guesses:
                fixed_i = {k: problem.fixed_value(i, k) for k in problem.fixed}
                guesses[i] = initial_guess(problem.records[i], model, fixed=fixed_i)
            start[sn] = guesses[i][n]
    from duffsym.identify.problem import effect_record_bounds

    scaled = set(effect_record_bounds(model, problem.records))
    for sn, (n, lab) in zip(slot_names, slots):
        lo, hi = problem.bounds[n]
        v = start[sn]
        if not math.isfinite(v):
            raise ModelError(f"x0: initial value of {sn} must be finite; got {v}")
        if not lo <= v <= hi and n in scaled:  # a bound scaled to the record (Effect.record_bounds): moved inside
            v = start[sn] = min(max(v, lo), hi)
        if not lo <= v <= hi:
            raise ModelError(f"x0: initial value of {sn} = {v:g} is outside its bounds [{lo:g}, {hi:g}]; move it inside")
    return start


def best_run(runs: Sequence[Run]) -> int:
    """Index of the converged run with the lowest cost (the first run if none converged; ties: the first)."""
    ok = [i for i, r in enumerate(runs) if r.success]
    return min(ok, key=lambda i: runs[i].cost) if ok else 0


def bound_restart_policy(nlp: CollocationNLP, best: Run, th_start: np.ndarray, *, max_iter: int,
                         progress=None, deadline: float | None = None) -> tuple[Run, dict | None]:
    """When ``best`` ended with a parameter on a bound it did not start on, one more run from its end
    parameters with those back at their start values (states from the data); the restart is kept if
    it lowers the cost. Returns the run kept and a note for ``settings["bound_restart"]`` (None if no
    parameter moved onto a bound).

    The converged ``best`` is never lost: the restart runs under :func:`~duffsym.identify.nlp.restart_guard`
    (it stops when its iterations turn slow or ill-conditioned, or after a few times ``best``'s iterations)
    and under the fit's ``deadline``; a stopped restart keeps ``best``, and the note says why it stopped."""
    from duffsym.identify.nlp import restart_guard

    # a parameter that moved onto a bound may be a trap of the path, not of the data: measured on
    # noise-free Table 2 data, 1 of 120 random starts stopped at k1 = 0, k2 ~ 0 (NRMSE 0.015);
    # a new run from its end parameters with k1 back at its start value (states from the data again,
    # as in every start) reached the truth
    lo_s, hi_s, n_slots = nlp.lo, nlp.hi, nlp.n_slots
    th_end = best.w[:n_slots]
    tol_b = 1e-6 * np.maximum(1.0, np.abs(th_end))
    at_bound = [j for j in range(n_slots)
                if (np.isfinite(lo_s[j]) and th_end[j] - lo_s[j] <= tol_b[j] < th_start[j] - lo_s[j])
                or (np.isfinite(hi_s[j]) and hi_s[j] - th_end[j] <= tol_b[j] < hi_s[j] - th_start[j])]
    if not at_bound:
        return best, None
    th_re = th_end.copy()
    th_re[at_bound] = th_start[at_bound]
    again = nlp.solve(th_re, max_iter=max_iter, progress=progress, label="bound restart", deadline=deadline,
                      guard=restart_guard(best, max_iter=max_iter))
    names_b = ", ".join(nlp.slot_names[j] for j in at_bound)
    better = again.success and again.cost < best.cost * (1 - 1e-9)
    y2 = 2 * nlp.y_norm**2
    stopped = ("the time limit" if again.stopped == "time" else again.stopped)
    note = {"parameters": [nlp.slot_names[j] for j in at_bound], "cost_before": best.cost * y2,
            "cost_after": again.cost * y2 if math.isfinite(again.cost) else math.inf,
            "kept": "restart" if better else "first", "iterations": again.iterations,
            "stopped": stopped or None}
    if better:
        kept = replace(again, n_iter=best.n_iter + again.n_iter,
                       message=again.message + f"; {names_b} had stopped on a bound: a restart with it back at its "
                       f"start lowered the cost {best.cost / again.cost:.3g}x")
    elif stopped:
        kept = replace(best, message=best.message + f"; {names_b} ended on a bound; a restart with it back at its start "
                       f"was stopped after {again.n_iter} iterations ({stopped}); the converged run is kept")
    else:
        kept = replace(best, message=best.message + f"; {names_b} ended on a bound and a restart with it back at its "
                       "start found nothing better")
    return kept, note


def _evaluate(problem: Problem, nlp: CollocationNLP, slot_values, x0s, compute_stderr: bool) -> dict:
    """Free run of the fitted parameters on every record, its errors, and the Laplace covariance."""
    rec_params = [problem.record_params(i, slot_values) for i in range(len(problem.records))]
    U_list = [b.U for b in nlp.layout]
    t_free = time.perf_counter()
    runs = [free_run_trajectory(problem.model, rp, rec, U, x)
            for rp, rec, U, x in zip(rec_params, problem.records, U_list, x0s)]
    free_run = [_outcome(tr) for tr in runs]
    t_free = time.perf_counter() - t_free
    y_sims = tuple(fr[0] for fr in free_run)
    ok_runs = all(fr[1] for fr in free_run)
    records = problem.records
    sse = sum(float(np.sum((np.asarray(r.y) - ys) ** 2)) for r, ys in zip(records, y_sims))
    sst = sum(float(np.sum((np.asarray(r.y) - np.mean(r.y)) ** 2)) for r in records)
    used = [problem.sample_weights(i) > 0 for i in range(len(records))]
    sse_u = sum(float(np.sum(((np.asarray(r.y) - ys) ** 2)[u])) for r, ys, u in zip(records, y_sims, used))
    sst_u = sum(float(np.sum(((np.asarray(r.y) - np.mean(np.asarray(r.y)[u])) ** 2)[u])) for r, u in zip(records, used))
    t_se = time.perf_counter()
    cov = np.full((nlp.n_slots, nlp.n_slots), np.nan)
    if compute_stderr and ok_runs:
        cov = laplace_covariance(problem, rec_params, x0s, U_list, y_sims)
    t_se = time.perf_counter() - t_se
    return {"rec_params": rec_params, "y_sims": y_sims, "ok": ok_runs,
            "integrator": [{"record": r.name, **tr.integrator} for r, tr in zip(records, runs)],
            "failure": next((fr[2] for fr in free_run if not fr[1]), ""),
            "nrmse": math.sqrt(sse / sst) if ok_runs else math.inf,
            "nrmse_records": tuple(record_nrmse(r.y, ys) for r, ys in zip(records, y_sims)),
            "nrmse_objective": math.sqrt(sse_u / sst_u) if ok_runs else math.inf,
            "covariance": cov, "t_free": t_free, "t_se": t_se}


def _result(problem, nlp, best: Run, fitted: dict, slot_values, x0s, settings, timings,
            flags: bool = True) -> IdentificationResult:
    """The :class:`IdentificationResult`: the run, judged usable or not (:func:`usability`), with its flags."""
    import casadi

    import duffsym
    from duffsym.identify.quality import fit_flags, usability

    model = problem.model
    nrmse = fitted["nrmse"]
    r2 = 1 - nrmse**2 if math.isfinite(nrmse) else -math.inf
    status, success, message = best.status, best.success, best.message
    if success and not fitted["ok"]:
        success = False
        message = (f"IPOPT converged ({status}) but the free-run simulation with the fitted parameters failed: "
                   f"{fitted['failure']}")
        status = "free-run failed"
    elif success:
        status, success, message = usability(problem, fitted["rec_params"], r2, status, message)
    cov = fitted["covariance"]
    stderr = {n: float(math.sqrt(cov[j, j])) if np.isfinite(cov[j, j]) and cov[j, j] >= 0 else math.nan
              for j, n in enumerate(nlp.slot_names)}
    params = problem.full_params(slot_values) if not problem.group_order else _grouped_params(problem, slot_values)
    t_flags = time.perf_counter()
    flags = fit_flags(problem, nlp, best.w, fitted["rec_params"], r2) if fitted["ok"] and flags else ()
    t_flags = time.perf_counter() - t_flags  # the first fit of a model derives its stability conditions (~0.4 s)
    return IdentificationResult(
        model=model, params=params, free=tuple(nlp.slot_names), fixed=dict(problem.fixed), stderr=stderr,
        covariance=cov, cost=best.cost * 2 * nlp.y_norm**2, nrmse=nrmse, r2=r2,
        status=status, success=success, message=message, n_iter=best.n_iter,
        timings={**timings, "free_run": fitted["t_free"], "stderr": fitted["t_se"], "flags": t_flags},
        mask=problem.masks(), defaults_applied=dict(problem.defaults_applied), effects=tuple(model.effects),
        structural={k: v for k, v in model.structural}, nrmse_records=fitted["nrmse_records"],
        nrmse_objective=fitted["nrmse_objective"], x0=tuple(x0s), y_sim=fitted["y_sims"],
        records=tuple(r.name for r in problem.records), mask_info=dict(problem.mask_info), settings=settings,
        versions={"casadi": casadi.__version__, "duffsym": getattr(duffsym, "__version__", "?")},
        n_samples=int(sum(r.n_times for r in problem.records)),
        group_params={lab: problem.record_params(problem.labels.index(lab), slot_values)
                      for lab in problem.group_order},
        groups=tuple(problem.labels) if problem.group_order else (), flags=tuple(flags),
    )


def _structured_derivatives(w, g, blocks, interval, out_fn, model, free, p_scale_free, *, theta_size, n_g, K, y_norm,
                            stride=1, extra=((), (), ()), n_g_total=None):
    """The NLP's constraint Jacobian and the triangle of the Lagrangian's Hessian, assembled by blocks.

    Every collocation interval k depends only on ``z_k = (x_k, xc_k, x_k+1, p_k)`` (scaled states at
    both ends, its collocation states, its copy of the free parameters), and every objective term
    only on ``(x_k, p_k)``. The Jacobian and Hessian of one interval and of one objective term are
    generated once as SX functions, mapped over the intervals, and their nonzeros scattered into
    the global matrices (sums where blocks overlap, by one constant sparse matrix product). The
    linear constraints (parameter copies chained to theta) add constant entries.
    """
    import casadi as ca

    nx, nu, n_free, n_par = model.n_states, model.n_inputs, len(free), model.n_params
    nzz = nx * (K + 2) + n_free
    n_rows = nx * K + nx
    z = ca.SX.sym("z", nzz)
    uk, uk1, hk = ca.SX.sym("uk", nu), ca.SX.sym("uk1", nu), ca.SX.sym("h")
    pf, sx = ca.SX.sym("pf", n_par), ca.SX.sym("sx", nx)
    pk = z[nx * (K + 2):]
    ps = ca.vertcat(*[pk[free.index(n)] * p_scale_free[free.index(n)] if n in free else pf[j]
                      for j, n in enumerate(model.param_names)])
    res, xend = interval(z[:nx], ca.reshape(z[nx: nx + nx * K], nx, K), uk, uk1, hk, ps, sx)
    gk = ca.vertcat(res, xend - z[nx + nx * K: nx * (K + 2)])
    Jk = ca.jacobian(gk, z)
    lam = ca.SX.sym("lam", n_rows)
    Hk = ca.triu(ca.hessian(ca.dot(lam, gk), z)[0])
    args = [z, uk, uk1, hk, pf, sx]
    jfun = ca.Function("jac_interval", args, [ca.vertcat(*Jk.nonzeros())])
    hfun = ca.Function("hess_interval", args + [lam], [ca.vertcat(*Hk.nonzeros())])
    jr, jc = (np.asarray(a, dtype=np.int64) for a in Jk.sparsity().get_triplet())
    hr, hc = (np.asarray(a, dtype=np.int64) for a in Hk.sparsity().get_triplet())
    # one objective term: 0.5 * w * ((y_hat - y) / y_norm)^2 of v = (x_k, p_k)
    v = ca.SX.sym("v", nx + n_free)
    uo, yk, wk, lf = ca.SX.sym("u", nu), ca.SX.sym("y"), ca.SX.sym("wk"), ca.SX.sym("lam_f")
    pv = ca.vertcat(*[v[nx + free.index(n)] * p_scale_free[free.index(n)] if n in free else pf[j]
                      for j, n in enumerate(model.param_names)])
    ok = 0.5 * wk * ((out_fn(v[:nx] * sx, uo, pv) - yk) / y_norm) ** 2
    Ho = ca.triu(ca.hessian(lf * ok, v)[0])
    ofun = ca.Function("hess_term", [v, uo, yk, wk, pf, sx, lf], [ca.vertcat(*Ho.nonzeros())])
    orr, occ = (np.asarray(a, dtype=np.int64) for a in Ho.sparsity().get_triplet())

    lam_f = ca.MX.sym("lam_f")
    lam_g = ca.MX.sym("lam_g", n_g if n_g_total is None else n_g_total)
    p_empty = ca.MX.sym("p", 0)
    J_rows, J_cols, J_vals, H_rows, H_cols, H_vals = [], [], [], [], [], []
    for b in blocks:
        o, N, U = b["offset"], b["N"], b["U"]
        k = np.arange(N - 1)
        xs_idx = o + np.arange(nx)[:, None] + nx * np.arange(N)[None, :]                     # (nx, N)
        xc_idx = o + nx * N + np.arange(nx * K)[:, None] + nx * K * k[None, :]              # (nx K, N-1)
        nb = -(-N // stride)
        pb_idx = o + nx * N + nx * K * (N - 1) + np.arange(n_free)[:, None] + n_free * np.arange(nb)[None, :]
        p_idx = pb_idx[:, np.arange(N) // stride]                                          # (n_free, N)
        zi = np.vstack([xs_idx[:, :-1], xc_idx, xs_idx[:, 1:], p_idx[:, :-1]])            # (nzz, N-1)
        c0 = b["g_offset"]
        c1 = c0 + nx * K * (N - 1)
        c2 = c1 + nx * (N - 1)
        c3 = c2 + n_free
        gi = np.vstack([c0 + np.arange(nx * K)[:, None] + nx * K * k[None, :],
                        c1 + np.arange(nx)[:, None] + nx * k[None, :]])                   # (n_rows, N-1)
        Z = ca.reshape(w[zi.ravel(order="F").tolist()], nzz, N - 1)
        L = ca.reshape(lam_g[gi.ravel(order="F").tolist()], n_rows, N - 1)
        common = (U[:-1].T, U[1:].T, b["h"][None, :], b["pf"], b["S"])
        J_vals.append(ca.vec(jfun.map(N - 1)(Z, *common)))
        J_rows.append(gi[jr, :].ravel(order="F"))
        J_cols.append(zi[jc, :].ravel(order="F"))
        H_vals.append(ca.vec(hfun.map(N - 1)(Z, *common, L)))
        H_rows.append(zi[hr, :].ravel(order="F"))
        H_cols.append(zi[hc, :].ravel(order="F"))
        vi = np.vstack([xs_idx, p_idx])
        V = ca.reshape(w[vi.ravel(order="F").tolist()], nx + n_free, N)
        H_vals.append(ca.vec(ofun.map(N)(V, U.T, b["y"][None, :], b["wts"][None, :], b["pf"], b["S"], lam_f)))
        H_rows.append(vi[orr, :].ravel(order="F"))
        H_cols.append(vi[occ, :].ravel(order="F"))
        # linear constraints: p_0 - theta = 0 and p_b+1 - p_b = 0 between consecutive copies
        jf = np.arange(n_free)
        chain = (c3 + jf[:, None] + n_free * np.arange(nb - 1)[None, :]).ravel(order="F")
        J_rows += [c2 + jf, c2 + jf, chain, chain]
        J_cols += [pb_idx[:, 0], np.asarray(b["sidx"]), pb_idx[:, 1:].ravel(order="F"), pb_idx[:, :-1].ravel(order="F")]
        n_lin = n_free * (nb - 1)
        J_vals.append(ca.DM(np.concatenate([np.ones(n_free), -np.ones(n_free), np.ones(n_lin), -np.ones(n_lin)])))
    if len(extra[0]):  # linear parameter constraints: constant rows after the dynamics
        J_rows.append(np.asarray(extra[0]))
        J_cols.append(np.asarray(extra[1]))
        J_vals.append(ca.DM(np.asarray(extra[2], dtype=float)))
    n_g = n_g if n_g_total is None else n_g_total
    n_w = w.numel()
    jac = _scatter(np.concatenate(J_rows), np.concatenate(J_cols), ca.vertcat(*J_vals), n_g, n_w, upper=False)
    hess = _scatter(np.concatenate(H_rows), np.concatenate(H_cols), ca.vertcat(*H_vals), n_w, n_w, upper=True)
    jac_g = ca.Function("nlp_jac_g", [w, p_empty], [g, jac], ["x", "p"], ["g", "jac_g_x"])
    hess_lag = ca.Function("nlp_hess_l", [w, p_empty, lam_f, lam_g], [hess],
                           ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])
    return jac_g, hess_lag


def _scatter(rows, cols, vals, n_rows, n_cols, *, upper):
    """Sparse ``n_rows x n_cols`` MX matrix whose entry (rows[t], cols[t]) sums ``vals[t]``.

    With ``upper``, entries below the diagonal move to their mirror image above it (the symmetric
    Hessian's upper triangle).
    """
    import casadi as ca

    rows = np.asarray(rows, dtype=np.int64)
    cols = np.asarray(cols, dtype=np.int64)
    if upper:
        rows, cols = np.minimum(rows, cols), np.maximum(rows, cols)
    key = cols * n_rows + rows
    uniq, inverse = np.unique(key, return_inverse=True)
    r_u, c_u = uniq % n_rows, uniq // n_rows
    colind = np.searchsorted(c_u, np.arange(n_cols + 1))
    sp = ca.Sparsity(n_rows, n_cols, colind.tolist(), r_u.tolist())
    if uniq.size == key.size:
        order = np.empty_like(inverse)
        order[inverse] = np.arange(inverse.size)
        nz = vals[order.tolist()]
    else:
        A = ca.DM(ca.Sparsity(uniq.size, key.size, np.arange(key.size + 1).tolist(), inverse.tolist()), 1.0)
        nz = ca.mtimes(A, vals)
    return ca.MX(sp, nz)


def _grouped_params(problem, slot_values) -> dict[str, float]:
    """Shared values by name, per-group values as ``name[label]``, per-group fixed values likewise."""
    out = {}
    for n in problem.model.param_names:
        if n in problem.free and n not in problem.per_group:
            out[n] = slot_values[n]
        elif n in problem.per_group:
            for lab in problem.group_order:
                out[f"{n}[{lab}]"] = slot_values[f"{n}[{lab}]"]
        elif any(k == n for k, _ in problem.group_fixed):
            for lab in problem.group_order:
                out[f"{n}[{lab}]"] = problem.group_fixed.get((n, lab), problem.fixed[n])
        else:
            out[n] = problem.fixed[n]
    return out


def _random_starts(th0, lo, hi, scale, n, spread, rng) -> list[np.ndarray]:
    """Scaled parameter starts: ``th0`` times log-uniform factors, kept strictly inside the bounds."""
    if n <= 0:
        return []
    rng = np.random.default_rng(rng)
    out = []
    base = np.where(th0 != 0, th0, 1.0)
    for _ in range(n):
        th = base * np.exp(rng.uniform(-math.log(spread), math.log(spread), th0.size))
        span = np.where(np.isfinite(hi - lo), hi - lo, np.abs(th) + 1.0)
        th = np.clip(th, lo + 1e-6 * span, hi - 1e-6 * span)
        out.append(th)
    return out


def _status_message(status: str, success: bool, max_iter: int) -> str:
    if success:
        return f"IPOPT converged ({status})"
    hints = {
        "Maximum_Iterations_Exceeded": f"IPOPT reached max_iter={max_iter} before converging; raise max_iter or "
                                       "give a better start",
        "Infeasible_Problem_Detected": "IPOPT found the collocation constraints locally infeasible; check the "
                                       "parameter bounds and the model's stability for this input",
        "Restoration_Failed": "IPOPT's restoration phase failed; try another start or looser bounds",
        "Invalid_Number_Detected": "IPOPT met NaN/inf in the model functions; the start or bounds allow a "
                                   "blow-up, tighten the bounds",
    }
    return hints.get(status, f"IPOPT did not converge ({status}); inspect the problem or try another start")


def free_run_trajectory(model, params, record, U, x0):
    """The free run of ``params`` on ``record`` (explicit RK4, or the implicit integrator it fell back to)."""
    from duffsym.simulate import simulate

    return simulate(model, params, np.asarray(record.t), U, x0=x0, on_failure="return")


def _outcome(traj) -> tuple:
    return np.asarray(traj.y, dtype=float), traj.success, traj.message


def _free_run(model, params, record, U, x0):
    """``(y, success, message)`` of :func:`free_run_trajectory`."""
    return _outcome(free_run_trajectory(model, params, record, U, x0))


def laplace_covariance(problem, rec_params, x0s, U_list, y_sims) -> np.ndarray:
    """Gauss–Newton covariance of the identified values (slots), initial states marginalised (see :func:`fit`)."""
    from duffsym.simulate import simulate

    model = problem.model
    slots = problem.slots
    n_slots = len(slots)
    nx = model.n_states
    n_rec = len(problem.records)
    n_cols = n_slots + nx * n_rec
    blocks, resid, weights = [], [], []
    for i, (rec, U, x0, params) in enumerate(zip(problem.records, U_list, x0s, rec_params)):
        chans = {c.name: U[:, j] for j, c in enumerate(model.inputs)}
        t = np.asarray(rec.t)
        # a fixed substep count keeps the discretisation the same while differencing
        ref = simulate(model, params, t, chans, x0=x0, on_failure="return")
        if not ref.success:
            return np.full((n_slots, n_slots), np.nan)
        n_sub = int(min(max(int(ref.substeps.max()), 1) * 2, 200))
        # ... and the same integrator (the implicit one when the explicit run fell back to it)
        how = {"substeps": n_sub, "method": ref.method, "on_failure": "return"}
        base = simulate(model, params, t, chans, x0=x0, **how)
        Jb = np.zeros((rec.n_times, n_cols))
        for j in sorted(set(problem.slot_index(i))):
            n = slots[j][0]
            step = 1e-6 * max(abs(params[n]), model.param(n).typical_scale)
            ys = []
            for sgn in (1, -1):
                p = dict(params)
                p[n] = params[n] + sgn * step
                ys.append(simulate(model, p, t, chans, x0=x0, **how).y)
            Jb[:, j] = (ys[0] - ys[1]) / (2 * step)
        x0v = np.asarray(x0, dtype=float)
        for s in range(nx):
            step = 1e-6 * max(abs(x0v[s]), 1e-3 * max(1.0, float(np.max(np.abs(x0v)))))
            ys = []
            for sgn in (1, -1):
                xx = x0v.copy()
                xx[s] += sgn * step
                ys.append(simulate(model, params, t, chans, x0=xx, **how).y)
            Jb[:, n_slots + nx * i + s] = (ys[0] - ys[1]) / (2 * step)
        blocks.append(Jb)
        resid.append(np.asarray(rec.y) - base.y)
        weights.append(problem.sample_weights(i))
    J = np.vstack(blocks)
    # an initial state the output never sees (the carrier state of a static law) is not estimated: no column
    J = J[:, np.concatenate([np.ones(n_slots, dtype=bool), np.any(J[:, n_slots:] != 0, axis=0)])]
    n_cols = J.shape[1]
    r = np.concatenate(resid)
    wv = np.concatenate(weights)
    used = wv > 0
    if not np.all(np.isfinite(J[used])):
        return np.full((n_slots, n_slots), np.nan)
    dof = int(np.count_nonzero(used)) - n_cols
    if dof <= 0:
        return np.full((n_slots, n_slots), np.nan)
    sigma2 = float(np.sum(wv * r**2)) / dof
    H = J[used].T @ (wv[used, None] * J[used])
    # column scaling keeps the inversion well conditioned when parameters differ by decades
    d = np.sqrt(np.diag(H))
    d = np.where(d > 0, d, 1.0)
    Hs = H / np.outer(d, d)
    cond = np.linalg.cond(Hs)
    if np.isfinite(cond) and cond <= 1e14:
        return (sigma2 * np.linalg.inv(Hs) / np.outer(d, d))[:n_slots, :n_slots]
    warnings.warn(f"the Gauss-Newton Hessian is singular (condition number {cond:.3g}): some free parameters are "
                  "not identifiable from these records; their standard errors are set to inf",
                  ConvergenceWarning, stacklevel=3)
    out = (sigma2 * np.linalg.pinv(Hs) / np.outer(d, d))[:n_slots, :n_slots]
    w_eig, v_eig = np.linalg.eigh(Hs)
    weak = np.abs(v_eig[:n_slots, np.abs(w_eig) < 1e-14 * np.max(np.abs(w_eig))]).sum(axis=1) > 1e-6
    out[weak, :] = np.inf
    out[:, weak] = np.inf
    return out


_laplace_covariance = laplace_covariance  # the name before the fit became a pipeline
