r"""The collocation NLP of a :class:`~duffsym.identify.Problem`, built once and solved from many starts.

:class:`CollocationNLP` holds the transcription described in :mod:`duffsym.identify.collocation`
(decision variables, bounds, constraints, the IPOPT solver with its structured derivatives);
:meth:`CollocationNLP.solve` runs IPOPT from one parameter start and returns a :class:`Run`.
An IPOPT intermediate callback (:func:`_iteration_hook`) counts iterations, reports progress
through a ``progress`` callable and stops the solve when the user presses Ctrl-C
(:class:`FitInterrupted`, a :class:`KeyboardInterrupt`).
"""
from __future__ import annotations

import math
import signal
import threading
import time
from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

from duffsym.errors import ModelError

#: Seconds between two "iteration k" progress lines of one solve.
PROGRESS_EVERY = 2.0

#: IPOPT's Hessian regularisation (``lg(rg)`` in its log) at or above this marks an ill-conditioned
#: iteration: measured on 3000 Silverbox samples in mV and ms, iterations at 1e7-1e17 took 35-130 s each
#: (MUMPS reallocating its workspace), those below 1e4 0.3-0.5 s.
REGULARISATION_ALARM = 1e8

#: A bound restart stops (keeping the converged run it started from) when one of its iterations takes
#: longer than this many times the first run's median iteration (and over ``RESTART_SLOW_FLOOR`` s) ...
RESTART_SLOW_FACTOR = 20.0
RESTART_SLOW_FLOOR = 2.0
#: ... after this many iterations at or above :data:`REGULARISATION_ALARM` ...
RESTART_ALARM_ITERATIONS = 3
#: ... or when it has run this many times the first run's iterations (at least ``RESTART_MIN_ITER``).
RESTART_ITER_FACTOR = 3.0
RESTART_MIN_ITER = 50


class FitInterrupted(KeyboardInterrupt):
    """The user interrupted an IPOPT solve (Ctrl-C); nothing of the fit is returned."""


@dataclass(frozen=True)
class Run:
    """One IPOPT run: how it ended, its iterations, the scaled optimum and its scaled cost."""

    status: str
    success: bool
    n_iter: int
    w: np.ndarray
    cost: float
    message: str
    iterations: dict | None = None  # per-iteration summary (:meth:`IterationLog.summary`)
    stopped: str = ""  # why the hook stopped IPOPT ("time", "restart-guard: ..."), else ""


@dataclass(frozen=True)
class _Block:
    """Where one record's variables sit in the decision vector, and its data."""

    offset: int
    N: int
    S: np.ndarray
    p_offset: int
    nb: int
    U: np.ndarray
    X_init: np.ndarray


#: MUMPS' extra workspace, % of its estimate: IPOPT's default, stated here so that it is one setting. Not
#: raised: MUMPS ran out of it (INFO(1) = -9, raised 1000 -> 2000 -> 4000 -> 8000 %) only in iterations whose
#: Hessian regularisation had reached 1e11-1e17 (3000 Silverbox samples in mV and ms), which the bound
#: restart's guard and the time limit now bound; a larger start would only move the cost of those iterations.
MUMPS_MEM_PERCENT = 1000


def ipopt_settings(*, tol: float = 1e-10, acceptable_tol: float = 1e-7, max_iter: int = 500, print_level: int = 0,
                   linear_solver: str = "mumps", ipopt_options: Mapping[str, object] | None = None) -> dict:
    """IPOPT/CasADi options of a fit (the defaults are :func:`~duffsym.identify.fit`'s); ``ipopt_options``
    are added with the ``ipopt.`` prefix."""
    opts = {
        "ipopt.tol": float(tol), "ipopt.acceptable_tol": float(acceptable_tol), "ipopt.max_iter": int(max_iter),
        "ipopt.print_level": int(print_level), "print_time": False, "ipopt.sb": "yes",
        "ipopt.linear_solver": linear_solver, "error_on_fail": False,
        "ipopt.mumps_mem_percent": MUMPS_MEM_PERCENT,
    }
    for k, v in (ipopt_options or {}).items():
        opts[k if k.startswith("ipopt.") else f"ipopt.{k}"] = v
    return opts


