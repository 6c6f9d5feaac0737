"""One explicit integrator for every model, compiled once: the model's functions are called through pointers.

Each generated module compiles its own RK4 integrator (``_integrator_template.py``), with the right-hand side
inlined four times per substep: the fastest free run, but 4-7 s of compiling per model, and in a diagnosis or
a ladder every candidate is a new model (py-spy over ladders: 63-70 % of the time in numba's compiler, all of
it there). :func:`integrate` here is the same RK4 with the same stiffness-chosen substeps, written once; it
takes the model's ``rhs_ptr``, ``jac_ptr`` and ``output_ptr`` (generated beside the inlined ones, with the
explicit signatures below) as first-class functions, so a new model compiles only those three small functions
(3-8x less, ``benchmarks/lever_generic_integrator.py``), for a free run 2-4x slower (about 1 ms for 3000
samples) that agrees with the inlined integrator to rounding (below 1e-14 of max|y|).

:func:`duffsym.simulate.simulate` uses it for its explicit runs, :func:`integrate_implicit` (ROS2, the same
pointers) for its stiff runs, and :func:`integrate_batch` (the RK4 over parameter sets in parallel) for
:func:`duffsym.simulate.simulate_batch`; only the sampler's kernel, where the run time counts, stays inlined.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange, types

_A1 = types.float64[::1]
_A2 = types.float64[:, ::1]
_RO1 = types.Array(types.float64, 1, "C", readonly=True)
_RO2 = types.Array(types.float64, 2, "C", readonly=True)

#: ``rhs_ptr(x, u, p, out)``, ``jac_ptr(x, u, p, out)`` (out: n x n) and ``output_ptr(x, u, p) -> y`` of a model
SIG_RHS = types.void(_A1, _A1, _RO1, _A1)
SIG_JAC = types.void(_A1, _A1, _RO1, _A2)
SIG_OUT = types.float64(_A1, _A1, _RO1)

STATUS_OK = 0
STATUS_BLOWUP = 1
STATUS_TOO_STIFF = 2


@njit(cache=True)
def _spectral_radius(J):
    """The template's ``spectral_radius``: exact for one or two states, Gershgorin's bound above."""
    n = J.shape[0]
    if n == 1:
        return abs(J[0, 0])
    if n == 2:
        tr = J[0, 0] + J[1, 1]
        det = J[0, 0] * J[1, 1] - J[0, 1] * J[1, 0]
        disc = 0.25 * tr * tr - det
        if disc >= 0.0:
            s = math.sqrt(disc)
            return max(abs(0.5 * tr + s), abs(0.5 * tr - s))
        return math.sqrt(det)
    best = 0.0
    for i in range(n):
        s = 0.0
        for j in range(n):
            s += abs(J[i, j])
        best = max(best, s)
    return best


@njit(cache=True)
def _rk4(rhs, x, U, k, p, dt, m, hold, xo, work):
    """``m`` RK4 substeps over sample interval ``k`` from ``x`` into ``xo``, the input linear within it (held
    if ``hold``), as the template's ``_advance``; ``work`` holds the stages, the inputs and their step (9 rows)."""
    n, ni = x.shape[0], U.shape[1]
    k1, k2, k3, k4, xs = work[0, :n], work[1, :n], work[2, :n], work[3, :n], work[4, :n]
    ua, ub, uc, g = work[5, :ni], work[6, :ni], work[7, :ni], work[8, :ni]
    h = dt / m
    for i in range(n):
        xo[i] = x[i]
    for j in range(ni):  # the input's step per substep, once per interval (as the template's g0, g1, ...)
        g[j] = 0.0 if hold else (U[k + 1, j] - U[k, j]) / m
    for s in range(m):
        for j in range(ni):
            ua[j] = U[k, j] + s * g[j]
            ub[j] = ua[j] + 0.5 * g[j]
            uc[j] = ua[j] + g[j]
        rhs(xo, ua, p, k1)
        for i in range(n):
            xs[i] = xo[i] + 0.5 * h * k1[i]
        rhs(xs, ub, p, k2)
        for i in range(n):
            xs[i] = xo[i] + 0.5 * h * k2[i]
        rhs(xs, ub, p, k3)
        for i in range(n):
            xs[i] = xo[i] + h * k3[i]
        rhs(xs, uc, p, k4)
        for i in range(n):
            xo[i] = xo[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@njit(cache=True)
def _fail_from(k, X, Y):
    for kk in range(k, Y.shape[0]):
        Y[kk] = np.nan
        for i in range(X.shape[1]):
            X[kk, i] = np.nan


@njit(cache=True)
def _stiffness(jac, x, U, k, p, J, u):
    for j in range(U.shape[1]):
        u[j] = U[k, j]
    jac(x, u, p, J)
    return _spectral_radius(J)


@njit(cache=True)
def _within(x, blowup):
    for i in range(x.shape[0]):
        if not (abs(x[i]) <= blowup):
            return False
    return True


@njit(cache=True)
def _output(output, x, U, k, p, u):
    for j in range(U.shape[1]):
        u[j] = U[k, j]
    return output(x, u, p)


#: the leading arguments of every kernel here (the model's three functions) and the trailing outputs of a run
#: (states X, outputs Y, substeps M)
_MODEL = (types.FunctionType(SIG_RHS), types.FunctionType(SIG_JAC), types.FunctionType(SIG_OUT))
_RUN_OUT = (_A2, _A1, types.int64[::1])
_SIG = types.UniTuple(types.int64, 2)(
    *_MODEL, _RO1, _RO2, _RO1, _RO1, types.int64, types.float64, types.int64, types.boolean, types.float64, *_RUN_OUT
)


class Settings(NamedTuple):
    """The integrator's settings, as :func:`duffsym.simulate.simulate` passes them: ``substeps`` (> 0 fixed,
    <= 0 chosen from the stiffness), the stiffness target ``h_lambda``, ``max_substeps``, ``hold`` (the input
    held over each interval instead of linear) and the ``blowup`` state magnitude."""

    substeps: int
    h_lambda: float
    max_substeps: int
    hold: bool
    blowup: float


def integrate(mod, t, U, x0, p, settings: Settings, X, Y, M) -> tuple[int, int]:
    """Integrate the generated module ``mod``'s model from ``x0`` over the sample times ``t`` with inputs ``U``
    (read-only C-contiguous float64, as :func:`duffsym.simulate.frozen_array` gives them), as the template's
    ``integrate``: writes states ``X``, outputs ``Y`` and substeps ``M``; returns (status, index of the first
    failed sample or -1)."""
    s = settings
    return _integrate(mod.rhs_ptr, mod.jac_ptr, mod.output_ptr, t, U, x0, p, int(s.substeps), float(s.h_lambda),
                      int(s.max_substeps), bool(s.hold), float(s.blowup), X, Y, M)  # fmt: skip


@njit(_SIG, cache=True)
def _integrate(rhs, jac, output, t, U, x0, p, substeps, h_lambda, max_substeps, hold, blowup, X, Y, M):
    """The template's ``integrate`` (same arguments after the three functions, same outputs and statuses)."""
    n = x0.shape[0]
    x = np.empty(n)
    xo = np.empty(n)
    J = np.empty((n, n))
    u = np.empty(U.shape[1])
    work = np.empty((9, max(n, U.shape[1])))
    for i in range(n):
        x[i] = x0[i]
        X[0, i] = x0[i]
    Y[0] = _output(output, x, U, 0, p, u)
    adaptive = substeps <= 0
    rho = _stiffness(jac, x, U, 0, p, J, u) if adaptive else 0.0
    rho_prev = -1.0
    dt_prev = 1.0
    for k in range(t.shape[0] - 1):
        dt = t[k + 1] - t[k]
        m = substeps
        if adaptive:  # the stiffness predicted at the interval's end from its trend (as the template)
            r = rho + (rho - rho_prev) * (dt / dt_prev) if rho_prev >= 0.0 and rho > rho_prev else rho
            m = max(1, int(math.ceil(dt * r / h_lambda)))
            rho_prev = rho
            dt_prev = dt
        while True:
            if m > max_substeps:
                _fail_from(k + 1, X, Y)
                return STATUS_TOO_STIFF, k
            _rk4(rhs, x, U, k, p, dt, m, hold, xo, work)
            finite = _within(xo, blowup)
            if not finite:
                if adaptive and m < max_substeps:
                    m = min(max_substeps, 4 * m)
                    continue
                break
            if not adaptive:
                break
            rho = _stiffness(jac, xo, U, k + 1, p, J, u)
            if dt * rho / m <= h_lambda:
                break
            m = max(m + 1, int(math.ceil(dt * rho / h_lambda)))
        if not finite:
            _fail_from(k + 1, X, Y)
            return STATUS_BLOWUP, k + 1
        M[k] = m
        for i in range(n):
            x[i] = xo[i]
            X[k + 1, i] = xo[i]
        Y[k + 1] = _output(output, x, U, k + 1, p, u)
    return STATUS_OK, -1


_SIG_BATCH = types.void(
    *_MODEL,
    _RO1,
    _RO2,
    _RO2,
    _RO2,
    types.int64,
    types.float64,
    types.int64,
    types.boolean,
    types.float64,
    _A2,
    types.int64[::1],
    types.int64[::1],
    types.int64[::1],
)


def integrate_batch(mod, t, U, X0, P, settings: Settings, Y, status, fail_index, total_substeps) -> None:
    """:func:`integrate` for many parameter sets (rows of ``P``) and initial states (rows of ``X0``), in
    parallel, as the template's ``integrate_batch``: writes each set's outputs (rows of ``Y``), status, first
    failed sample and total substeps."""
    s = settings
    _integrate_batch(mod.rhs_ptr, mod.jac_ptr, mod.output_ptr, t, U, X0, P, int(s.substeps), float(s.h_lambda),
                     int(s.max_substeps), bool(s.hold), float(s.blowup), Y, status, fail_index,
                     total_substeps)  # fmt: skip


@njit(_SIG_BATCH, cache=True, parallel=True)
def _integrate_batch(rhs, jac, output, t, U, X0, P, substeps, h_lambda, max_substeps, hold, blowup, Y, status,
                     fail_index, total_substeps):  # fmt: skip
    n_times = t.shape[0]
    for s in prange(P.shape[0]):
        X = np.empty((n_times, X0.shape[1]))
        M = np.zeros(max(n_times - 1, 1), dtype=np.int64)
        st, idx = _integrate(rhs, jac, output, t, U, X0[s], P[s], substeps, h_lambda, max_substeps, hold, blowup,
                             X, Y[s], M)  # fmt: skip
        status[s] = st
        fail_index[s] = idx
        total_substeps[s] = M.sum()


# ------------------------------------------------------------------------------------------------
# Linearly implicit (Rosenbrock) integrator for stiff runs: ROS2 of Verwer, Spee, Blom & Hundsdorfer
# (SIAM J. Sci. Comput. 20, 1999), gamma = 1 + 1/sqrt(2). Second order for any Jacobian (a W-method,
# so the time dependence of the input needs no df/dt term), L-stable, one LU of (I - gamma h J) per
# step and no Newton iteration. The embedded first-order solution x + h k1 gives the error estimate.

ROS_GAMMA = 1.0 + 1.0 / math.sqrt(2.0)


@njit(cache=True)
def _lu(A, piv):
    """In-place LU factorisation with partial pivoting; False if singular."""
    n = A.shape[0]
    for c in range(n):
        r = c
        big = abs(A[c, c])
        for i in range(c + 1, n):
            if abs(A[i, c]) > big:
                big = abs(A[i, c])
                r = i
        if not (big > 0.0):
            return False
        piv[c] = r
        if r != c:
            for j in range(n):
                tmp = A[c, j]
                A[c, j] = A[r, j]
                A[r, j] = tmp
        for i in range(c + 1, n):
            f = A[i, c] / A[c, c]
            A[i, c] = f
            for j in range(c + 1, n):
                A[i, j] -= f * A[c, j]
    return True


@njit(cache=True)
def _lu_solve(A, piv, b):
    """Solve A z = b in place (b becomes z) with the factors of _lu."""
    n = A.shape[0]
    for c in range(n):
        r = piv[c]
        if r != c:
            tmp = b[c]
            b[c] = b[r]
            b[r] = tmp
    for i in range(n):
        for j in range(i):
            b[i] -= A[i, j] * b[j]
    for i in range(n - 1, -1, -1):
        for j in range(i + 1, n):
            b[i] -= A[i, j] * b[j]
        b[i] /= A[i, i]


@njit(cache=True)
def _ros2_step(rhs, jac, x, ua, ub, p, h, J, A, piv, k1, k2, xs, f, xn, err):
    """One ROS2 step of size h from x (input ua at the start, ub at the end). Writes xn and the
    embedded error err; False if the step matrix is singular or the stage is not finite."""
    n = x.shape[0]
    jac(x, ua, p, J)
    for i in range(n):
        for j in range(n):
            A[i, j] = -ROS_GAMMA * h * J[i, j]
        A[i, i] += 1.0
    if not _lu(A, piv):
        return False
    rhs(x, ua, p, k1)
    _lu_solve(A, piv, k1)
    for i in range(n):
        xs[i] = x[i] + h * k1[i]
    if not _within(xs, 1e300):
        return False
    rhs(xs, ub, p, f)
    for i in range(n):
        k2[i] = f[i] - 2.0 * k1[i]
    _lu_solve(A, piv, k2)
    for i in range(n):
        xn[i] = x[i] + h * (1.5 * k1[i] + 0.5 * k2[i])
        err[i] = 0.5 * h * (k1[i] + k2[i])
    return True


_SIG_IMPLICIT = types.UniTuple(types.int64, 2)(
    *_MODEL,
    _RO1,
    _RO2,
    _RO1,
    _RO1,
    types.int64,
    types.float64,
    types.float64,
    types.int64,
    types.boolean,
    types.float64,
    *_RUN_OUT,
)


class ImplicitSettings(NamedTuple):
    """The implicit integrator's settings: ``substeps`` (> 0 equal steps per interval, <= 0 steps chosen by the
    embedded error estimate with ``rtol`` and ``atol``), ``max_steps`` per interval, ``hold`` and ``blowup``."""

    substeps: int
    rtol: float
    atol: float
    max_steps: int
    hold: bool
    blowup: float


def integrate_implicit(mod, t, U, x0, p, settings: ImplicitSettings, X, Y, M) -> tuple[int, int]:
    """:func:`integrate` with the linearly implicit ROS2 integrator, for stiff runs (same arrays, outputs and
    statuses; ``M`` holds the accepted steps per interval)."""
    s = settings
    return _integrate_implicit(mod.rhs_ptr, mod.jac_ptr, mod.output_ptr, t, U, x0, p, int(s.substeps),
                               float(s.rtol), float(s.atol), int(s.max_steps), bool(s.hold), float(s.blowup),
                               X, Y, M)  # fmt: skip


@njit(_SIG_IMPLICIT, cache=True)
def _integrate_implicit(rhs, jac, output, t, U, x0, p, substeps, rtol, atol, max_steps, hold, blowup, X, Y,
                        M):  # fmt: skip
    """The template's ROS2 ``integrate_implicit``: over the sample times t (arguments and outputs as _integrate).

    substeps > 0 takes that many equal steps per sample interval (a fixed discretisation, for
    finite differences); substeps <= 0 controls the step size by the embedded error estimate
    (scaled RMS norm with rtol, atol), carrying the step size from one interval to the next.
    Blow-up (a state non-finite or beyond ``blowup``) and step-size collapse (more than max_steps
    steps in one interval, or a step below 1e-12 of the interval) stop the run and are reported.
    M holds the accepted steps per interval.

    Long: a numba kernel; its step loop stays whole because every helper called per step costs a call
    in the innermost loop, and the step-size control shares most of the loop's local state.
    """
    n = x0.shape[0]
    ni = U.shape[1]
    x = np.empty(n)
    xn = np.empty(n)
    J = np.empty((n, n))
    A = np.empty((n, n))
    piv = np.zeros(n, dtype=np.int64)
    k1 = np.empty(n)
    k2 = np.empty(n)
    xs = np.empty(n)
    f = np.empty(n)
    err = np.empty(n)
    ua = np.empty(ni)
    ub = np.empty(ni)
    u = np.empty(ni)
    for i in range(n):
        x[i] = x0[i]
        X[0, i] = x0[i]
    Y[0] = _output(output, x, U, 0, p, u)
    adaptive = substeps <= 0
    h = -1.0
    for k in range(t.shape[0] - 1):
        dt = t[k + 1] - t[k]
        if h <= 0.0 or h > dt:
            h = dt
        if not adaptive:
            h = dt / substeps
        tau = 0.0
        steps = 0
        tries = 0
        start_norm = 1e-300
        for i in range(n):
            start_norm = max(start_norm, abs(x[i]))
        status = STATUS_OK
        while tau < dt * (1.0 - 1e-12):
            last = tau + h >= dt * (1.0 - 1e-12)
            hs = dt - tau if last else h
            if tries >= max_steps or hs < 1e-12 * dt:
                # a step size collapsing while the state grows tenfold within the interval is a
                # finite-time escape (blow-up); otherwise the right-hand side is too stiff/rough
                grown = 0.0
                for i in range(n):
                    grown = max(grown, abs(x[i]))
                status = STATUS_BLOWUP if grown > 10.0 * start_norm else STATUS_TOO_STIFF
                break
            for j in range(ni):
                g = 0.0 if hold else (U[k + 1, j] - U[k, j]) / dt
                ua[j] = U[k, j] + tau * g
                ub[j] = U[k, j] + (tau + hs) * g
            ok = _ros2_step(rhs, jac, x, ua, ub, p, hs, J, A, piv, k1, k2, xs, f, xn, err)
            tries += 1
            if adaptive:
                e = 0.0
                if ok:
                    for i in range(n):
                        sc = atol + rtol * max(abs(x[i]), abs(xn[i]))
                        e += (err[i] / sc) ** 2
                    e = math.sqrt(e / n)
                if not ok or not (e == e) or e > 1.0:
                    fac = 0.2 if not ok or not (e == e) else max(0.2, 0.9 / math.sqrt(e))
                    h = hs * fac
                    continue
                fac = 5.0 if e == 0.0 else min(5.0, 0.9 / math.sqrt(e))
                if not last:
                    h = hs * fac
                else:
                    h = max(h, hs * fac) if hs < h else hs * fac
            elif not ok:
                status = STATUS_BLOWUP
                break
            if not _within(xn, blowup):
                status = STATUS_BLOWUP
                break
            for i in range(n):
                x[i] = xn[i]
            tau += hs
            steps += 1
        if status != STATUS_OK:
            _fail_from(k + 1, X, Y)
            return status, (k + 1 if status == STATUS_BLOWUP else k)
        M[k] = steps
        for i in range(n):
            X[k + 1, i] = x[i]
        Y[k + 1] = _output(output, x, U, k + 1, p, u)
    return STATUS_OK, -1
