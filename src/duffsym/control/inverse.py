"""The inverse for control: the command history that makes a command-driven model produce a desired force.

Solved on the same symbolic model as everything else: its CasADi right-hand side is discretised by
Radau IIA collocation (degree 3, stiffly accurate, so the stiff c3 x'^n term needs no substeps) on the
sample grid, the command is a decision variable at every sample (linear between samples, as
:func:`duffsym.simulate.simulate` reconstructs it), held within its range and rate, and IPOPT
minimises the squared force error (plus a small penalty on command effort and changes, which picks
the cheapest of equally good commands). The answer is checked by a free run of the model with that
command (the compiled simulator, not the NLP's discretisation); where that run misses the desired
force the sample is reported unreachable, with the reason: the command at its upper or lower limit,
at its rate limit, or a desired force that would supply power (an MR damper can only dissipate).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from duffsym._json import finite_or_none
from duffsym.errors import DataError, ModelError
from duffsym.options import resolve

#: Collocation degree (Radau IIA points).
DEGREE = 3
#: A sample is unreachable when the checked free run misses the desired force by more than this
#: fraction of the desired force's RMS (and by more than the tolerance given).
UNREACHABLE_FRACTION = 0.05


def command_index(model) -> int:
    """Index of the model's command input channel; ModelError if it has none."""
    for j, ch in enumerate(model.inputs):
        if ch.signal == "command" and ch.order == 0:
            return j
    raise ModelError(
        f"model {model.name} has no command input (channels {[c.name for c in model.inputs]}); the "
        "inverse needs a command-driven model, e.g. mr-damper-current (duffsym models lists them)"
    )


@dataclass(frozen=True, eq=False)
class InverseResult:
    """The command history found by :func:`invert` and how well the model then tracks the desired force.

    Attributes
    ----------
    t, command : (n_times,) the command (within ``limits`` and ``rate``).
    force_desired, force_model : (n_times,) the desired force and the model's free run with ``command``.
    rmse, nrmse : tracking error of that free run (nrmse relative to the desired force's RMS).
    unreachable : (n_times,) bool, samples where the free run misses the desired force.
    reasons : per-reason counts of unreachable samples; ``segments``: their time intervals with a reason.
    success, status, message : the solver's outcome (``success`` means a command was found and its
        free run completed; unreachable samples are reported, not a failure).
    """

    model: str
    t: np.ndarray
    command: np.ndarray
    force_desired: np.ndarray
    force_model: np.ndarray
    limits: tuple[float, float]
    rate: float | None
    rmse: float
    nrmse: float
    unreachable: np.ndarray
    reasons: dict
    segments: list
    success: bool
    status: str
    message: str
    seconds: dict = field(default_factory=dict)
    x0: tuple = ()
    command_name: str = "command"

    @property
    def fraction_unreachable(self) -> float:
        return float(np.mean(self.unreachable)) if self.unreachable.size else 0.0

    def effort(self) -> dict:
        """Command effort: mean level (in command units), RMS and total variation per second."""
        c = self.command
        dur = float(self.t[-1] - self.t[0]) or 1.0
        return {
            "mean": float(np.mean(c)),
            "rms": float(np.sqrt(np.mean(c**2))),
            "variation_per_s": float(np.sum(np.abs(np.diff(c))) / dur),
        }

    def to_dict(self) -> dict:
        return {
            "model": self.model,
            "success": bool(self.success),
            "status": self.status,
            "message": self.message,
            "limits": [float(v) for v in self.limits],
            "rate": None if self.rate is None else finite_or_none(self.rate),
            "rmse": finite_or_none(self.rmse),
            "nrmse": finite_or_none(self.nrmse),
            "n_samples": int(self.t.size),
            "fraction_unreachable": self.fraction_unreachable,
            "unreachable_reasons": dict(self.reasons),
            "unreachable_segments": list(self.segments),
            "effort": self.effort(),
            "seconds": dict(self.seconds),
            "x0": [float(v) for v in self.x0],
            "command_name": self.command_name,
        }

    def summary(self) -> str:
        head = (
            f"inverse of {self.model}: {self.status}"
            + ("" if self.success else f" (FAILED: {self.message})")
            + f"; command within [{self.limits[0]:g}, {self.limits[1]:g}]"
            + (f", rate <= {self.rate:g}/s" if self.rate else "")
        )
        lines = [
            head,
            f"  tracking by the model's free run: RMSE {self.rmse:.4g}, NRMSE {self.nrmse:.4g} over "
            f"{self.t.size} samples; solved in {self.seconds.get('solve', math.nan):.2f} s",
        ]
        if self.unreachable.any():
            why = ", ".join(f"{k}: {v}" for k, v in self.reasons.items())
            lines.append(f"  unreachable: {self.fraction_unreachable:.1%} of the samples ({why})")
            for s in self.segments[:8]:
                lines.append(f"    {s['start']:.4g}-{s['end']:.4g} s: {s['reason']}")
            if len(self.segments) > 8:
                lines.append(f"    ... {len(self.segments) - 8} more segment(s) in the JSON")
        else:
            lines.append("  the desired force is reachable throughout")
        e = self.effort()
        lines.append(
            f"  command effort: mean {e['mean']:.4g}, RMS {e['rms']:.4g}, variation {e['variation_per_s']:.4g}/s"
        )
        return "\n".join(lines)


