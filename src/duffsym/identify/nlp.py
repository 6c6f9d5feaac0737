r"""The collocation NLP of a :class:`~duffsym.identify.Problem`, built once and solved from many starts.

:class:`CollocationNLP` holds the transcription described in :mod:`duffsym.identify.collocation`
(decision variables, bounds, constraints, the IPOPT solver with its structured derivatives);
:meth:`CollocationNLP.solve` runs IPOPT from one parameter start and returns a :class:`Run`. Each record
is one :class:`RecordBlock` (where its variables and constraints sit, and its data); the states start
from the data (:mod:`duffsym.identify.states`). The structured derivatives (the default) assemble the
constraint Jacobian and the Lagrangian's Hessian from one interval's, generated once
(:func:`_structured_derivatives`); :func:`collocation_coefficients` gives the collocation polynomial.
An IPOPT intermediate callback (:func:`_iteration_hook`) counts iterations, reports progress
through a ``progress`` callable and stops the solve when the user presses Ctrl-C
(:class:`FitInterrupted`, a :class:`KeyboardInterrupt`).
"""

from __future__ import annotations

import math
import os
import signal
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from duffsym.errors import ModelError
from duffsym.identify.problem import parameter_scales
from duffsym.identify.states import driven_states, initial_states
from duffsym.status import Status

#: Seconds between two "iteration k" progress lines of one solve.
PROGRESS_EVERY = 2.0

#: IPOPT's Hessian regularisation (``lg(rg)`` in its log) at or above this marks an ill-conditioned
#: iteration: measured on 3000 Silverbox samples in mV and ms, iterations at 1e7-1e17 took two orders of
#: magnitude longer than those below 1e4 (MUMPS reallocating its workspace; benchmarks/bench_ipopt_iterations.py).
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

#: A run has stalled on a ridge when, for ``RIDGE_WINDOW`` iterations at IPOPT's final barrier parameter
#: (mu <= ``RIDGE_MU``) and with the collocation constraints met (inf_pr <= ``RIDGE_INF_PR``), its cost fell by
#: less than ``RIDGE_GAIN`` (relative) while a parameter still moved by more than ``RIDGE_MOVE`` (relative):
#: measured on the 25-test UTFSM campaign (7577 samples), IPOPT crawled from iteration ~70 to its limit of 500
#: with full Newton steps, c3 and A_f_u growing together along a near-symmetry, the cost falling ~1 % per 50
#: iterations (37.3 -> 36.0 over 180 iterations). A converged run spends a few iterations at the final mu.
RIDGE_WINDOW = 50
RIDGE_GAIN = 0.01
RIDGE_MU = 1e-6
RIDGE_INF_PR = 1e-4
RIDGE_MOVE = 0.01
#: ... a move counted relative to the parameter's own size, or to this fraction of its typical scale when it is
#: smaller (a parameter near 0 only wobbles). Relative to the full typical scale, the Dyke record's final ladder
#: fit (1503 samples, mr-damper-current from the fitting part's optimum) crawled 500 iterations at mu 1e-11, the
#: cost falling 0.007 % per 50, unseen: k2 (typical 500) moved -12.05 -> -9.56, which counted as 0.5 %.
RIDGE_FLOOR = 0.1
#: A run has diverged when IPOPT's primal infeasibility (the largest collocation defect, in the NLP's scaled units,
#: where states are of order one) exceeds ``DIVERGED_INF_PR`` and ``DIVERGED_GROWTH`` times the lowest it had in the
#: run. Measured on 6 s of the Dyke command record at 500 Hz (``duffsym fit --model mr-damper-current``, 3005
#: samples): from iteration 40 the infeasibility sat at ~2e2 with steps of 1e-4, then a watchdog step took it to
#: 1.1e11 (dual infeasibility 3e15); the next iteration's Hessian regularisation reached 1.6e13, MUMPS ran out of
#: workspace, and one iteration ran past 4 minutes (the fit had not ended after 5). Converging runs in the tests and
#: benchmarks peak below 1e4 (e.g. 3.2e3 from 17 on the Dyke input-delay candidate, which then came back).
DIVERGED_INF_PR = 1e8
DIVERGED_GROWTH = 1e6
#: A run has stalled when ``STALL_ITERATIONS`` of its iterations each took over ``STALL_FACTOR`` times the median of
#: the run's iterations before it (and over ``STALL_FLOOR`` s) with IPOPT's Hessian regularisation at
#: :data:`REGULARISATION_ALARM` or more: each such iteration factorises the KKT system many times over while MUMPS
#: reallocates its workspace. Measured on the same Dyke fit's second start (``--starts 3``): iterations of
#: 0.3-0.8 s, then 6, 7, 19, 22, 26, 170 and 60 s (regularisation 1.2e8-8.3e8) without the iterate diverging; the
#: rule stops it at its 12th iteration (85 s) where it ran past 6 minutes.
STALL_ITERATIONS = 3
STALL_FACTOR = 10.0
STALL_FLOOR = 2.0
#: the reasons the divergence and stall rules give start with these (a fit from the automatic start stopped by either
#: is fitted again from the model's defaults, :func:`duffsym.identify.collocation.fit`)
HOPELESS_STOPS = ("diverged:", "stalled:")
#: what to do after either stop ended a fit (not a bound restart, which keeps its converged first run): on that Dyke
#: fit the third of three starts converged (NRMSE 0.197, 132 s in all)
OTHER_STARTS = "Try other starts (--starts 3) or fix parameters the record does not determine (--fix)"


