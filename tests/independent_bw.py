"""An independent simulator of a mass with a restoring hysteresis element: Bouc–Wen or Duffing-like.

Written from the equations, *not* from duffsym: this module imports numpy only, so the structure model's
identification (``duffsym.model.structure``) can be tested on records its own code did not make.

The Bouc–Wen oscillator of the hysteretic benchmark (Noël & Schoukens 2016; the constants of
``../shared/data/external/bouc_wen_benchmark/SOURCE.md``)::

    m y'' + c y' + k y + z = u,
    z' = alpha y' - beta (gamma |y'| |z|^(nu-1) z + delta y' |z|^nu)

and a mass carrying the paper's Duffing-like element (Eq. 12, driven by the mass's own motion,
force A_f x' on the mass)::

    m y'' + c y' + k y + A_f x' = u,
    x'' + (c1 + c2) x' + (k1 + k2) x + k3 x^n + c3 x'^n = k1 y + c1 y'

and the rate-independent (path-time) variant of that element, written here from its definition: the
element's own time is the path s of its driving displacement (ds = rho dt, rho = sqrt(y'^2 + eps^2))::

    dx/dt = rho w,   dw/dt = rho (k1 y - (c1 + c2) w - (k1 + k2) x - k3 x^n - c3 w^n) + c1 y' - c_dir y' |w|,
    force on the mass A_f w   (w = dx/ds)

(``c_dir``: an optional directional damping, per unit path c_dir sign(y') |w|, the exact |.|, default 0).

Integration: classical RK4 with ``substeps`` steps per sample; the force u is the sampled input held
linearly between samples (as the benchmark's upsampled multisine), evaluated at every stage.
"""

from __future__ import annotations

import math

import numpy as np

#: The benchmark's constants (SI units).
BOUC_WEN = dict(m=2.0, c=10.0, k=5e4, alpha=5e4, beta=1e3, gamma=0.8, delta=-1.1, nu=1.0)