def _collocation_matrices(d: int):
    import casadi as ca

    tau = np.append(0.0, ca.collocation_points(d, "radau"))
    C = np.zeros((d + 1, d + 1))
    D = np.zeros(d + 1)
    for j in range(d + 1):
        p = np.poly1d([1.0])
        for r in range(d + 1):
            if r != j:
                p *= np.poly1d([1.0, -tau[r]]) / (tau[j] - tau[r])
        D[j] = p(1.0)
        dp = np.polyder(p)
        for r in range(d + 1):
            C[j, r] = dp(tau[r])
    return tau, C, D


def _interval_function(model):
    """Residuals of one collocation interval and its end state: F(xk, Xc, uk, uk1, p, h)."""
    import casadi as ca

    from duffsym.codegen.casadi_fn import casadi_functions

    rhs, _ = casadi_functions(model)
    n, ni, d = model.n_states, model.n_inputs, DEGREE
    tau, C, D = _collocation_matrices(d)
    xk = ca.SX.sym("xk", n)
    Xc = ca.SX.sym("Xc", n, d)
    uk = ca.SX.sym("uk", ni)
    uk1 = ca.SX.sym("uk1", ni)
    p = ca.SX.sym("p", model.n_params)
    h = ca.SX.sym("h")
    pts = [xk] + [Xc[:, r] for r in range(d)]
    res = []
    for r in range(1, d + 1):
        dx = sum(C[j, r] * pts[j] for j in range(d + 1))
        u = uk + tau[r] * (uk1 - uk)
        res.append(h * rhs(pts[r], u, p) - dx)
    xend = sum(D[j] * pts[j] for j in range(d + 1))
    return ca.Function("interval", [xk, Xc, uk, uk1, p, h], [ca.vertcat(*res), xend])


def _driven_by_command(model, jc: int) -> list[int]:
    """States whose equation involves the command and no other state (the field's lag): they start at
    their equilibrium for the first command value."""
    import sympy as sp

    cmd = model.input_symbols[jc]
    out = []
    for i, e in enumerate(model.rhs):
        others = {s for k, s in enumerate(model.states) if k != i}
        if cmd in e.free_symbols and not (e.free_symbols & others):
            out.append(i)
    del sp
    return out