class FitInterrupted(KeyboardInterrupt):
    """The user interrupted an IPOPT solve (Ctrl-C); nothing of the fit is returned."""


@dataclass(frozen=True)
class Run:
    """One IPOPT run: how it ended, its iterations, the scaled optimum and its scaled cost.

    ``status`` is IPOPT's return status as a :class:`~duffsym.status.Status` (a ``str`` with IPOPT's name as
    its value); a name the enumeration lacks (``"error"``: CasADi raised) stays the plain string."""

    status: Status | str
    success: bool
    n_iter: int
    w: np.ndarray
    cost: float
    message: str
    iterations: dict | None = None  # per-iteration summary (:meth:`IterationLog.summary`)
    stopped: str = ""  # why the hook stopped IPOPT ("time", "restart-guard: ..."), else ""


@dataclass(frozen=True)
class RecordBlock:
    """One record in the NLP: where its variables and constraints sit, and the data its intervals use.

    The decision vector holds, per record from ``offset``: its ``N`` sample states (scaled by ``S``), its
    collocation states, then ``nb`` copies of the free parameters from ``p_offset`` (one per
    ``param_stride`` samples). Its constraints start at row ``g_offset``.
    """

    offset: int  # first decision variable of the record (its first sample state)
    N: int  # samples
    S: np.ndarray  # (n_states,) state scale
    p_offset: int  # first of its parameter copies
    nb: int  # number of parameter copies
    U: np.ndarray  # (N, n_inputs) input matrix (Record.input_matrix)
    X_init: np.ndarray  # (N, n_states) data-based state guess (duffsym.identify.states)
    h: np.ndarray  # (N-1,) sample intervals
    pf: np.ndarray  # (n_params,) fixed values, 0 where free
    sidx: list  # the slots of the free parameters (Problem.slot_index)
    y: np.ndarray  # (N,) measured output
    wts: np.ndarray  # (N,) sample weights (0: masked)
    g_offset: int  # first constraint row of the record
    driven_range: dict = field(default_factory=dict)  # input-driven state -> (lower, upper) bounds


#: MUMPS' extra workspace, % of its estimate: IPOPT's default, stated here so that it is one setting. Not
#: raised: MUMPS ran out of it (INFO(1) = -9, raised 1000 -> 2000 -> 4000 -> 8000 %) only in iterations whose
#: Hessian regularisation had reached 1e11-1e17 (3000 Silverbox samples in mV and ms), which the bound
#: restart's guard and the time limit now bound; a larger start would only move the cost of those iterations.
MUMPS_MEM_PERCENT = 1000
#: IPOPT's initial barrier parameter (its default 0.1 assumes a start far from the answer and first pulls the iterate
#: toward the middle of the bounds). A fit here starts from the data (the equation-error start, the states on the
#: measured trajectory), and a smaller barrier keeps that start. Measured (``benchmarks/bench_ipopt_iterations.py``,
#: both codes in one run): 6 s of the Dyke command record at 500 Hz, default fit, 421 iterations and a failure after
#: 207 s (iterations up to 22 s) -> converged in 53 iterations, 25.5 s, none over 0.61 s, NRMSE 0.1973; one UTFSM sine
#: test 102 -> 74 iterations, same NRMSE; the shipped sine 11 -> 9; the Dyke ladder's base fit (1050 samples)
#: 245 -> 113 iterations, in-sample cost +0.08 %, held-out 0.2231 -> 0.2210. Slower: 3000 Silverbox samples with
#: ``duffing`` + input-shift, 82 -> 160 iterations (13.7 -> 30.7 s; 35.1 s in a second run), in a bound restart that
#: crawls until its guard stops it, a fit that reaches NRMSE 0.999 either way. See also the Dyke ladder in
#: ``benchmarks/README.md``: its discovered term is now needed, and the ladder takes a second step.
MU_INIT = 1e-3


#: whether CasADi's bundled OpenBLAS has been held to one thread (see :func:`one_blas_thread`)
_BLAS_HELD: list[bool] = []


