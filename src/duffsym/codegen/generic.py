"""One explicit integrator for every model, compiled once: the model's functions are called through pointers.

Each generated module compiles its own RK4 integrator (``_integrator_template.py``), with the right-hand side
inlined four times per substep: the fastest free run, but 4-7 s of compiling per model, and in a diagnosis or
a ladder every candidate is a new model (py-spy over ladders: 63-70 % of the time in numba's compiler, all of
it there). :func:`integrate` here is the same RK4 with the same stiffness-chosen substeps, written once; it
takes the model's ``rhs_ptr``, ``jac_ptr`` and ``output_ptr`` (generated beside the inlined ones, with the
explicit signatures below) as first-class functions, so a new model compiles only those three small functions
(3-8x less, ``benchmarks/lever_generic_integrator.py``), for a free run 2-4x slower (about 1 ms for 3000
samples) that agrees with the inlined integrator to rounding (below 1e-14 of max|y|).

:func:`duffsym.simulate.simulate` uses it for its explicit runs; the batch and sampler kernels, where the run
time counts, keep the inlined integrator.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, types

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


_SIG = types.UniTuple(types.int64, 2)(
    types.FunctionType(SIG_RHS),
    types.FunctionType(SIG_JAC),
    types.FunctionType(SIG_OUT),
    _RO1,
    _RO2,
    _RO1,
    _RO1,
    types.int64,
    types.float64,
    types.int64,
    types.boolean,
    types.float64,
    _A2,
    _A1,
    types.int64[::1],
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
