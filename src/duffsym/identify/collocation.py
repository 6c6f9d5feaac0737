r"""Direct collocation + IPOPT: the optimal fit of a model's parameters to measured records.

The state trajectory of every record is a decision variable. Each sample interval
:math:`[t_k, t_{k+1}]` carries a Legendre collocation polynomial of degree 3 (Gauss points, A-stable,
so the stiff Table 2 dynamics need no substeps); the model's equations (generated from the
SymPy model as CasADi functions) hold at the collocation points, with the input reconstructed
linearly between samples, as in :func:`duffsym.simulate.simulate`. The objective is the weighted sum
of squared output residuals at the samples; masked samples leave the objective but their states
still obey the dynamics. Every record shares the parameters; each has its own free initial state.

Parameters enter scaled by ``ParamSpec.scale`` (or, for an effect's parameter that follows the record's units,
the larger of that and its magnitude on the record: :func:`~duffsym.identify.problem.parameter_scales`) and
states by the magnitude of their data-based initial guess, so the decision variables are O(1). The states
start from the data (:mod:`duffsym.identify.states`): for the models with output :math:`y = A_f x_2`,
:math:`x_2 = y / A_f` and :math:`x_1` its cumulative integral with its linear drift removed. Starting the
states at the data, not at a simulation from a guess, is what makes the fit insensitive to the parameter guess.
Those magnitudes, the bounds and IPOPT's tolerances are those of O(1) units: a record whose input or
output peak is far from 1 is fitted divided by powers of 1000 and its answer mapped back through the
model's derived unit-scaling map (:mod:`duffsym.identify.unitscale`), so the same record in any units
gives the same fit (``settings["unit_scaling"]`` says what was done, or why not).

This module is the fit's pipeline only: :func:`parameter_start` -> the NLP
(:class:`~duffsym.identify.nlp.CollocationNLP`, built once) -> one IPOPT run per start -> :func:`best_run`
and :func:`bound_restart_policy` -> the free run (:func:`duffsym.simulate.simulate_record`) and the
covariance (:func:`duffsym.identify.covariance.laplace_covariance`) -> the :class:`IdentificationResult`.
Its options are one :class:`FitOptions`.

References
----------
L. T. Biegler, Nonlinear Programming, SIAM 2010, ch. 10 (direct transcription), doi:10.1137/1.9780898719383.
A. Wächter and L. T. Biegler, Math. Program. 106 (2006) 25-57 (IPOPT), doi:10.1007/s10107-004-0559-y.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields, replace

import numpy as np

from duffsym.errors import ModelError
from duffsym.identify.covariance import laplace_covariance
from duffsym.identify.initial import initial_guess
from duffsym.identify.nlp import (
    HOPELESS_STOPS,
    OTHER_STARTS,
    CollocationNLP,
    IterationLog,
    Run,
    ipopt_settings,
    restart_guard,
)
from duffsym.identify.problem import Problem, record_scaled_bounds
from duffsym.identify.quality import fit_flags, usability
from duffsym.identify.result import IdentificationResult
from duffsym.identify.result import nrmse as record_nrmse
from duffsym.identify.structure import rescaled_problem
from duffsym.identify.unitscale import unit_plan
from duffsym.simulate import simulate_record
from duffsym.status import Status

#: Up to this many samples in total, ``fit(expand="auto")`` expands the NLP graph.
EXPAND_AUTO_SAMPLES = 1000

#: Samples sharing one copy of the free parameters in the NLP (see ``fit``).
PARAM_STRIDE = 8


@dataclass(frozen=True)
class FitOptions:
    """The settings of :func:`fit` (every field has the default ``fit`` uses; pass the object as
    ``fit(problem, x0, options)`` or any field as a keyword, ``fit(problem, max_iter=200)``).

    Fields
    ------
    tol, acceptable_tol, max_iter : IPOPT's ``tol``, ``acceptable_tol`` and ``max_iter``.
    linear_solver : IPOPT's linear solver (``"mumps"`` ships with CasADi).
    degree : degree of the Legendre collocation polynomial in each sample interval.
    print_level : IPOPT verbosity (0 silent).
    expand : (``derivatives="casadi"`` only) expand the CasADi graph to scalar form: evaluation per
        iteration ~10x faster, build ~5x slower (a cost per sample). ``"auto"`` expands only for
        multistart fits (``n_starts >= 3``) of up to ``EXPAND_AUTO_SAMPLES`` samples in total, where the
        faster iterations repay the build (a single 400-sample fit does not repay it: it finished sooner
        unexpanded); otherwise it keeps the mapped graph, whose build is linear in N.
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
        its stability conditions, a symbolic derivation per model, for flags nobody reads).
    bound_restart : (single-start fits; with ``n_starts > 1`` the other starts do this job) when the
        run ends with a free parameter on a bound it did not start on, run IPOPT once more from its end
        parameters with those back at their start values (the states from the data, as for every
        start), and keep the restart if it lowers the cost (``settings["bound_restart"]`` says what
        happened). A path can be pushed onto a bound by its first steps, far from the data's optimum.
    progress : a callable taking one line of text (e.g. ``print`` to stderr), or None: the stage
        (building, solving) and, every ``nlp.PROGRESS_EVERY`` seconds of a solve, its IPOPT iteration,
        elapsed time, the last iteration's time and, when it is ill-conditioned, IPOPT's Hessian
        regularisation (from IPOPT's intermediate callback).
    guard : a stop rule asked after every IPOPT iteration of the run(s) from the start(s) with the run's
        :class:`~duffsym.identify.nlp.IterationLog`; a reason it returns stops the run, which is then not a
        success and says why. For optional runs that a converged fit already answers (the second start of
        :func:`~duffsym.identify.fit_with_effects`: :func:`~duffsym.identify.nlp.bounded_guard`). None: none.
    max_wall_time : seconds the solves may take in all (None: no limit). When the budget runs out, IPOPT
        stops at its next iteration: during the first run(s) the result is not a success and its message
        names the phase and what to try; during a bound restart the converged run it started from is kept.
        ``settings["iterations"]`` gives each run's iteration times and regularisation either way.
    """

    tol: float = 1e-10
    acceptable_tol: float = 1e-7
    max_iter: int = 500
    linear_solver: str = "mumps"
    degree: int = 3
    print_level: int = 0
    expand: bool | str = "auto"
    compute_stderr: bool = True
    n_starts: int = 1
    start_spread: float = 10.0
    rng: np.random.Generator | int | None = None
    ipopt_options: Mapping[str, object] | None = None
    derivatives: str = "structured"
    param_stride: int = PARAM_STRIDE
    bound_restart: bool = True
    progress: Callable[[str], None] | None = None
    flags: bool = True
    max_wall_time: float | None = None
    guard: Callable[[IterationLog], str] | None = None


def fit_options(options: FitOptions | None = None, **settings) -> FitOptions:
    """``options`` (default :class:`FitOptions`) with the keyword ``settings`` replacing its fields.

    Raises
    ------
    TypeError
        For a keyword that is not a :class:`FitOptions` field (named in the message), or ``options`` of
        another type.
    """
    if options is None:
        options = FitOptions()
    elif not isinstance(options, FitOptions):
        raise TypeError(f"fit() options must be a FitOptions; got {type(options).__name__}")
    unknown = sorted(set(settings) - {f.name for f in fields(FitOptions)})
    if unknown:
        raise TypeError(
            f"fit() got an unexpected keyword argument {unknown[0]!r} (the settings are FitOptions' "
            f"fields: {', '.join(f.name for f in fields(FitOptions))})"
        )
    return replace(options, **settings) if settings else options


def fit(
    problem: Problem,
    x0: Mapping[str, float] | Sequence[float] | None = None,
    options: FitOptions | None = None,
    **settings,
) -> IdentificationResult:
    r"""Identify the free parameters of ``problem`` by direct collocation and IPOPT.

    Parameters
    ----------
    problem : the :class:`Problem` (model, records, free/fixed parameters, bounds, weights, mask).
    x0 : initial values of the free parameters (by name, or ordered as ``problem.free``); missing
        names, or None, take :func:`~duffsym.identify.initial_guess` on the first record.
    options : the solver settings, a :class:`FitOptions` (default: its defaults).
    **settings : any :class:`FitOptions` field by name (``tol``, ``max_iter``, ``n_starts``, ``rng``,
        ``compute_stderr``, ``progress``, ``max_wall_time``, ...), replacing that field of ``options``;
        an unknown name raises :class:`TypeError`.

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
    objective to the free parameters and the initial states of each record (forward differences of
    :func:`duffsym.simulate.simulate` with a fixed substep count),
    :math:`\Sigma = \sigma^2 (J^\top W J)^{-1}`, :math:`\sigma^2 = \mathrm{SSR}/(N - p)`, ``p``
    counting the free parameters and the initial states; the parameter block of :math:`\Sigma`
    is reported (the initial states are marginalised).
    """
    opts = fit_options(options, **settings)
    t_plan = time.perf_counter()
    plan = unit_plan(problem, x0)  # a record far from unit scale: fitted normalised and mapped back
    t_plan = time.perf_counter() - t_plan
    if plan.applied:
        assert plan.problem is not None
        fitted = _fit(plan.problem, plan.x0, opts)
        t_map = time.perf_counter()
        out = plan.result(fitted, problem)
        return replace(out, timings={**out.timings, "unit_scaling": t_plan + time.perf_counter() - t_map})
    return plan.annotate(_fit(problem, x0, opts))


def _fit(problem: Problem, x0, opts: FitOptions) -> IdentificationResult:
    """The fit of ``problem`` in its own units; from the model's defaults once more when the automatic start
    (``x0`` None) converged to a model whose free run fails, or its solve diverged or stalled
    (:func:`_second_start`)."""
    t0 = time.perf_counter()
    first = _fit_from(problem, x0, opts)
    if x0 is not None or not (first.status is Status.FREE_RUN_FAILED or _hopeless(first)):
        return first
    left = None if opts.max_wall_time is None else float(opts.max_wall_time) - (time.perf_counter() - t0)
    if left is not None and left <= 0:
        return first
    return _second_start(problem, first, replace(opts, max_wall_time=left))


def _hopeless(res: IdentificationResult) -> bool:
    """Whether ``res``'s solve was stopped because it diverged or stalled (:data:`~.nlp.HOPELESS_STOPS`), read from
    ``settings["stop_rule"]`` (:func:`stop_rule`), not from the message's words."""
    return not res.success and f"{res.settings.get('stop_rule')}:" in HOPELESS_STOPS


def stop_rule(run: Run) -> str | None:
    """The name of the duffsym rule that stopped IPOPT in ``run`` (``"time"``, ``"ridge"``, ``"diverged"``,
    ``"stalled"``, or the first word of a caller's guard reason), or None when IPOPT ended on its own."""
    if not run.stopped:
        return None
    return run.stopped.split(":", 1)[0].strip() or None


def _second_start(problem: Problem, first: IdentificationResult, opts: FitOptions) -> IdentificationResult:
    """The fit from the model's defaults (inside the bounds) after the automatic start's fit failed its free run,
    or its solve diverged or stalled.

    Collocation fits the trajectory, so it can converge to an unstable model that follows the samples but diverges
    when run free. Measured on s12's smoke record (``mr-damper-current``, a switching current): the command start
    (c1 3.30, c3 302, k2 241, eta 100; the truth 4, 400, 300, 100) converged in 76 iterations to k1 + k2 = -25.5,
    c1 + c2 = -8.7, whose free run blows up; so did 3 starts differing from it in the last bit (4 of 4, with and
    without the bound restart); from the defaults the fit reaches NRMSE 0.0100 and the truth. On 6 s of the Dyke
    record at 500 Hz the command start's solve diverged at iteration 52; from the defaults the fit reaches NRMSE
    0.197 (87 s, a ridge stop after a bound restart). (Both with IPOPT's initial barrier parameter 0.1; from
    :data:`~.nlp.MU_INIT` the command start converges there in 53 iterations, NRMSE 0.1973.)"""
    x0 = {n: min(max(problem.model.param(n).default, problem.bounds[n][0]), problem.bounds[n][1]) for n in problem.free}
    say = opts.progress or _silent
    stopped = _hopeless(first)
    say(
        f"the fit from the automatic start {'was stopped' if stopped else 'diverges when run free'}; fitting again "
        "from the model's defaults"
    )
    second = _fit_from(problem, x0, opts)
    why = first.message.split(": ", 1)[-1]
    note = {"first_status": str(first.status), "first_message": first.message, "kept": "defaults"}
    if not second.success:
        note.update(kept="first", second_status=str(second.status))
        return replace(first, settings={**first.settings, "second_start": note})
    return replace(
        second,
        message=second.message + f"; from the model's defaults (the automatic start's fit "
        f"{'was stopped' if stopped else 'diverged when run free'}: {why})",
        settings={**second.settings, "second_start": note},
    )


def _fit_from(problem: Problem, x0, opts: FitOptions) -> IdentificationResult:
    """The fit of ``problem`` in its own units from ``x0`` (the pipeline of :func:`fit`)."""
    t_build = time.perf_counter()
    n_starts, expand = _checked_options(problem, opts)
    say = opts.progress or _silent
    problem, start, nlp = _build(problem, x0, opts, expand, say)
    build = time.perf_counter() - t_build
    solved = _solve(problem, nlp, opts, n_starts, build, say)
    slot_values, x0s = nlp.unscale(solved.best.w)
    # a solve the time limit or a stop rule (diverged, stalled, a caller's guard) stopped is not an optimum: no
    # standard errors (they would cost more time: about 2 s on the Dyke slice's diverged command start)
    stopped = solved.best.status in (Status.TIME_LIMIT, Status.USER_STOP)
    fitted = _evaluate(problem, nlp, slot_values, x0s, opts.compute_stderr and not stopped)
    settings_out = _settings(opts, nlp, start, expand, solved, fitted)
    return _result(
        problem,
        nlp,
        solved.best,
        fitted,
        slot_values,
        x0s,
        settings_out,
        {"build": build, "solve": solved.seconds},
        flags=opts.flags,
    )


@dataclass(frozen=True)
class Solved:
    """The IPOPT runs of one fit: the run kept (``best``), every start's run, the bound restart's note
    (``settings["bound_restart"]``), how many runs converged and the seconds the solves took."""

    best: Run
    runs: tuple[Run, ...]
    bound_note: dict | None
    n_converged: int
    seconds: float


def _build(problem: Problem, x0, opts: FitOptions, expand: bool, say) -> tuple[Problem, dict, CollocationNLP]:
    """The start of every slot and the NLP (a composed structure's problem rescaled to O(1) first)."""
    start = parameter_start(problem, x0)
    if getattr(problem.model, "composition", ()):  # a structure with an element: O(1) variables whatever the units
        problem = rescaled_problem(problem, start)
    say(
        f"building the collocation NLP ({sum(r.n_times for r in problem.records)} samples, "
        f"{len(problem.slot_names)} free parameters)"
    )
    nlp = CollocationNLP(
        problem,
        start,
        degree=opts.degree,
        derivatives=opts.derivatives,
        expand=expand,
        param_stride=opts.param_stride,
        solver_options=ipopt_settings(
            tol=opts.tol,
            acceptable_tol=opts.acceptable_tol,
            max_iter=opts.max_iter,
            print_level=opts.print_level,
            linear_solver=opts.linear_solver,
            ipopt_options=opts.ipopt_options,
        ),
    )
    return problem, start, nlp


def _solve(problem: Problem, nlp: CollocationNLP, opts: FitOptions, n_starts: int, build: float, say) -> Solved:
    """One IPOPT run per start (the first from the start, the others random), the best kept, a bound restart."""
    t_solve = time.perf_counter()
    deadline = None if opts.max_wall_time is None else t_solve + float(opts.max_wall_time)
    starts = [nlp.th0] + _random_starts(nlp.th0, nlp.lo, nlp.hi, nlp.p_scale, n_starts - 1, opts.start_spread, opts.rng)
    say(f"built in {build:.1f} s; solving" + (f" from {n_starts} starts" if n_starts > 1 else ""))
    runs = [
        nlp.solve(
            th,
            max_iter=opts.max_iter,
            progress=opts.progress,
            deadline=deadline,
            label=f"start {i + 1}/{n_starts}" if n_starts > 1 else "",
            guard=opts.guard,
        )
        for i, th in enumerate(starts)
    ]
    runs = [
        _timed_out(
            r,
            "the IPOPT solve" + (f" of start {i + 1}/{n_starts}" if n_starts > 1 else ""),
            opts.max_wall_time,
            problem,
        )
        for i, r in enumerate(runs)
    ]
    runs = [_on_guard(_on_ridge(r)) for r in runs]
    i_best = best_run(runs)
    best, bound_note = runs[i_best], None
    if opts.bound_restart and n_starts == 1 and best.success:
        best, bound_note = bound_restart_policy(
            nlp, best, starts[i_best], max_iter=opts.max_iter, progress=opts.progress, deadline=deadline
        )
    n_ok = sum(r.success for r in runs)
    if n_starts > 1:
        best = replace(best, message=best.message + f"; best of {n_starts} starts ({n_ok} converged)")
    solve = time.perf_counter() - t_solve
    say(
        f"solved in {solve:.1f} s: {best.status}, {best.n_iter} iterations"
        + _iteration_note(runs, bound_note)
        + "; free run and standard errors"
    )
    return Solved(best, tuple(runs), bound_note, n_ok, solve)


def _settings(
    opts: FitOptions, nlp: CollocationNLP, start: dict, expand: bool, solved: Solved, fitted: Evaluation
) -> dict:
    """``IdentificationResult.settings``: how the fit was made (the keys of ``docs/contract.md``)."""
    runs, bound_note = solved.runs, solved.bound_note
    return {
        "method": "direct collocation",
        "scheme": "legendre",
        "degree": int(opts.degree),
        "expand": bool(expand) and opts.derivatives == "casadi",
        "derivatives": opts.derivatives,
        "param_stride": nlp.stride,
        "tol": opts.tol,
        "acceptable_tol": opts.acceptable_tol,
        "max_iter": int(opts.max_iter),
        "linear_solver": opts.linear_solver,
        "start": start,
        "n_starts": len(runs),
        "starts_converged": solved.n_converged,
        "constraints": nlp.constraints,
        "bound_restart": bound_note,
        "stop_rule": stop_rule(solved.best),
        "start_costs": [r.cost * 2 * nlp.y_norm**2 for r in runs],
        "y_norm": nlp.y_norm,
        "max_wall_time": opts.max_wall_time,
        "iterations": [r.iterations for r in runs]
        + ([bound_note["iterations"]] if bound_note and bound_note.get("iterations") else []),
        "integrator": fitted.integrator,
    }


def _silent(msg: str) -> None:
    return None


def _timed_out(run: Run, phase: str, budget, problem) -> Run:
    """A run the wall-clock budget stopped: not a success, with a message naming the phase and what to try."""
    if run.stopped != "time":
        return run
    n = sum(r.n_times for r in problem.records)
    info = run.iterations or {}
    return replace(
        run,
        status=Status.TIME_LIMIT,
        success=False,
        message=(
            f"stopped by the time limit ({budget:g} s) in {phase} after {run.n_iter} iterations (slowest iteration "
            f"{info.get('seconds_max', 0):.1f} s, Hessian regularisation up to "
            f"{info.get('regularisation_max', 0):.1e}); "
            f"try: check the units of the record (a time column in ms, signals far from O(1)), a start closer to the "
            f"data (--fix or x0), fewer samples ({n} now: decimate or cut the record), or a larger time limit"
        ),
    )


def _on_ridge(run: Run) -> Run:
    """A run stopped on a ridge (:meth:`~duffsym.identify.nlp.IterationLog.ridge`): its answer, usable, with the
    status :attr:`~duffsym.status.Status.RIDGE` and a message naming what still moved."""
    if not run.stopped.startswith("ridge"):
        return run
    return replace(
        run,
        status=Status.RIDGE,
        success=True,
        message=f"IPOPT stopped after {run.n_iter} iterations on a {run.stopped}: the parameters that moved are "
        "poorly determined by these records (see the ridge flag)",
    )


def _on_guard(run: Run) -> Run:
    """A run the caller's ``guard`` stopped (not the time limit, not a ridge): not a success, saying why."""
    if not run.stopped or run.stopped == "time" or run.status == Status.RIDGE:
        return run
    advice = f". {OTHER_STARTS}" if run.stopped.startswith(HOPELESS_STOPS) else ""
    return replace(run, success=False, message=f"stopped after {run.n_iter} iterations: {run.stopped}{advice}")


def ridge_flag(run: Run) -> list[dict]:
    """The ``ridge`` flag of a fit whose kept run stalled on a ridge ([] otherwise)."""
    if run.status != Status.RIDGE:
        return []
    return [
        {
            "flag": "ridge",
            "message": f"the fit stalled on a {run.stopped}; those parameters trade against each other (a "
            "near-symmetry of the model on these records, or an optimum at a limit such as a rigid-plastic "
            "element): read their standard errors, fix one of them (--fix), or add records that separate them",
        }
    ]


def _iteration_note(runs, bound_note) -> str:
    """`` (iterations median X s, max Y s at iteration k[; N ill-conditioned])`` of the runs of a fit."""
    infos = [r.iterations for r in runs if r.iterations] + (
        [bound_note["iterations"]] if bound_note and bound_note.get("iterations") else []
    )
    if not infos or not sum(i["n"] for i in infos):
        return ""
    worst = max(infos, key=lambda i: i["seconds_max"])
    med = float(np.median([i["seconds_median"] for i in infos if i["n"]]))
    bad = sum(i["ill_conditioned"] for i in infos)
    return (
        f" (iteration median {med:.2g} s, slowest {worst['seconds_max']:.2g} s"
        + (
            f"; {bad} ill-conditioned iterations, Hessian regularisation up to "
            f"{max(i['regularisation_max'] for i in infos):.1e}"
            if bad
            else ""
        )
        + ")"
    )


def _checked_options(problem: Problem, opts: FitOptions) -> tuple[int, bool]:
    """The solver options checked; ``(n_starts, expand)`` resolved."""
    n_starts, start_spread, expand = opts.n_starts, opts.start_spread, opts.expand
    if int(n_starts) != n_starts or n_starts < 1 or not start_spread >= 1:
        raise ModelError(f"n_starts must be a positive integer and start_spread >= 1; got {n_starts}, {start_spread}")
    n_starts = int(n_starts)
    if expand == "auto":
        expand = sum(r.n_times for r in problem.records) <= EXPAND_AUTO_SAMPLES and n_starts >= 3
    elif not isinstance(expand, bool):
        raise ModelError(f"expand must be True, False or 'auto'; got {expand!r}")
    if opts.derivatives not in ("structured", "casadi"):
        raise ModelError(f"derivatives must be 'structured' or 'casadi'; got {opts.derivatives!r}")
    if opts.degree < 1 or int(opts.degree) != opts.degree:
        raise ModelError(f"degree must be a positive integer; got {opts.degree}")
    if opts.max_iter < 0 or opts.tol <= 0:
        raise ModelError(f"max_iter must be >= 0 and tol > 0; got max_iter={opts.max_iter}, tol={opts.tol}")
    return n_starts, expand


def parameter_start(problem: Problem, x0: Mapping[str, float] | Sequence[float] | None = None) -> dict[str, float]:
    """The start value of every parameter slot: ``x0`` where given (by name, or ordered as
    ``problem.slot_names``), else :func:`~duffsym.identify.initial_guess` on the slot's first record;
    checked finite and inside the bounds."""
    model, slots, slot_names = problem.model, problem.slots, problem.slot_names
    start: dict[str, float] = {}
    if x0 is not None:
        if isinstance(x0, Mapping):
            unknown = sorted(set(x0) - set(model.param_names) - set(slot_names))
            if unknown:
                raise ModelError(f"x0: unknown parameter(s) {unknown}; known: {list(model.param_names)}")
            for sn, (n, _lab) in zip(slot_names, slots):
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
    scaled = set(record_scaled_bounds(model, problem.records))
    for sn, (n, _lab) in zip(slot_names, slots):
        lo, hi = problem.bounds[n]
        v = start[sn]
        if not math.isfinite(v):
            raise ModelError(f"x0: initial value of {sn} must be finite; got {v}")
        if not lo <= v <= hi and n in scaled:  # a bound scaled to the record (record_scaled_bounds): moved inside
            v = start[sn] = min(max(v, lo), hi)
        if not lo <= v <= hi:
            raise ModelError(
                f"x0: initial value of {sn} = {v:g} is outside its bounds [{lo:g}, {hi:g}]; move it inside"
            )
    return start


def best_run(runs: Sequence[Run]) -> int:
    """Index of the converged run with the lowest cost (the first run if none converged; ties: the first)."""
    ok = [i for i, r in enumerate(runs) if r.success]
    return min(ok, key=lambda i: runs[i].cost) if ok else 0


def bound_restart_policy(
    nlp: CollocationNLP, best: Run, th_start: np.ndarray, *, max_iter: int, progress=None, deadline: float | None = None
) -> tuple[Run, dict | None]:
    """When ``best`` ended with a parameter on a bound it did not start on, one more run from its end
    parameters with those back at their start values (states from the data); the restart is kept if
    it lowers the cost. Returns the run kept and a note for ``settings["bound_restart"]`` (None if no
    parameter moved onto a bound).

    The converged ``best`` is never lost: the restart runs under :func:`~duffsym.identify.nlp.restart_guard`
    (it stops when its iterations turn slow or ill-conditioned, or after a few times ``best``'s iterations)
    and under the fit's ``deadline``; a stopped restart keeps ``best``, and the note says why it stopped."""
    # a parameter that moved onto a bound may be a trap of the path, not of the data: measured on
    # noise-free Table 2 data, 1 of 120 random starts stopped at k1 = 0, k2 ~ 0 (NRMSE 0.015);
    # a new run from its end parameters with k1 back at its start value (states from the data again,
    # as in every start) reached the truth
    lo_s, hi_s, n_slots = nlp.lo, nlp.hi, nlp.n_slots
    th_end = best.w[:n_slots]
    tol_b = 1e-6 * np.maximum(1.0, np.abs(th_end))
    at_bound = [
        j
        for j in range(n_slots)
        if (np.isfinite(lo_s[j]) and th_end[j] - lo_s[j] <= tol_b[j] < th_start[j] - lo_s[j])
        or (np.isfinite(hi_s[j]) and hi_s[j] - th_end[j] <= tol_b[j] < hi_s[j] - th_start[j])
    ]
    if not at_bound:
        return best, None
    th_re = th_end.copy()
    th_re[at_bound] = th_start[at_bound]
    again = nlp.solve(
        th_re,
        max_iter=max_iter,
        progress=progress,
        label="bound restart",
        deadline=deadline,
        guard=restart_guard(best, max_iter=max_iter),
    )
    names_b = ", ".join(nlp.slot_names[j] for j in at_bound)
    better = again.success and again.cost < best.cost * (1 - 1e-9)
    y2 = 2 * nlp.y_norm**2
    stopped = "the time limit" if again.stopped == "time" else again.stopped
    note = {
        "parameters": [nlp.slot_names[j] for j in at_bound],
        "cost_before": best.cost * y2,
        "cost_after": again.cost * y2 if math.isfinite(again.cost) else math.inf,
        "kept": "restart" if better else "first",
        "iterations": again.iterations,
        "stopped": stopped or None,
    }
    if better:
        kept = replace(
            again,
            n_iter=best.n_iter + again.n_iter,
            message=again.message + f"; {names_b} had stopped on a bound: a restart with it back at its "
            f"start lowered the cost {best.cost / again.cost:.3g}x",
        )
    elif stopped:
        kept = replace(
            best,
            message=best.message + f"; {names_b} ended on a bound; a restart with it back at its start "
            f"was stopped after {again.n_iter} iterations ({stopped}); the converged run is kept",
        )
    else:
        kept = replace(
            best,
            message=best.message + f"; {names_b} ended on a bound and a restart with it back at its "
            "start found nothing better",
        )
    return kept, note


@dataclass(frozen=True)
class Evaluation:
    """The fitted parameters judged by their free run on every record (:func:`_evaluate`).

    ``rec_params``: each record's parameters by name; ``y_sims``: each free-run output; ``ok``: every free
    run succeeded (``failure``: the first failure's message); ``integrator``: each record's integrator;
    ``nrmse`` over all samples, ``nrmse_records`` per record, ``nrmse_objective`` over the samples in the
    objective (inf when a run failed); ``covariance`` of the slots (NaN when not computed);
    ``t_free``, ``t_se``: the seconds of the free runs and of the covariance.
    """

    rec_params: list
    y_sims: tuple
    ok: bool
    integrator: list
    failure: str
    nrmse: float
    nrmse_records: tuple
    nrmse_objective: float
    covariance: np.ndarray
    t_free: float
    t_se: float


def _evaluate(problem: Problem, nlp: CollocationNLP, slot_values, x0s, compute_stderr: bool) -> Evaluation:
    """Free run of the fitted parameters on every record, its errors, and the Laplace covariance."""
    rec_params = [problem.record_params(i, slot_values) for i in range(len(problem.records))]
    t_free = time.perf_counter()
    runs = [
        simulate_record(problem.model, rp, rec, x0=x, on_failure="return")
        for rp, rec, x in zip(rec_params, problem.records, x0s)
    ]
    t_free = time.perf_counter() - t_free
    y_sims = tuple(np.asarray(tr.y, dtype=float) for tr in runs)
    ok_runs = all(tr.success for tr in runs)
    records = problem.records
    sse = sum(float(np.sum((np.asarray(r.y) - ys) ** 2)) for r, ys in zip(records, y_sims))
    sst = sum(float(np.sum((np.asarray(r.y) - np.mean(r.y)) ** 2)) for r in records)
    used = [problem.sample_weights(i) > 0 for i in range(len(records))]
    sse_u = sum(float(np.sum(((np.asarray(r.y) - ys) ** 2)[u])) for r, ys, u in zip(records, y_sims, used))
    sst_u = sum(float(np.sum(((np.asarray(r.y) - np.mean(np.asarray(r.y)[u])) ** 2)[u])) for r, u in zip(records, used))
    t_se = time.perf_counter()
    cov = np.full((nlp.n_slots, nlp.n_slots), np.nan)
    if compute_stderr and ok_runs:
        cov = laplace_covariance(problem, rec_params, x0s, [b.U for b in nlp.blocks], y_sims)
    t_se = time.perf_counter() - t_se
    return Evaluation(
        rec_params=rec_params,
        y_sims=y_sims,
        ok=ok_runs,
        integrator=[{"record": r.name, **tr.integrator} for r, tr in zip(records, runs)],
        failure=next((tr.message for tr in runs if not tr.success), ""),
        nrmse=math.sqrt(sse / sst) if ok_runs else math.inf,
        nrmse_records=tuple(record_nrmse(r.y, ys) for r, ys in zip(records, y_sims)),
        nrmse_objective=math.sqrt(sse_u / sst_u) if ok_runs else math.inf,
        covariance=cov,
        t_free=t_free,
        t_se=t_se,
    )


def _result(
    problem, nlp, best: Run, fitted: Evaluation, slot_values, x0s, settings, timings, flags: bool = True
) -> IdentificationResult:
    """The :class:`IdentificationResult`: the run, judged usable or not (:func:`usability`), with its flags."""
    import casadi

    import duffsym

    model = problem.model
    nrmse = fitted.nrmse
    r2 = 1 - nrmse**2 if math.isfinite(nrmse) else -math.inf
    status, success, message = best.status, best.success, best.message
    if success and not fitted.ok:
        success = False
        message = (
            f"IPOPT converged ({status}) but the free-run simulation with the fitted parameters failed: "
            f"{fitted.failure}"
        )
        status = Status.FREE_RUN_FAILED
    elif success:
        status, success, message = usability(problem, fitted.rec_params, r2, status, message)
    cov = fitted.covariance
    stderr = {
        n: float(math.sqrt(cov[j, j])) if np.isfinite(cov[j, j]) and cov[j, j] >= 0 else math.nan
        for j, n in enumerate(nlp.slot_names)
    }
    params = problem.full_params(slot_values) if not problem.group_order else _grouped_params(problem, slot_values)
    t_flags = time.perf_counter()
    flag_list = (fit_flags(problem, nlp, best.w, fitted.rec_params, r2, stderr) if fitted.ok and flags else []) + (
        ridge_flag(best)
    )
    t_flags = time.perf_counter() - t_flags  # the first fit of a model derives its stability conditions
    casadi_version = casadi.__version__  # type: ignore[attr-defined]  # CasADi's stubs leave out __version__
    return IdentificationResult(
        model=model,
        params=params,
        free=tuple(nlp.slot_names),
        fixed=dict(problem.fixed),
        stderr=stderr,
        covariance=cov,
        cost=best.cost * 2 * nlp.y_norm**2,
        nrmse=nrmse,
        r2=r2,
        status=status,
        success=success,
        message=message,
        n_iter=best.n_iter,
        timings={**timings, "free_run": fitted.t_free, "stderr": fitted.t_se, "flags": t_flags},
        mask=problem.masks(),
        defaults_applied=dict(problem.defaults_applied),
        effects=tuple(model.effects),
        structural=dict(model.structural),
        nrmse_records=fitted.nrmse_records,
        nrmse_objective=fitted.nrmse_objective,
        x0=tuple(x0s),
        y_sim=fitted.y_sims,
        records=tuple(r.name for r in problem.records),
        mask_info=dict(problem.mask_info),
        settings=settings,
        versions={"casadi": casadi_version, "duffsym": getattr(duffsym, "__version__", "?")},
        n_samples=int(sum(r.n_times for r in problem.records)),
        group_params={
            lab: problem.record_params(problem.labels.index(lab), slot_values) for lab in problem.group_order
        },
        groups=tuple(problem.labels) if problem.group_order else (),
        flags=tuple(flag_list),
    )


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
