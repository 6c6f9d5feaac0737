"""An independent generator of MR-damper records driven by a changing coil command.

Written from the equations, *not* from duffsym: numpy only, so the current-driven model
(``mr-damper-current``) can be tested on data its own model code did not make. The device:

    x'' + (c1(u) + c2(u)) x' + (k1(u) + k2(u)) x + k3 x^n + c3(u) x'^n = k1(u) d + c1(u) d'
    u'  = -eta (u - i(t))                      (the field lags the coil command i, Spencer et al. 1997)
    y   = A_f (1 + A_f_u u) x'  (+ white noise)

with each coefficient theta(u) = theta + theta_u u (the linear field dependence; relative for A_f). The displacement
d(t) is a sum of sines and the command i(t) a smooth random switching signal (tanh of sines), both
analytic and evaluated at every RK4 stage; ``substeps`` RK4 steps per sample. The command may also
be constant (one test at one current).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: A device in the spirit of Table 2 of the paper (coefficients fall as the field grows; per ampere).
TRUTH = dict(
    c1=10.0,
    c2=30.0,
    c3=330.0,
    k1=45.0,
    k2=600.0,
    k3=0.0,
    A_f=1.5,
    c1_u=-4.0,
    c2_u=-20.0,
    c3_u=-80.0,
    k1_u=-15.0,
    k2_u=-200.0,
    A_f_u=0.8,
    eta=60.0,
)
FIELD = ("c1", "c2", "c3", "k1", "k2")


@dataclass(frozen=True)
class Sines:
    """s(t) = offset + sum_i A_i sin(2 pi f_i t + phi_i), with its exact first derivative."""

    amps: tuple
    freqs: tuple
    phases: tuple
    offset: float = 0.0

    def __call__(self, t, order: int = 0):
        t = np.asarray(t, dtype=float)
        out = np.full_like(t, self.offset if order == 0 else 0.0)
        for a, f, ph in zip(self.amps, self.freqs, self.phases):
            w = 2 * math.pi * f
            out += a * w**order * np.sin(w * t + ph + order * math.pi / 2)
        return out


@dataclass(frozen=True)
class Switching:
    """A smooth random switching command: lo + (hi - lo) (1 + tanh(sharp * s(t))) / 2, s a sum of sines."""

    lo: float
    hi: float
    carrier: Sines
    sharp: float = 6.0

    def __call__(self, t):
        return self.lo + (self.hi - self.lo) * 0.5 * (1 + np.tanh(self.sharp * self.carrier(t)))


def constant(level: float):
    return lambda t: np.full_like(np.asarray(t, dtype=float), float(level))


def coefficients(p: dict, u):
    return {k: p[k] + p[k + "_u"] * u for k in FIELD}


def rhs(p: dict, n: int, x, v, u, d, dd, i):
    c = coefficients(p, u)
    acc = (
        -(c["c1"] + c["c2"]) * v
        - (c["k1"] + c["k2"]) * x
        - p["k3"] * x**n
        - c["c3"] * v**n
        + c["k1"] * d
        + c["c1"] * dd
    )
    return v, acc, -p["eta"] * (u - i)


def integrate(rhs_fn, disp: Sines, command, *, dt: float, duration: float, settle: float, substeps: int):
    """RK4 of ``rhs_fn(x, v, u, d, d_dot, i) -> (x', v', u')`` with the analytic inputs evaluated at every stage,
    ``substeps`` steps per sample, from rest with the field at the command; ``(t, states, n_settle)``."""
    n_settle, n_keep = int(round(settle / dt)), int(round(duration / dt))
    t = (np.arange(n_settle + n_keep) - n_settle) * dt
    h = dt / substeps
    s = np.array([0.0, 0.0, float(command(t[:1])[0])])
    out = np.empty((t.size, 3))
    out[0] = s
    for k in range(t.size - 1):
        for j in range(substeps):
            t0 = t[k] + j * h
            tt = np.array([t0, t0 + h / 2, t0 + h])
            d, dd, ii = disp(tt), disp(tt, 1), command(tt)

            def f(state, m, d=d, dd=dd, ii=ii):
                return np.array(rhs_fn(state[0], state[1], state[2], d[m], dd[m], ii[m]))

            q1 = f(s, 0)
            q2 = f(s + h / 2 * q1, 1)
            q3 = f(s + h / 2 * q2, 1)
            q4 = f(s + h * q3, 2)
            s = s + h / 6 * (q1 + 2 * q2 + 2 * q3 + q4)
        out[k + 1] = s
    return t, out, n_settle


def generate(
    p: dict,
    disp: Sines,
    command,
    *,
    dt: float = 0.002,
    duration: float = 6.0,
    n: int = 5,
    noise: float = 0.01,
    settle: float = 1.0,
    substeps: int = 10,
    seed: int = 0,
) -> dict:
    """Simulate and sample: ``{"t", "d", "d_dot", "command", "y", "y_clean"}`` after ``settle`` seconds."""
    t, out, n_settle = integrate(
        lambda x, v, u, d, dd, i: rhs(p, n, x, v, u, d, dd, i),
        disp,
        command,
        dt=dt,
        duration=duration,
        settle=settle,
        substeps=substeps,
    )
    keep = slice(n_settle, None)
    y_clean = p["A_f"] * (1 + p["A_f_u"] * out[keep, 2]) * out[keep, 1]
    rng = np.random.default_rng(seed)
    y = y_clean + noise * float(np.sqrt(np.mean(y_clean**2))) * rng.standard_normal(y_clean.size)
    tk = t[keep] - t[n_settle]
    return {
        "t": tk,
        "d": disp(t[keep]),
        "d_dot": disp(t[keep], 1),
        "command": command(t[keep]),
        "y": y,
        "y_clean": y_clean,
        "field": out[keep, 2],
    }