class CollocationNLP:
    """The transcribed least-squares problem of ``problem`` with IPOPT, built once.

    Parameters
    ----------
    problem : the :class:`~duffsym.identify.Problem`.
    start : start value of every parameter slot (``problem.slot_names``), inside its bounds; it
        scales the states (their data-based guess depends on the parameters) and is the first start.
    degree, derivatives, expand, param_stride : see :func:`~duffsym.identify.fit`.
    solver_options : the IPOPT/CasADi options (default :func:`ipopt_settings`).

    Attributes
    ----------
    th0, lo, hi : the start and the bounds of the parameter slots, scaled by ``p_scale``.
    y_norm : RMS of the measured outputs (the objective is scaled by it).
    constraints : the linear parameter constraints as stated (for the result).
    """

    def __init__(self, problem, start: Mapping[str, float], *, degree: int = 3, derivatives: str = "structured",
                 expand: bool = False, param_stride: int = 8, solver_options: Mapping[str, object] | None = None):
        import casadi as ca

        from duffsym.codegen.casadi_fn import casadi_functions
        from duffsym.identify.collocation import collocation_coefficients

        self.problem = problem
        model = problem.model
        self.model = model
        self.free = problem.free
        self.slot_names = problem.slot_names
        self.n_slots = len(problem.slots)
        self.stride = int(param_stride)
        if self.stride < 1:
            raise ModelError(f"param_stride must be a positive integer; got {param_stride}")
        self.degree = int(degree)
        self.rhs_fn, self.out_fn = casadi_functions(model)
        self.p_scale_free = np.array([model.param(n).typical_scale for n in self.free])
        self.p_scale = np.array([model.param(n).typical_scale for n, _ in problem.slots])
        self.tau, C, D = collocation_coefficients(degree, "legendre")
        self.interval, self.out_scaled = self._interval_functions(ca, C, D)
        self.lo = np.array([problem.bounds[n][0] for n, _ in problem.slots]) / self.p_scale
        self.hi = np.array([problem.bounds[n][1] for n, _ in problem.slots]) / self.p_scale
        self.th0 = np.array([start[sn] for sn in self.slot_names]) / self.p_scale
        y_all = np.concatenate([np.asarray(r.y) for r in problem.records])
        self.y_norm = float(np.sqrt(np.mean(y_all**2))) or 1.0
        self._transcribe(ca, start)
        self._linear_constraints()
        self.solver = self._solver(ca, derivatives, expand, dict(solver_options or ipopt_settings()))

    # ------------------------------------------------------------------ building
    def _interval_functions(self, ca, C, D):
        """One interval as a CasADi function of scaled states (mapped over all intervals of a record)."""
        model, K, tau = self.model, self.degree, self.tau
        nx, nu = model.n_states, model.n_inputs
        xk, xc = ca.SX.sym("xk", nx), ca.SX.sym("xc", nx, K)
        uk, uk1, hk = ca.SX.sym("uk", nu), ca.SX.sym("uk1", nu), ca.SX.sym("h")
        ps = ca.SX.sym("p", model.n_params)
        sx = ca.SX.sym("sx", nx)  # state scale
        pts = [xk] + [xc[:, j] for j in range(K)]
        res = []
        for j in range(1, K + 1):
            xdot_h = sum(C[r, j] * pts[r] for r in range(K + 1))
            u_j = (1 - tau[j]) * uk + tau[j] * uk1
            f_j = self.rhs_fn(pts[j] * sx, u_j, ps)
            res.append(xdot_h - hk * f_j / sx)
        x_end = sum(D[r] * pts[r] for r in range(K + 1))
        interval = ca.Function("interval", [xk, xc, uk, uk1, hk, ps, sx], [ca.vertcat(*res), x_end])
        xo, uo = ca.SX.sym("x", nx), ca.SX.sym("u", nu)
        out_scaled = ca.Function("out", [xo, uo, ps, sx], [self.out_fn(xo * sx, uo, ps)])
        return interval, out_scaled

    def _transcribe(self, ca, start) -> None:
        """Decision variables, bounds, start vector, dynamics constraints and objective of every record."""
        problem, model, K, stride = self.problem, self.model, self.degree, self.stride
        nx, n_free, n_slots = model.n_states, len(self.free), self.n_slots
        n_w = n_slots + sum(nx * r.n_times + nx * K * (r.n_times - 1) + n_free * -(-r.n_times // stride)
                            for r in problem.records)
        self.wsym = wsym = ca.MX.sym("w", n_w)
        self.theta = wsym[:n_slots]
        lbw, ubw, w0 = list(self.lo), list(self.hi), list(self.th0)
        self.g_parts, self.obj = [], 0
        self.layout, self.blocks = [], []
        offset, n_g = n_slots, 0
        for i, rec in enumerate(problem.records):
            blk, spec, parts, w0_i = self._record(ca, i, rec, start, offset, n_g)
            self.g_parts += parts
            w0 += w0_i
            n_var = blk.p_offset - offset
            lbw += [-np.inf] * (n_var + n_free * blk.nb)
            ubw += [np.inf] * (n_var + n_free * blk.nb)
            for j, (lo, hi) in spec.pop("driven_range").items():  # input-driven states stay in their range
                for k in range(blk.N):
                    lbw[offset + k * nx + j], ubw[offset + k * nx + j] = lo / blk.S[j], hi / blk.S[j]
            self.layout.append(blk)
            self.blocks.append(spec)
            n_g += (nx * K + nx) * (blk.N - 1) + n_free * blk.nb
            offset += n_var + n_free * blk.nb
        self.n_g = n_g
        self.w0, self.lbw, self.ubw = np.asarray(w0, dtype=float), np.asarray(lbw), np.asarray(ubw)

    def _record(self, ca, i, rec, start, offset, n_g):
        """One record's block: its variables, collocation and chain constraints, objective and start values."""
        from duffsym.identify.collocation import _input_matrix, driven_states, initial_states

        problem, model, K, tau, stride = self.problem, self.model, self.degree, self.tau, self.stride
        nx, n_free, free = model.n_states, len(self.free), self.free
        wsym, th0 = self.wsym, self.th0
        N = rec.n_times
        U = _input_matrix(model, rec)
        sidx = problem.slot_index(i)
        p_start = np.array([problem.record_params(i, start)[n] for n in model.param_names])
        X_init = initial_states(model, rec, p_start)
        driven = {}
        for j, traj in driven_states(model, rec, p_start).items():
            # a first-order lag stays within the range of what drives it (the command's range for the field)
            lo, hi = float(np.min(traj)), float(np.max(traj))
            pad = 0.02 * (hi - lo) + 1e-6 * max(1.0, abs(lo), abs(hi))
            driven[j] = (lo - pad, hi + pad)
        S = np.maximum(np.max(np.abs(X_init), axis=0), 1e-3 * max(1.0, float(np.max(np.abs(X_init)))))
        S = np.where(np.isfinite(S) & (S > 0), S, 1.0)
        n_var = nx * N + nx * K * (N - 1)
        Xs = ca.reshape(wsym[offset: offset + nx * N], nx, N)
        Xc = ca.reshape(wsym[offset + nx * N: offset + n_var], nx, K * (N - 1))
        # One copy of the free parameters per `stride` samples, chained to theta by linear
        # constraints: every interval then depends on nearby variables only, so the Hessian has no
        # dense rows (shared parameters made CasADi's build quadratic and slowed MUMPS) and the chain
        # p_0 = theta, p_b+1 = p_b keeps the KKT matrix banded for the sparse factorization. A copy
        # per 8 samples instead of per sample: ~30 % less CPU at 12 800 samples (measured 1, 4, 8,
        # 16, 64: 5.8-6.2, 4.1-4.2, 3.8-4.4, 3.9-5.1, 4.2-5.1 s; no copies at all: ~40 % more than 1).
        nb = -(-N // stride)
        Pl = ca.reshape(wsym[offset + n_var: offset + n_var + n_free * nb], n_free, nb)
        copy_of = (np.arange(N) // stride).tolist()
        rows = []
        for n in model.param_names:
            if n in free:
                j = free.index(n)
                rows.append((Pl[j, :] if stride == 1 else Pl[j, copy_of]) * self.p_scale_free[j])
            else:
                rows.append(ca.DM.ones(1, N) * problem.fixed_value(i, n))
        P_all = ca.vertcat(*rows)
        h = np.diff(np.asarray(rec.t))
        coll, xend = self.interval.map(N - 1)(Xs[:, :-1], Xc, U[:-1].T, U[1:].T, h[None, :], P_all[:, :-1], S)
        parts = [ca.vec(coll), ca.vec(xend - Xs[:, 1:]), Pl[:, 0] - self.theta[sidx], ca.vec(Pl[:, 1:] - Pl[:, :-1])]
        y_hat = self.out_scaled.map(N)(Xs, U.T, P_all, S)
        wts = problem.sample_weights(i)
        r = (y_hat - np.asarray(rec.y)[None, :]) / self.y_norm
        self.obj = self.obj + 0.5 * ca.sum2(r**2 * wts[None, :])
        # initial values: sample states from the data, collocation states interpolated linearly
        Xs0 = X_init / S  # (N, nx); ca.vec(Xs) is column-major, i.e. sample by sample = Xs0 row-major
        Xc0 = np.empty((nx, K * (N - 1)))
        for j in range(K):
            Xc0[:, j::K] = ((1 - tau[j + 1]) * Xs0[:-1] + tau[j + 1] * Xs0[1:]).T
        w0 = list(Xs0.reshape(-1)) + list(Xc0.flatten(order="F"))
        w0 += list(np.tile(th0[sidx] * self.p_scale[sidx] / self.p_scale_free, nb))
        pf = np.array([0.0 if n in free else problem.fixed_value(i, n) for n in model.param_names])
        spec = dict(offset=offset, N=N, U=U, h=h, S=S, pf=pf, sidx=sidx, y=np.asarray(rec.y, dtype=float),
                    wts=wts, g_offset=n_g, driven_range=driven)
        return _Block(offset, N, S, offset + n_var, nb, U, X_init), spec, parts, w0

    def _linear_constraints(self) -> None:
        """``Problem.constraints``: one row per distinct set of slots, after the dynamics."""
        problem, free, slot_names = self.problem, self.free, self.slot_names
        con_r, con_c, con_v, lbg, ubg = [], [], [], np.zeros(self.n_g), np.zeros(self.n_g)
        con_info = []
        for coeffs, lo, hi in problem.constraints:
            seen = set()
            for i in range(len(problem.records)):
                sidx = problem.slot_index(i)
                key = tuple(sidx[free.index(n)] for n in coeffs)
                if key in seen:
                    continue
                seen.add(key)
                row = self.n_g + len(con_info)
                vals = [coeffs[n] * self.p_scale[j] for n, j in zip(coeffs, key)]
                self.g_parts.append(sum(v * self.theta[j] for v, j in zip(vals, key)))
                con_r += [row] * len(key)
                con_c += list(key)
                con_v += vals
                lbg, ubg = np.append(lbg, lo), np.append(ubg, hi)
                con_info.append({"coefficients": {slot_names[j]: coeffs[n] for n, j in zip(coeffs, key)},
                                 "lower": lo, "upper": hi})
        self.lbg, self.ubg, self.constraints = lbg, ubg, con_info
        self._extra = (con_r, con_c, con_v)

    def _solver(self, ca, derivatives, expand, opts):
        from duffsym.identify.collocation import _structured_derivatives

        g = ca.vertcat(*self.g_parts)
        opts = {**opts, "expand": bool(expand)}
        if derivatives == "structured":
            jac_g, hess_lag = _structured_derivatives(
                self.wsym, g, self.blocks, self.interval, self.out_fn, self.model, self.free, self.p_scale_free,
                theta_size=self.n_slots, n_g=self.n_g, K=self.degree, y_norm=self.y_norm, stride=self.stride,
                extra=self._extra, n_g_total=self.lbg.size)
            opts.update({"jac_g": jac_g, "hess_lag": hess_lag, "expand": False})
        self._hook = _iteration_hook()
        opts["iteration_callback"] = self._hook
        return ca.nlpsol("duffsym_fit", "ipopt", {"x": self.wsym, "f": self.obj, "g": g}, opts)

    # ------------------------------------------------------------------ solving
    def with_params(self, th: np.ndarray) -> np.ndarray:
        """The start vector with the parameter slots (and their per-stride copies) set to ``th``."""
        w = self.w0.copy()
        w[:self.n_slots] = th
        for i, blk in enumerate(self.layout):
            sidx = self.problem.slot_index(i)
            w[blk.p_offset: blk.p_offset + len(self.free) * blk.nb] = np.tile(
                th[sidx] * self.p_scale[sidx] / self.p_scale_free, blk.nb)
        return w

    def solve(self, th: np.ndarray, *, max_iter: int, progress: Callable[[str], None] | None = None,
              label: str = "", deadline: float | None = None, guard: Callable[["IterationLog"], str] | None = None,
              w_start: np.ndarray | None = None) -> Run:
        """One IPOPT run from the scaled parameters ``th`` (states from the data, or ``w_start``); never
        raises for solver failure. Ctrl-C during the run stops IPOPT and raises :class:`FitInterrupted`.

        ``deadline`` (a :func:`time.perf_counter` value) stops IPOPT at the first iteration after it
        (``Run.stopped == "time"``); ``guard`` is asked after every iteration and stops the run when it
        returns a reason (``Run.stopped`` is that reason). ``Run.iterations`` summarises the iteration times
        and IPOPT's Hessian regularisation (:class:`IterationLog`)."""
        if w_start is None:
            w_start = self.with_params(th)
        self._hook.solver = self.solver
        with self._hook.watching(progress, label, deadline=deadline, guard=guard):
            try:
                sol = self.solver(x0=w_start, lbx=self.lbw, ubx=self.ubw, lbg=self.lbg, ubg=self.ubg)
            except RuntimeError as exc:  # CasADi raises on evaluation errors it cannot recover from
                self._hook.raise_if_interrupted()
                return Run("error", False, 0, w_start, math.inf, f"IPOPT stopped with an error: {exc}",
                           self._hook.log.summary(), self._hook.stop_reason)
            self._hook.raise_if_interrupted()
        stats = self.solver.stats()
        status = str(stats.get("return_status", "unknown"))
        success = bool(stats.get("success", False))
        cost = float(sol["f"])
        from duffsym.identify.collocation import _status_message

        log = self._hook.log
        log.finish(stats)
        return Run(status, success, int(stats.get("iter_count", 0)), np.asarray(sol["x"]).reshape(-1),
                   cost if math.isfinite(cost) else math.inf, _status_message(status, success, max_iter),
                   log.summary(), self._hook.stop_reason)

    def unscale(self, w: np.ndarray) -> tuple[dict[str, float], list[tuple[float, ...]]]:
        """Slot values by name (clipped into the bounds) and each record's initial state, from a solution."""
        w = w.copy()
        # IPOPT relaxes bounds by ~1e-8 relative: a parameter on its bound can come back just outside
        # it, which a prior or a later Problem would reject
        w[:self.n_slots] = np.clip(w[:self.n_slots], self.lo, self.hi)
        slot_values = dict(zip(self.slot_names, map(float, w[:self.n_slots] * self.p_scale)))
        nx = self.model.n_states
        x0s = [tuple(float(v) for v in w[b.offset: b.offset + nx] * b.S) for b in self.layout]
        return slot_values, x0s


def _make_hook_class():
    """The CasADi callback class (built on first use: importing casadi costs ~0.3 s)."""
    import casadi as ca

    class Hook(ca.Callback):
        """IPOPT's intermediate callback: count, report, and stop on request (return 1)."""

        def __init__(self):
            ca.Callback.__init__(self)
            self.progress, self.label = None, ""
            self.iterations, self.t0, self.last = 0, 0.0, 0.0
            self.interrupted = False
            self.solver, self.deadline, self.guard, self.stop_reason = None, None, None, ""
            self.log = IterationLog(0.0)
            self.construct("duffsym_fit_progress", {})

        def get_n_in(self):
            return ca.nlpsol_n_out()

        def get_n_out(self):
            return 1

        def get_name_in(self, i):
            return ca.nlpsol_out(i)

        def get_name_out(self, i):
            return "ret"

        def get_sparsity_in(self, i):
            # only the cost is taken: declaring the iterate, constraints and multipliers empty keeps
            # IPOPT's vectors (millions of values on long records) from being copied at every iteration
            return ca.Sparsity.scalar() if ca.nlpsol_out(i) == "f" else ca.Sparsity(0, 0)

        def eval(self, arg):
            self.iterations += 1
            now = time.perf_counter()
            self.log.add(now, self.solver)
            if self.progress is not None and now - self.last >= PROGRESS_EVERY:
                self.last = now
                self.progress(f"solving{self.label}: iteration {self.iterations}, {now - self.t0:.1f} s"
                              + self.log.progress_note())
            if self.interrupted:
                return [1]
            if self.deadline is not None and now >= self.deadline:
                self.stop_reason = "time"
                return [1]
            reason = self.guard(self.log) if self.guard is not None else ""
            if reason:
                self.stop_reason = reason
                return [1]
            return [0]

        def watching(self, progress, label, deadline=None, guard=None):
            return _Watch(self, progress, label, deadline, guard)

        def raise_if_interrupted(self):
            if self.interrupted:
                raise FitInterrupted(f"interrupted after {self.iterations} IPOPT iterations")

    return Hook


class IterationLog:
    """Per-iteration record of one IPOPT run: wall time of each iteration and IPOPT's Hessian
    regularisation (read live from the solver's statistics, ``regularization_size``)."""

    def __init__(self, t0: float):
        self.t_prev = t0
        self.times: list[float] = []
        self.reg: list[float] = []
        self.inf_pr: list[float] = []
        self.obj: list[float] = []
        self.restoration = False

    def add(self, now: float, solver) -> None:
        self.times.append(now - self.t_prev)
        self.t_prev = now
        it = {}
        if solver is not None:
            try:
                it = solver.stats().get("iterations", {})
            except RuntimeError:  # no statistics yet
                it = {}
        for key, out in (("regularization_size", self.reg), ("inf_pr", self.inf_pr), ("obj", self.obj)):
            vals = it.get(key) or [math.nan]
            out.append(float(vals[-1]))

    def finish(self, stats: Mapping) -> None:
        status = str(stats.get("return_status", ""))
        self.restoration = self.restoration or "Restoration" in status

    @property
    def alarms(self) -> int:
        """Iterations whose Hessian regularisation reached :data:`REGULARISATION_ALARM`."""
        return int(sum(r >= REGULARISATION_ALARM for r in self.reg if math.isfinite(r)))

    def progress_note(self) -> str:
        if not self.times:
            return ""
        note = f" (last iteration {self.times[-1]:.2g} s"
        reg = self.reg[-1] if self.reg else math.nan
        if math.isfinite(reg) and reg >= REGULARISATION_ALARM:
            note += f"; Hessian regularisation {reg:.1e}: the problem is ill-conditioned here"
        return note + ")"

    def summary(self) -> dict:
        """Over IPOPT's callbacks (its iteration 0, the start, included): ``{"n", "seconds_total", "seconds_median", "seconds_max", "slowest", "regularisation_max",
        "ill_conditioned"}`` (for ``settings["iterations"]`` of a fit)."""
        t = np.asarray(self.times, dtype=float)
        reg = np.asarray([r for r in self.reg if math.isfinite(r)], dtype=float)
        return {"n": int(t.size), "seconds_total": float(t.sum()),
                "seconds_median": float(np.median(t)) if t.size else 0.0,
                "seconds_max": float(t.max()) if t.size else 0.0,
                "slowest": int(np.argmax(t)) + 1 if t.size else 0,
                "regularisation_max": float(reg.max()) if reg.size else 0.0,
                "ill_conditioned": self.alarms, "restoration_failed": bool(self.restoration)}


def restart_guard(first: Run, *, max_iter: int) -> Callable[[IterationLog], str]:
    """The stop rule of a bound restart: it may not cost more than the converged run it started from is
    worth keeping. Stops when an iteration takes ``RESTART_SLOW_FACTOR`` times the first run's median
    iteration (and over ``RESTART_SLOW_FLOOR`` s), after ``RESTART_ALARM_ITERATIONS`` iterations with the
    Hessian regularisation at :data:`REGULARISATION_ALARM` or more, or after ``RESTART_ITER_FACTOR`` times
    the first run's iterations (at least ``RESTART_MIN_ITER``) without having converged."""
    info = first.iterations or {}
    slow = max(RESTART_SLOW_FLOOR, RESTART_SLOW_FACTOR * float(info.get("seconds_median", 0.0)))
    cap = min(int(max_iter), max(RESTART_MIN_ITER, int(RESTART_ITER_FACTOR * max(first.n_iter, 1))))

    def guard(log: IterationLog) -> str:
        if log.times and log.times[-1] > slow:
            return f"an iteration took {log.times[-1]:.1f} s (the first run's median {info.get('seconds_median', 0):.2g} s)"
        if log.alarms >= RESTART_ALARM_ITERATIONS:
            return (f"{log.alarms} iterations with IPOPT's Hessian regularisation >= {REGULARISATION_ALARM:.0e} "
                    "(ill-conditioned)")
        if len(log.times) >= cap:
            return f"{len(log.times)} iterations without converging (the first run needed {first.n_iter})"
        return ""

    return guard


class _Watch:
    """Context of one solve: progress set up, and SIGINT turned into a stop request (main thread only)."""

    def __init__(self, hook, progress, label, deadline=None, guard=None):
        self.hook, self.progress, self.label = hook, progress, label
        self.deadline, self.guard = deadline, guard
        self.previous = None

    def __enter__(self):
        h = self.hook
        h.progress, h.label = self.progress, f" ({self.label})" if self.label else ""
        h.iterations, h.interrupted = 0, False
        h.deadline, h.guard, h.stop_reason = self.deadline, self.guard, ""
        h.t0 = h.last = time.perf_counter()
        h.log = IterationLog(h.t0)
        if threading.current_thread() is threading.main_thread():
            self.previous = signal.signal(signal.SIGINT, self._on_sigint)
        return self

    def _on_sigint(self, signum, frame):
        self.hook.interrupted = True  # IPOPT stops at its next iteration (the callback returns 1)

    def __exit__(self, *exc):
        if self.previous is not None:
            signal.signal(signal.SIGINT, self.previous)
        return False


_HOOK_CLASS = None


def _iteration_hook():
    """A new IPOPT intermediate callback (:func:`_make_hook_class`)."""
    global _HOOK_CLASS
    if _HOOK_CLASS is None:
        _HOOK_CLASS = _make_hook_class()
    return _HOOK_CLASS()