def multisine(
    n: int, fs: float, *, f_lo: float = 5.0, f_hi: float = 150.0, rms: float = 50.0, seed: int = 0
) -> np.ndarray:
    """One period of a random-phase multisine of ``n`` samples, flat amplitude on ``[f_lo, f_hi]``, scaled to
    ``rms``."""
    rng = np.random.default_rng(seed)
    k = np.arange(n // 2 + 1)
    f = k * fs / n
    U = np.zeros(k.size, dtype=complex)
    band = (f >= f_lo) & (f <= f_hi)
    U[band] = np.exp(2j * math.pi * rng.uniform(size=int(band.sum())))
    u = np.fft.irfft(U, n)
    return u * rms / np.sqrt(np.mean(u**2))


def _bw_rhs(s, u, p):
    y, v, z = s
    m, c, k = p["m"], p["c"], p["k"]
    a, b, g, dl, nu = p["alpha"], p["beta"], p["gamma"], p["delta"], p["nu"]
    az = abs(z)
    zdot = a * v - b * (g * abs(v) * az ** (nu - 1) * z + dl * v * az**nu)
    return np.array([v, (u - c * v - k * y - z) / m, zdot])


def _dl_rhs(s, u, p):
    y, v, x, w = s
    n = p["n"]
    force = p["A_f"] * w
    acc = (u - p["c"] * v - p["k"] * y - force) / p["m"]
    xacc = (
        p["k1"] * y + p["c1"] * v - (p["c1"] + p["c2"]) * w - (p["k1"] + p["k2"]) * x - p["k3"] * x**n - p["c3"] * w**n
    )
    return np.array([v, acc, w, xacc])


def _dlp_rhs(s, u, p):
    y, v, x, w = s
    n = p["n"]
    rho = math.sqrt(v * v + p["eps"] ** 2)
    acc = (u - p["c"] * v - p["k"] * y - p["A_f"] * w) / p["m"]
    wdot = (
        rho * (p["k1"] * y - (p["c1"] + p["c2"]) * w - (p["k1"] + p["k2"]) * x - p["k3"] * x**n - p["c3"] * w**n)
        + p["c1"] * v
    )
    wdot -= p.get("c_dir", 0.0) * v * abs(w)  # the directional damping (sign of y') |w| per unit path
    return np.array([v, acc, rho * w, wdot])


def _rk4(rhs, s0, u, p, dt, substeps):
    s = np.array(s0, dtype=float)
    out = np.empty((u.size, s.size))
    out[0] = s
    h = dt / substeps
    for i in range(u.size - 1):
        u0, u1 = u[i], u[i + 1]
        for j in range(substeps):
            a0 = j / substeps
            ua, um, ub = (u0 + (u1 - u0) * (a0 + f / substeps) for f in (0.0, 0.5, 1.0))
            k1 = rhs(s, ua, p)
            k2 = rhs(s + 0.5 * h * k1, um, p)
            k3 = rhs(s + 0.5 * h * k2, um, p)
            k4 = rhs(s + h * k3, ub, p)
            s = s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out[i + 1] = s
    return out


def simulate_bouc_wen(u, fs: float = 750.0, params: dict | None = None, *, substeps: int = 20, s0=(0, 0, 0)):
    """States ``(n, 3)``: displacement y [m], velocity y' [m/s], hysteretic force z [N]."""
    return _rk4(_bw_rhs, s0, np.asarray(u, dtype=float), {**BOUC_WEN, **(params or {})}, 1.0 / fs, substeps)


def simulate_duffing_like_structure(u, fs: float, params: dict, *, substeps: int = 20, s0=(0, 0, 0, 0)):
    """States ``(n, 4)``: y, y', the element's x, x' (force on the mass ``A_f x'``)."""
    return _rk4(_dl_rhs, s0, np.asarray(u, dtype=float), params, 1.0 / fs, substeps)


def simulate_path_structure(u, fs: float, params: dict, *, substeps: int = 20, s0=(0, 0, 0, 0)):
    """States ``(n, 4)`` of a mass carrying the path-time element: y, y', x, w = dx/ds (force ``A_f w``);
    ``params`` holds m, c, k, c1, c2, c3, k1, k2, k3, A_f, n and eps (and optionally c_dir)."""
    return _rk4(_dlp_rhs, s0, np.asarray(u, dtype=float), params, 1.0 / fs, substeps)


def path_element_loop(amplitude: float, params: dict, *, cycles: int = 3, per_cycle: int = 400, substeps: int = 10):
    """The path-time element driven by d = amplitude sin(theta), integrated in the phase theta (no time, no
    rate: ds = |amplitude cos theta| dtheta, the limit eps -> 0): ``(theta, d, y = A_f w)`` at
    ``per_cycle`` phases per cycle. The statement of rate independence: a drive at any frequency gives
    this loop."""
    A, n = amplitude, params["n"]

    def rhs(s, theta, p):
        x, w = s
        dth, rate = A * math.cos(theta), abs(A * math.cos(theta))
        wdot = (
            rate
            * (
                p["k1"] * A * math.sin(theta)
                - (p["c1"] + p["c2"]) * w
                - (p["k1"] + p["k2"]) * x
                - p["k3"] * x**n
                - p["c3"] * w**n
            )
            + p["c1"] * dth
        )
        return np.array([rate * w, wdot])

    theta = np.arange(cycles * per_cycle + 1) * (2 * math.pi / per_cycle)
    s = np.zeros(2)
    out = np.empty((theta.size, 2))
    out[0] = s
    h = theta[1] / substeps
    for i in range(theta.size - 1):
        for j in range(substeps):
            t0 = theta[i] + j * h
            k1 = rhs(s, t0, params)
            k2 = rhs(s + 0.5 * h * k1, t0 + 0.5 * h, params)
            k3 = rhs(s + 0.5 * h * k2, t0 + 0.5 * h, params)
            k4 = rhs(s + h * k3, t0 + h, params)
            s = s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out[i + 1] = s
    return theta, A * np.sin(theta), params["A_f"] * out[:, 1]