@dataclass(frozen=True)
class InverseOptions:
    """Every setting of :func:`invert` (its docstring describes each), with its default."""

    limits: tuple[float, float] = (0.0, 1.0)
    rate: float | None = None
    x0: Sequence[float] | None = None
    effort_weight: float = 1e-6
    smooth_weight: float = 1e-3
    tolerance: float = 0.0
    command_guess: Sequence[float] | None = field(default=None, compare=False)
    max_iter: int = 500
    command_name: str = "command"


def invert(
    model,
    params: Mapping[str, float] | Sequence[float],
    t,
    inputs: np.ndarray,
    force,
    options: InverseOptions | None = None,
    **settings,
) -> InverseResult:
    """The command history within ``limits`` (and ``|dc/dt| <= rate``) that makes ``model`` produce ``force``.

    The settings (``limits`` to ``command_name``) are the fields of :class:`InverseOptions`, given as an
    ``options`` object, by keyword, or both (the keywords win); an unknown setting raises :class:`TypeError`.

    Parameters
    ----------
    model : a command-driven model (an input channel ``command``, e.g. ``mr-damper-current``).
    params : its parameters (e.g. a fit's).
    t : (n_times,) sample times.
    inputs : (n_times, n_inputs) the model's inputs; the command column is ignored (it is the unknown).
    force : (n_times,) the desired output.
    limits : command range (lo, hi). rate : largest |dc/dt| (command units per second), None for none.
    x0 : initial state; by default the mechanical states are free (chosen by the solver, as a fit
        chooses them) and a state driven only by the command starts at its equilibrium.
    effort_weight, smooth_weight : weights of the mean squared command (relative to the range) and
        of its squared changes, against the mean squared force error relative to the force's RMS.
    tolerance : absolute force error below which a sample counts as reached (in addition to
        ``UNREACHABLE_FRACTION`` of the force's RMS).
    command_guess : (n_times,) start of the command (default mid-range).
    """
    from duffsym.simulate import check_time, simulate

    o = resolve(InverseOptions, options, settings, "invert")
    rate, x0, command_guess = o.rate, o.x0, o.command_guess
    jc = command_index(model)
    t = check_time(t)
    U = np.array(inputs, dtype=float, copy=True)
    y_star = np.asarray(force, dtype=float)
    lo, hi = (float(v) for v in o.limits)
    _check(model, t, U, y_star, lo, hi, rate)
    p = model.param_vector(params)
    N = t.size - 1
    n = model.n_states
    scale = float(np.sqrt(np.mean(y_star**2))) or 1.0
    c0 = (
        np.full(t.size, 0.5 * (lo + hi)) if command_guess is None else np.clip(np.asarray(command_guess, float), lo, hi)
    )
    U[:, jc] = c0
    tic = time.perf_counter()
    guess = simulate(model, p, t, U, x0=x0, on_failure="return")
    Xg = guess.x if guess.success else np.zeros((t.size, n))
    solver, w0, (lbx, ubx, lbg, ubg) = _inverse_nlp(model, p, t, U, jc, y_star, scale, lo, hi, o, Xg, c0)
    build = time.perf_counter() - tic
    tic = time.perf_counter()
    sol = solver(x0=w0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
    solve = time.perf_counter() - tic
    stats = solver.stats()
    status = str(stats.get("return_status", "unknown"))
    wopt = np.asarray(sol["x"]).ravel()
    X_opt = wopt[: n * (N + 1)].reshape((N + 1, n))
    c_opt = np.clip(wopt[-(N + 1) :], lo, hi)
    return _checked(
        model,
        p,
        t,
        U,
        jc,
        c_opt,
        X_opt[0],
        y_star,
        lo,
        hi,
        rate,
        o.tolerance,
        scale,
        status,
        bool(stats.get("success")) or status == "Solved_To_Acceptable_Level",
        {"build": build, "solve": solve},
        o.command_name,
    )


def _inverse_nlp(model, p, t, U, jc: int, y_star, scale: float, lo: float, hi: float, o: InverseOptions, Xg, c0):
    """The collocation NLP of the inverse: (IPOPT solver, start, bounds ``(lbx, ubx, lbg, ubg)``)."""
    import casadi as ca

    from duffsym.codegen.casadi_fn import casadi_functions

    rate, x0 = o.rate, o.x0
    effort_weight, smooth_weight, max_iter = o.effort_weight, o.smooth_weight, o.max_iter
    N = t.size - 1
    n, ni = model.n_states, model.n_inputs
    F = _interval_function(model).map(N)
    _, out = casadi_functions(model)
    X = ca.MX.sym("X", n, N + 1)
    Xc = ca.MX.sym("Xc", n, DEGREE * N)
    c = ca.MX.sym("c", N + 1)
    Ufix = U.T.copy()
    Ufix[jc, :] = 0.0
    sel = np.zeros((ni, 1))
    sel[jc, 0] = 1.0
    Um = ca.DM(Ufix) + ca.mtimes(ca.DM(sel), c.T)
    h = ca.DM(np.diff(t)).T
    P = ca.repmat(ca.DM(p), 1, N)
    res, xend = F(X[:, :N], Xc, Um[:, :N], Um[:, 1:], P, h)
    y = out.map(N + 1)(X, Um, ca.repmat(ca.DM(p), 1, N + 1))
    rng = max(hi - lo, 1e-12)
    J = (
        ca.sumsqr((y.T - ca.DM(y_star)) / scale) / (N + 1)
        + effort_weight * ca.sumsqr((c - lo) / rng) / (N + 1)
        + smooth_weight * ca.sumsqr((c[1:] - c[:-1]) / rng) / N
    )
    g = [ca.vec(res), ca.vec(xend - X[:, 1:])]
    lbg = [np.zeros(n * DEGREE * N), np.zeros(n * N)]
    ubg = [np.zeros(n * DEGREE * N), np.zeros(n * N)]
    if rate is not None:
        g.append(c[1:] - c[:-1])
        lim = rate * np.diff(t)
        lbg.append(-lim)
        ubg.append(lim)
    lbx_X = -np.inf * np.ones((n, N + 1))
    ubx_X = np.inf * np.ones((n, N + 1))
    if x0 is not None:
        lbx_X[:, 0] = ubx_X[:, 0] = np.asarray(x0, dtype=float)
    else:
        rhs, _ = casadi_functions(model)
        for i in _driven_by_command(model, jc):
            g.append(rhs(X[:, 0], Um[:, 0], ca.DM(p))[i])
            lbg.append(np.zeros(1))
            ubg.append(np.zeros(1))
    w = ca.vertcat(ca.vec(X), ca.vec(Xc), c)
    Xc_guess = np.repeat(Xg[:-1].T, DEGREE, axis=1)  # each stage starts from its interval's start state
    w0 = np.concatenate([Xg.T.ravel(order="F"), Xc_guess.ravel(order="F"), c0])
    lbx = np.concatenate([lbx_X.ravel(order="F"), -np.inf * np.ones(n * DEGREE * N), np.full(N + 1, lo)])
    ubx = np.concatenate([ubx_X.ravel(order="F"), np.inf * np.ones(n * DEGREE * N), np.full(N + 1, hi)])
    solver = ca.nlpsol(
        "inverse",
        "ipopt",
        {"x": w, "f": J, "g": ca.vertcat(*g)},
        {
            "print_time": False,
            "ipopt": {"print_level": 0, "sb": "yes", "max_iter": int(max_iter), "tol": 1e-8, "acceptable_tol": 1e-5},
        },
    )
    return solver, w0, (lbx, ubx, np.concatenate(lbg), np.concatenate(ubg))


def _check(model, t, U, y_star, lo, hi, rate) -> None:
    if U.shape != (t.size, model.n_inputs):
        raise DataError(
            f"inputs must have shape ({t.size}, {model.n_inputs}) for channels "
            f"{[c.name for c in model.inputs]}; got {U.shape}"
        )
    if y_star.shape != t.shape or not np.all(np.isfinite(y_star)):
        bad = np.flatnonzero(~np.isfinite(y_star))
        raise DataError(
            f"the desired force must be {t.size} finite values like t; got shape {y_star.shape}"
            + (f", non-finite at index {bad[0]}" if bad.size else "")
        )
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise DataError(f"command limits must be finite with LO < HI; got {lo}, {hi}")
    if rate is not None and not (math.isfinite(rate) and rate > 0):
        raise DataError(f"the command rate limit must be a positive number per second; got {rate}")


def _checked(model, p, t, U, jc, c, x0, y_star, lo, hi, rate, tolerance, scale, status, ok, seconds, command_name):
    """The free run with command ``c`` and where it misses the desired force (with the reason)."""
    from duffsym.simulate import simulate

    U = U.copy()
    U[:, jc] = c
    tr = simulate(model, p, t, U, x0=x0, on_failure="return")
    y = np.asarray(tr.y, dtype=float)
    if not tr.success:
        ok, status = False, f"{status}; free run failed"
    err = y - y_star
    rmse = float(np.sqrt(np.mean(err**2)))
    miss = np.abs(err) > max(tolerance, UNREACHABLE_FRACTION * scale)
    if not tr.success:
        miss = np.ones(t.size, dtype=bool)
    reason = _reasons(model, U, jc, c, y, y_star, lo, hi, rate, t, miss)
    counts: dict[str, int] = {}
    for r in reason[miss]:
        counts[r] = counts.get(r, 0) + 1
    message = (
        tr.message
        if not tr.success
        else ("ok" if not miss.any() else f"{np.mean(miss):.1%} of the samples unreachable within the command limits")
    )
    return InverseResult(
        model=model.name,
        t=t,
        command=c,
        force_desired=y_star,
        force_model=y,
        limits=(lo, hi),
        rate=rate,
        rmse=rmse,
        nrmse=rmse / scale,
        unreachable=miss,
        reasons=counts,
        segments=_segments(t, miss, reason),
        success=bool(ok and tr.success),
        status=status,
        message=message,
        seconds=seconds,
        x0=tuple(map(float, x0)),
        command_name=command_name,
    )


def _reasons(model, U, jc, c, y, y_star, lo, hi, rate, t, miss) -> np.ndarray:
    """Why each sample is missed: the command at a limit, at its rate limit, or power it would need."""
    tol = 1e-3 * (hi - lo)
    vel = next((j for j, ch in enumerate(model.inputs) if ch.signal == "d" and ch.order == 1), None)
    out = np.full(t.size, "not reached (the state cannot follow within the limits)", dtype=object)
    active = "active force (would supply power; a damper can only dissipate)"
    dc = np.gradient(c, t) if t.size > 1 else np.zeros_like(c)
    for k in np.flatnonzero(miss):
        wrong_way = vel is not None and y_star[k] * U[k, vel] < 0
        if wrong_way and y[k] * y_star[k] <= 0:
            out[k] = active
        elif c[k] >= hi - tol and abs(y_star[k]) > abs(y[k]):
            out[k] = "above the force at the upper command limit"
        elif c[k] <= lo + tol and abs(y_star[k]) < abs(y[k]):
            out[k] = "below the force at the lower command limit"
        elif rate is not None and abs(dc[k]) >= 0.98 * rate:
            out[k] = "command rate limit"
        elif wrong_way:
            out[k] = active
    return out


def _segments(t, miss, reason) -> list[dict]:
    segs = []
    k = 0
    while k < t.size:
        if not miss[k]:
            k += 1
            continue
        j = k
        while j + 1 < t.size and miss[j + 1] and reason[j + 1] == reason[k]:
            j += 1
        segs.append({"start": float(t[k]), "end": float(t[j]), "n_samples": int(j - k + 1), "reason": str(reason[k])})
        k = j + 1
    return segs