def one_blas_thread(ca) -> None:
    """Hold the OpenBLAS that CasADi bundles for MUMPS (loaded with the IPOPT plugin) to one thread, once per
    process. Its second thread spins while it waits: on 6 s of the Dyke record (1050 samples, 2 cores) it spent
    37 s of kernel time beside 35 s of work with the same wall time (36.6 s against 36.4 s with one thread), so it
    only took a core from the other processes (the candidates of a diagnosis on ``--workers``). threadpoolctl does
    not see this library (it is named ``libcasadi-tp-openblas``); the environment's ``OPENBLAS_NUM_THREADS``, when
    set, is left to rule. Without the library (another CasADi build) nothing is done."""
    if _BLAS_HELD or "OPENBLAS_NUM_THREADS" in os.environ:
        return
    _BLAS_HELD.append(True)
    import ctypes

    # the copies the plugin loaded (the folder holds the library under three file names, each its own copy)
    mode = getattr(os, "RTLD_NOLOAD", 0) | getattr(os, "RTLD_LAZY", 0)
    for path in sorted(Path(ca.__file__).parent.glob("libcasadi-tp-openblas*")):
        try:
            ctypes.CDLL(str(path), mode=mode).openblas_set_num_threads(1)
        except (OSError, AttributeError):
            continue


def ipopt_settings(
    *,
    tol: float = 1e-10,
    acceptable_tol: float = 1e-7,
    max_iter: int = 500,
    print_level: int = 0,
    linear_solver: str = "mumps",
    ipopt_options: Mapping[str, object] | None = None,
) -> dict:
    """IPOPT/CasADi options of a fit (the defaults are :func:`~duffsym.identify.fit`'s); ``ipopt_options``
    are added with the ``ipopt.`` prefix."""
    opts = {
        "ipopt.tol": float(tol),
        "ipopt.acceptable_tol": float(acceptable_tol),
        "ipopt.max_iter": int(max_iter),
        "ipopt.print_level": int(print_level),
        "print_time": False,
        "ipopt.sb": "yes",
        "ipopt.linear_solver": linear_solver,
        "error_on_fail": False,
        "ipopt.mumps_mem_percent": MUMPS_MEM_PERCENT,
        "ipopt.mu_init": MU_INIT,
    }
    for k, v in (ipopt_options or {}).items():
        opts[k if k.startswith("ipopt.") else f"ipopt.{k}"] = v
    return opts


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

    def __init__(
        self,
        problem,
        start: Mapping[str, float],
        *,
        degree: int = 3,
        derivatives: str = "structured",
        expand: bool = False,
        param_stride: int = 8,
        solver_options: Mapping[str, object] | None = None,
    ):
        import casadi as ca

        from duffsym.codegen.casadi_fn import casadi_functions

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
        scales = parameter_scales(model, problem.records)
        self.p_scale_free = np.array([scales[n] for n in self.free])
        self.p_scale = np.array([scales[n] for n, _ in problem.slots])
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
        n_w = n_slots + sum(
            nx * r.n_times + nx * K * (r.n_times - 1) + n_free * -(-r.n_times // stride) for r in problem.records
        )
        self.wsym = wsym = ca.MX.sym("w", n_w)
        self.theta = wsym[:n_slots]
        lbw, ubw, w0 = list(self.lo), list(self.hi), list(self.th0)
        self.g_parts, self.obj = [], 0
        self.blocks: list[RecordBlock] = []
        offset, n_g = n_slots, 0
        for i, rec in enumerate(problem.records):
            blk, parts, w0_i = self._record(ca, i, rec, start, offset, n_g)
            self.g_parts += parts
            w0 += w0_i
            n_var = blk.p_offset - offset
            lbw += [-np.inf] * (n_var + n_free * blk.nb)
            ubw += [np.inf] * (n_var + n_free * blk.nb)
            for j, (lo, hi) in blk.driven_range.items():  # input-driven states stay in their range
                for k in range(blk.N):
                    lbw[offset + k * nx + j], ubw[offset + k * nx + j] = lo / blk.S[j], hi / blk.S[j]
            self.blocks.append(blk)
            n_g += (nx * K + nx) * (blk.N - 1) + n_free * blk.nb
            offset += n_var + n_free * blk.nb
        self.n_g = n_g
        self.w0, self.lbw, self.ubw = np.asarray(w0, dtype=float), np.asarray(lbw), np.asarray(ubw)

    def _record(self, ca, i, rec, start, offset, n_g):
        """One record's block: its variables, collocation and chain constraints, objective and start values."""
        problem, model, K, tau, stride = self.problem, self.model, self.degree, self.tau, self.stride
        nx, n_free, free = model.n_states, len(self.free), self.free
        wsym, th0 = self.wsym, self.th0
        N = rec.n_times
        U = rec.input_matrix(model)
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
        Xs = ca.reshape(wsym[offset : offset + nx * N], nx, N)
        Xc = ca.reshape(wsym[offset + nx * N : offset + n_var], nx, K * (N - 1))
        # One copy of the free parameters per `stride` samples, chained to theta by linear
        # constraints: every interval then depends on nearby variables only, so the Hessian has no
        # dense rows (shared parameters made CasADi's build quadratic and slowed MUMPS) and the chain
        # p_0 = theta, p_b+1 = p_b keeps the KKT matrix banded for the sparse factorization. A copy
        # per 8 samples instead of per sample: ~30 % less CPU at 12 800 samples (strides 4 to 64 within
        # each other's spread; no copies at all: ~40 % more than a copy per sample).
        nb = -(-N // stride)
        Pl = ca.reshape(wsym[offset + n_var : offset + n_var + n_free * nb], n_free, nb)
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
        blk = RecordBlock(
            offset=offset,
            N=N,
            S=S,
            p_offset=offset + n_var,
            nb=nb,
            U=U,
            X_init=X_init,
            h=h,
            pf=pf,
            sidx=sidx,
            y=np.asarray(rec.y, dtype=float),
            wts=wts,
            g_offset=n_g,
            driven_range=driven,
        )
        return blk, parts, w0

    def _linear_constraints(self) -> None:
        """``Problem.constraints``: one row per distinct set of slots, after the dynamics."""
        problem, free, slot_names = self.problem, self.free, self.slot_names
        con_r, con_c, con_v, lbg, ubg = [], [], [], np.zeros(self.n_g), np.zeros(self.n_g)
        con_info: list[dict[str, Any]] = []
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
                con_info.append(
                    {"coefficients": {slot_names[j]: coeffs[n] for n, j in zip(coeffs, key)}, "lower": lo, "upper": hi}
                )
        self.lbg, self.ubg, self.constraints = lbg, ubg, con_info
        self.linear_rows = (con_r, con_c, con_v)  # the Jacobian's constant rows of the constraints

    def _solver(self, ca, derivatives, expand, opts):
        g = ca.vertcat(*self.g_parts)
        opts = {**opts, "expand": bool(expand)}
        if derivatives == "structured":
            jac_g, hess_lag = _structured_derivatives(self, g)
            opts.update({"jac_g": jac_g, "hess_lag": hess_lag, "expand": False})
        self._hook = _iteration_hook(self.wsym.numel(), self.n_slots)
        opts["iteration_callback"] = self._hook
        solver = ca.nlpsol("duffsym_fit", "ipopt", {"x": self.wsym, "f": self.obj, "g": g}, opts)
        one_blas_thread(ca)
        return solver

    # ------------------------------------------------------------------ solving
    def with_params(self, th: np.ndarray) -> np.ndarray:
        """The start vector with the parameter slots (and their per-stride copies) set to ``th``."""
        w = self.w0.copy()
        w[: self.n_slots] = th
        for i, blk in enumerate(self.blocks):
            sidx = self.problem.slot_index(i)
            w[blk.p_offset : blk.p_offset + len(self.free) * blk.nb] = np.tile(
                th[sidx] * self.p_scale[sidx] / self.p_scale_free, blk.nb
            )
        return w

    def solve(
        self,
        th: np.ndarray,
        *,
        max_iter: int,
        progress: Callable[[str], None] | None = None,
        label: str = "",
        deadline: float | None = None,
        guard: Callable[[IterationLog], str] | None = None,
        w_start: np.ndarray | None = None,
    ) -> Run:
        """One IPOPT run from the scaled parameters ``th`` (states from the data, or ``w_start``); never
        raises for solver failure. Ctrl-C during the run stops IPOPT and raises :class:`FitInterrupted`.

        ``deadline`` (a :func:`time.perf_counter` value) stops IPOPT at the first iteration after it
        (``Run.stopped == "time"``); ``guard`` is asked after every iteration and stops the run when it
        returns a reason (``Run.stopped`` is that reason). ``Run.iterations`` summarises the iteration times
        and IPOPT's Hessian regularisation (:class:`IterationLog`)."""
        if w_start is None:
            w_start = self.with_params(th)
        self._hook.solver = self.solver
        with self._hook.watching(progress, label, deadline=deadline, guard=self._with_ridge(guard)):
            try:
                sol = self.solver(x0=w_start, lbx=self.lbw, ubx=self.ubw, lbg=self.lbg, ubg=self.ubg)
            except RuntimeError as exc:  # CasADi raises on evaluation errors it cannot recover from
                self._hook.raise_if_interrupted()
                return Run(
                    "error",
                    False,
                    0,
                    w_start,
                    math.inf,
                    f"IPOPT stopped with an error: {exc}",
                    self._hook.log.summary(),
                    self._hook.stop_reason,
                )
            self._hook.raise_if_interrupted()
        stats = self.solver.stats()
        status = ipopt_status(stats.get("return_status", "unknown"))
        success = bool(stats.get("success", False))
        cost = float(sol["f"])
        log = self._hook.log
        log.finish(stats)
        return Run(
            status,
            success,
            int(stats.get("iter_count", 0)),
            np.asarray(sol["x"]).reshape(-1),
            cost if math.isfinite(cost) else math.inf,
            _status_message(status, success, max_iter),
            log.summary(),
            self._hook.stop_reason,
        )

    def _with_ridge(self, guard: Callable[[IterationLog], str] | None) -> Callable[[IterationLog], str]:
        """``guard``, then the divergence, stall and ridge checks (:meth:`IterationLog.diverged`,
        :meth:`IterationLog.stalled`, :meth:`IterationLog.ridge`), as one stop rule."""

        def both(log: IterationLog) -> str:
            told = guard(log) if guard is not None else ""
            return told or log.diverged() or log.stalled() or log.ridge(self.slot_names, self.p_scale)

        return both

    def unscale(self, w: np.ndarray) -> tuple[dict[str, float], list[tuple[float, ...]]]:
        """Slot values by name (clipped into the bounds) and each record's initial state, from a solution."""
        w = w.copy()
        # IPOPT relaxes bounds by ~1e-8 relative: a parameter on its bound can come back just outside
        # it, which a prior or a later Problem would reject
        w[: self.n_slots] = np.clip(w[: self.n_slots], self.lo, self.hi)
        slot_values = dict(zip(self.slot_names, map(float, w[: self.n_slots] * self.p_scale)))
        nx = self.model.n_states
        x0s = [tuple(float(v) for v in w[b.offset : b.offset + nx] * b.S) for b in self.blocks]
        return slot_values, x0s


def _structured_derivatives(nlp: CollocationNLP, g):
    """The NLP's constraint Jacobian and the triangle of the Lagrangian's Hessian, assembled by blocks.

    Every collocation interval k depends only on ``z_k = (x_k, xc_k, x_k+1, p_k)`` (scaled states at
    both ends, its collocation states, its copy of the free parameters), and every objective term
    only on ``(x_k, p_k)``. The Jacobian and Hessian of one interval and of one objective term are
    generated once as SX functions (:func:`_interval_derivatives`), mapped over the intervals of each
    record (:func:`_block_entries`), and their nonzeros scattered into the global matrices (sums where
    blocks overlap, by one constant sparse matrix product). The linear constraints (parameter copies
    chained to theta, ``Problem.constraints``) add constant entries.
    """
    import casadi as ca

    w = nlp.wsym
    fns = _interval_derivatives(nlp)
    lam_f = ca.MX.sym("lam_f")
    lam_g = ca.MX.sym("lam_g", nlp.lbg.size)
    p_empty = ca.MX.sym("p", 0)
    J_rows: list[np.ndarray] = []
    J_cols: list[np.ndarray] = []
    J_vals: list[Any] = []  # CasADi matrices
    H_rows: list[np.ndarray] = []
    H_cols: list[np.ndarray] = []
    H_vals: list[Any] = []
    for b in nlp.blocks:
        J, H = _block_entries(nlp, fns, b, lam_f, lam_g)
        for lists, entries in (((J_rows, J_cols, J_vals), J), ((H_rows, H_cols, H_vals), H)):
            for out, part in zip(lists, entries):
                out += part
    con_r, con_c, con_v = nlp.linear_rows
    if len(con_r):  # linear parameter constraints: constant rows after the dynamics
        J_rows.append(np.asarray(con_r))
        J_cols.append(np.asarray(con_c))
        J_vals.append(ca.DM(np.asarray(con_v, dtype=float)))
    n_w = w.numel()
    jac = _scatter(np.concatenate(J_rows), np.concatenate(J_cols), ca.vertcat(*J_vals), nlp.lbg.size, n_w, upper=False)
    hess = _scatter(np.concatenate(H_rows), np.concatenate(H_cols), ca.vertcat(*H_vals), n_w, n_w, upper=True)
    jac_g = ca.Function("nlp_jac_g", [w, p_empty], [g, jac], ["x", "p"], ["g", "jac_g_x"])
    hess_lag = ca.Function(
        "nlp_hess_l", [w, p_empty, lam_f, lam_g], [hess], ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"]
    )
    return jac_g, hess_lag


def _interval_derivatives(nlp: CollocationNLP) -> dict:
    """The derivatives of one interval and of one objective term, as SX functions with the triplets of
    their nonzeros: ``jac`` (Jacobian of the interval's constraints in ``z``), ``hess`` (upper triangle
    of the Hessian of ``lam . g_k``), ``obj`` (upper triangle of the Hessian of one objective term in
    ``v = (x_k, p_k)``)."""
    import casadi as ca

    model, free, p_scale_free, K = nlp.model, nlp.free, nlp.p_scale_free, nlp.degree
    nx, nu, n_free, n_par = model.n_states, model.n_inputs, len(free), model.n_params
    nzz = nx * (K + 2) + n_free
    z = ca.SX.sym("z", nzz)
    uk, uk1, hk = ca.SX.sym("uk", nu), ca.SX.sym("uk1", nu), ca.SX.sym("h")
    pf, sx = ca.SX.sym("pf", n_par), ca.SX.sym("sx", nx)
    pk = z[nx * (K + 2) :]
    ps = ca.vertcat(
        *[
            pk[free.index(n)] * p_scale_free[free.index(n)] if n in free else pf[j]
            for j, n in enumerate(model.param_names)
        ]
    )
    res, xend = nlp.interval(z[:nx], ca.reshape(z[nx : nx + nx * K], nx, K), uk, uk1, hk, ps, sx)
    gk = ca.vertcat(res, xend - z[nx + nx * K : nx * (K + 2)])
    Jk = ca.jacobian(gk, z)
    lam = ca.SX.sym("lam", nx * K + nx)
    Hk = ca.triu(ca.hessian(ca.dot(lam, gk), z)[0])
    args = [z, uk, uk1, hk, pf, sx]
    # one objective term: 0.5 * w * ((y_hat - y) / y_norm)^2 of v = (x_k, p_k)
    v = ca.SX.sym("v", nx + n_free)
    uo, yk, wk, lf = ca.SX.sym("u", nu), ca.SX.sym("y"), ca.SX.sym("wk"), ca.SX.sym("lam_f")
    pv = ca.vertcat(
        *[
            v[nx + free.index(n)] * p_scale_free[free.index(n)] if n in free else pf[j]
            for j, n in enumerate(model.param_names)
        ]
    )
    ok = 0.5 * wk * ((nlp.out_fn(v[:nx] * sx, uo, pv) - yk) / nlp.y_norm) ** 2
    Ho = ca.triu(ca.hessian(lf * ok, v)[0])

    def triplet(M):
        return tuple(np.asarray(a, dtype=np.int64) for a in M.sparsity().get_triplet())

    def nonzeros(M):  # one column of M's nonzeros (CasADi's stubs leave SXElem out of vertcat's arguments)
        return ca.vertcat(*M.nonzeros())

    return {
        "jac": (ca.Function("jac_interval", args, [nonzeros(Jk)]), *triplet(Jk)),
        "hess": (ca.Function("hess_interval", args + [lam], [nonzeros(Hk)]), *triplet(Hk)),
        "obj": (ca.Function("hess_term", [v, uo, yk, wk, pf, sx, lf], [nonzeros(Ho)]), *triplet(Ho)),
    }


def _block_entries(nlp: CollocationNLP, fns: dict, b: RecordBlock, lam_f, lam_g):
    """One record's entries of the Jacobian and of the Hessian: ``(rows, cols, vals)`` lists of each."""
    import casadi as ca

    w, nx, K, stride = nlp.wsym, nlp.model.n_states, nlp.degree, nlp.stride
    n_free = len(nlp.free)
    nzz, n_rows = nx * (K + 2) + n_free, nx * K + nx
    (jfun, jr, jc), (hfun, hr, hc), (ofun, orr, occ) = fns["jac"], fns["hess"], fns["obj"]
    o, N, U = b.offset, b.N, b.U
    k = np.arange(N - 1)
    xs_idx = o + np.arange(nx)[:, None] + nx * np.arange(N)[None, :]  # (nx, N)
    xc_idx = o + nx * N + np.arange(nx * K)[:, None] + nx * K * k[None, :]  # (nx K, N-1)
    nb = -(-N // stride)
    pb_idx = o + nx * N + nx * K * (N - 1) + np.arange(n_free)[:, None] + n_free * np.arange(nb)[None, :]
    p_idx = pb_idx[:, np.arange(N) // stride]  # (n_free, N)
    zi = np.vstack([xs_idx[:, :-1], xc_idx, xs_idx[:, 1:], p_idx[:, :-1]])  # (nzz, N-1)
    c0 = b.g_offset
    c1 = c0 + nx * K * (N - 1)
    c2 = c1 + nx * (N - 1)
    c3 = c2 + n_free
    gi = np.vstack(
        [c0 + np.arange(nx * K)[:, None] + nx * K * k[None, :], c1 + np.arange(nx)[:, None] + nx * k[None, :]]
    )  # (n_rows, N-1)
    Z = ca.reshape(w[zi.ravel(order="F").tolist()], nzz, N - 1)
    L = ca.reshape(lam_g[gi.ravel(order="F").tolist()], n_rows, N - 1)
    common = (U[:-1].T, U[1:].T, b.h[None, :], b.pf, b.S)
    J_vals = [ca.vec(jfun.map(N - 1)(Z, *common))]
    J_rows = [gi[jr, :].ravel(order="F")]
    J_cols = [zi[jc, :].ravel(order="F")]
    vi = np.vstack([xs_idx, p_idx])
    V = ca.reshape(w[vi.ravel(order="F").tolist()], nx + n_free, N)
    H_vals = [
        ca.vec(hfun.map(N - 1)(Z, *common, L)),
        ca.vec(ofun.map(N)(V, U.T, b.y[None, :], b.wts[None, :], b.pf, b.S, lam_f)),
    ]
    H_rows = [zi[hr, :].ravel(order="F"), vi[orr, :].ravel(order="F")]
    H_cols = [zi[hc, :].ravel(order="F"), vi[occ, :].ravel(order="F")]
    # linear constraints: p_0 - theta = 0 and p_b+1 - p_b = 0 between consecutive copies
    jf = np.arange(n_free)
    chain = (c3 + jf[:, None] + n_free * np.arange(nb - 1)[None, :]).ravel(order="F")
    J_rows += [c2 + jf, c2 + jf, chain, chain]
    J_cols += [pb_idx[:, 0], np.asarray(b.sidx), pb_idx[:, 1:].ravel(order="F"), pb_idx[:, :-1].ravel(order="F")]
    n_lin = n_free * (nb - 1)
    J_vals.append(ca.DM(np.concatenate([np.ones(n_free), -np.ones(n_free), np.ones(n_lin), -np.ones(n_lin)])))
    return (J_rows, J_cols, J_vals), (H_rows, H_cols, H_vals)


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


def ipopt_status(name) -> Status | str:
    """IPOPT's return status ``name`` as a :class:`~duffsym.status.Status` member (same string value), or the
    string itself when no member carries it (the JSON outputs keep IPOPT's text either way)."""
    try:
        return Status(str(name))
    except ValueError:
        return str(name)


def _status_message(status: str, success: bool, max_iter: int) -> str:
    """The message of a run that ended with IPOPT's ``status``: what to try when it did not converge."""
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


def _make_hook_class():
    """The CasADi callback class (built on first use, so that importing this module does not import CasADi)."""
    import casadi as ca

    class Hook(ca.Callback):
        """IPOPT's intermediate callback: count, report, and stop on request (return 1)."""

        def __init__(self, n_w: int, n_slots: int):
            ca.Callback.__init__(self)
            self.n_w, self.n_slots = int(n_w), int(n_slots)
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
            # only the cost and the iterate are taken (the parameter slots lead it, for the ridge check):
            # declaring the constraints and multipliers empty keeps those vectors from being copied
            name = ca.nlpsol_out(i)
            if name == "x":
                return ca.Sparsity.dense(self.n_w, 1)
            return ca.Sparsity.scalar() if name == "f" else ca.Sparsity(0, 0)

        def eval(self, arg):
            self.iterations += 1
            now = time.perf_counter()
            slots = np.asarray(arg[0][: self.n_slots]).reshape(-1) if self.n_slots else None
            self.log.add(now, self.solver, slots)
            if self.progress is not None and now - self.last >= PROGRESS_EVERY:
                self.last = now
                self.progress(
                    f"solving{self.label}: iteration {self.iterations}, {now - self.t0:.1f} s"
                    + self.log.progress_note()
                )
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
        self.mu: list[float] = []
        self.params: list[np.ndarray] = []  # the scaled parameter slots after each iteration
        self.restoration = False

    def add(self, now: float, solver, slots: np.ndarray | None = None) -> None:
        self.times.append(now - self.t_prev)
        self.t_prev = now
        it = {}
        if solver is not None:
            try:
                it = solver.stats().get("iterations", {})
            except RuntimeError:  # no statistics yet
                it = {}
        keys = (("regularization_size", self.reg), ("inf_pr", self.inf_pr), ("obj", self.obj), ("mu", self.mu))
        for key, out in keys:
            vals = it.get(key) or [math.nan]
            out.append(float(vals[-1]))
        if slots is not None:
            self.params.append(slots)

    def ridge(self, names: Sequence[str], scale: np.ndarray) -> str:
        """Why the run has stalled on a ridge (see :data:`RIDGE_WINDOW`), naming the parameters that still move
        and by how much over the window; "" when it has not."""
        k = RIDGE_WINDOW
        if len(self.obj) <= k or len(self.params) <= k:
            return ""
        mu, obj = np.asarray(self.mu[-k - 1 :]), np.asarray(self.obj[-k - 1 :])
        if not (np.all(mu <= RIDGE_MU) and self.inf_pr[-1] <= RIDGE_INF_PR and np.all(np.isfinite(obj))):
            return ""
        gain = (obj[0] - obj[-1]) / max(abs(obj[0]), 1e-300)
        if gain >= RIDGE_GAIN:
            return ""
        before, after = self.params[-k - 1] * scale, self.params[-1] * scale
        rel = (after - before) / np.maximum(np.abs(before), RIDGE_FLOOR * np.abs(scale))
        moving = [j for j in np.argsort(-np.abs(rel)) if abs(rel[j]) > RIDGE_MOVE]
        if not moving:
            return ""
        said = ", ".join(f"{names[j]} {before[j]:.4g} -> {after[j]:.4g}" for j in moving[:4])
        return f"ridge: over the last {k} iterations the cost fell by {100 * gain:.2g} % while {said} still moved"

    def diverged(self) -> str:
        """Why the run has diverged (see :data:`DIVERGED_INF_PR`), or "" when it has not."""
        pr = [v for v in self.inf_pr if v == v]
        if len(pr) < 2:
            return ""
        now, low = pr[-1], min(pr[:-1])
        if not (now > DIVERGED_INF_PR and now > DIVERGED_GROWTH * max(low, 1e-300)):
            return ""
        return (
            f"diverged: IPOPT's iterate left the dynamics (collocation defect {now:.1e}, {now / max(low, 1e-300):.1e} "
            f"times its lowest in this run); its next iterations would be ill-conditioned and slow"
        )

    def stalled(self) -> str:
        """Why the run has stalled in slow, ill-conditioned iterations (see :data:`STALL_ITERATIONS`), or ""."""
        if not (self._slow_and_ill(len(self.times) - 1)):
            return ""
        bad = [i for i in range(len(self.times)) if self._slow_and_ill(i)]
        if len(bad) < STALL_ITERATIONS:
            return ""
        worst = max(self.times[i] for i in bad)
        return (
            f"stalled: {len(bad)} iterations took over {STALL_FACTOR:g} times the run's median (up to {worst:.0f} s) "
            f"with IPOPT's Hessian regularisation >= {REGULARISATION_ALARM:.0e} (ill-conditioned)"
        )

    def _slow_and_ill(self, i: int) -> bool:
        if i < 3 or i >= len(self.reg) or not self.reg[i] >= REGULARISATION_ALARM:
            return False
        return self.times[i] > max(STALL_FLOOR, STALL_FACTOR * float(np.median(self.times[:i])))

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
        """Over IPOPT's callbacks (its iteration 0, the start, included): ``{"n", "seconds_total",
        "seconds_median", "seconds_max", "slowest", "regularisation_max", "ill_conditioned"}`` (for
        ``settings["iterations"]`` of a fit)."""
        t = np.asarray(self.times, dtype=float)
        reg = np.asarray([r for r in self.reg if math.isfinite(r)], dtype=float)
        return {
            "n": int(t.size),
            "seconds_total": float(t.sum()),
            "seconds_median": float(np.median(t)) if t.size else 0.0,
            "seconds_max": float(t.max()) if t.size else 0.0,
            "slowest": int(np.argmax(t)) + 1 if t.size else 0,
            "regularisation_max": float(reg.max()) if reg.size else 0.0,
            "ill_conditioned": self.alarms,
            "restoration_failed": bool(self.restoration),
        }


def first_run_summary(result) -> dict:
    """The iteration summary (:meth:`IterationLog.summary`) of a fit result's first IPOPT run, from its
    ``settings["iterations"]``; {} when the fit logged none."""
    return dict((result.settings.get("iterations") or [None])[0] or {})


def restart_guard(first: Run, *, max_iter: int) -> Callable[[IterationLog], str]:
    """The stop rule of a bound restart: it may not cost more than the converged run it started from is
    worth keeping (:func:`bounded_guard` of that run)."""
    return bounded_guard(first.iterations or {}, first.n_iter, max_iter=max_iter)


def bounded_guard(info: Mapping, n_iter: int, *, max_iter: int | None) -> Callable[[IterationLog], str]:
    """The stop rule of an optional run (a bound restart, a second start) that a converged run already answers,
    given that run's iteration summary ``info`` (:meth:`IterationLog.summary`) and iterations ``n_iter``.
    Stops when an iteration takes ``RESTART_SLOW_FACTOR`` times that run's median iteration (and over
    ``RESTART_SLOW_FLOOR`` s), after ``RESTART_ALARM_ITERATIONS`` iterations with the Hessian regularisation
    at :data:`REGULARISATION_ALARM` or more, or after ``RESTART_ITER_FACTOR`` times its iterations (at least
    ``RESTART_MIN_ITER``, at most ``max_iter``) without having converged. ``max_iter=None``: no iteration cap,
    only the other two rules (a second start from elsewhere may need more iterations than a run that started at
    the optimum)."""
    info = info or {}
    slow = max(RESTART_SLOW_FLOOR, RESTART_SLOW_FACTOR * float(info.get("seconds_median", 0.0)))
    cap = (
        math.inf
        if max_iter is None
        else min(int(max_iter), max(RESTART_MIN_ITER, int(RESTART_ITER_FACTOR * max(n_iter, 1))))
    )

    def guard(log: IterationLog) -> str:
        if log.times and log.times[-1] > slow:
            median = info.get("seconds_median", 0)
            return f"an iteration took {log.times[-1]:.1f} s (the first run's median {median:.2g} s)"
        if log.alarms >= RESTART_ALARM_ITERATIONS:
            return (
                f"{log.alarms} iterations with IPOPT's Hessian regularisation >= {REGULARISATION_ALARM:.0e} "
                "(ill-conditioned)"
            )
        if len(log.times) >= cap:
            return f"{len(log.times)} iterations without converging (the first run needed {n_iter})"
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
        if threading.current_thread() is threading.main_thread():  # put back what was there (Python's default if none)
            signal.signal(signal.SIGINT, self.previous if self.previous is not None else signal.default_int_handler)
        return False


_HOOK_CLASS = None


def _iteration_hook(n_w: int, n_slots: int):
    """A new IPOPT intermediate callback (:func:`_make_hook_class`) for ``n_w`` variables, ``n_slots`` of them
    the parameter slots at the front."""
    global _HOOK_CLASS
    if _HOOK_CLASS is None:
        _HOOK_CLASS = _make_hook_class()
    return _HOOK_CLASS(n_w, n_slots)
