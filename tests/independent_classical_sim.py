"""An independent simulator of the classical hysteresis and damper models, with the exact nonsmooth laws.

Written from the papers' equations, *not* from duffsym (numpy and scipy only): |v| is ``abs``, sign is ``sign``,
so the smooth forms duffsym fits (|v| ~ sqrt(v^2 + eps^2), sign ~ tanh(v/eps)) are tested against the laws they
approximate. Parameter names are the papers' (Spencer's alpha, alpha_u = alpha_b, ...):

- Bouc-Wen (z in force units):  y = c0 v + k0 (d - x0) + z,  z' = -gamma |v| z |z|^(n-1) - beta v |z|^n + A v
- Spencer et al. 1997:           y = c1(u) y' + k1 (d - x0),
                                 y' = (alpha(u) z + c0(u) v + k0 (d - y)) / (c0(u) + c1(u)),
                                 z' = BW(v - y'),  u' = -eta (u - i),  theta(u) = theta + theta_u u
- Dahl:                          y = z + sigma2 v,  z' = sigma0 (v - |v| z / Fc)
- LuGre:                         z' = v - sigma0 |v| z / g(v),  g = Fc + (Fs - Fc) exp(-(v/vs)^2),
                                 y = sigma0 z + sigma1 z' + sigma2 v
- Bingham:                       y = fc sign(v) + c0 v + f0
- biviscous:                     y = c_po v + clip((c_pr - c_po) v, -fy, fy) + f0

The displacement is a sum of sines (exact derivative at every stage); the command a constant or a function of t.
``simulate`` runs scipy's Radau (the reference) or a fixed-step RK4.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp


@dataclass(frozen=True)
class Sines:
    """d(t) = sum_i A_i sin(2 pi f_i t + phi_i), with its exact derivative."""

    amps: tuple
    freqs: tuple
    phases: tuple

    def __call__(self, t, order: int = 0):
        t = np.asarray(t, dtype=float)
        out = np.zeros_like(t)
        for a, f, ph in zip(self.amps, self.freqs, self.phases):
            w = 2 * math.pi * f
            out = out + a * w**order * np.sin(w * t + ph + order * math.pi / 2)
        return out


def _bw(v, z, p, n):
    return -p["gamma"] * abs(v) * z * abs(z) ** (n - 1) - p["beta"] * v * abs(z) ** n + p["A"] * v


def _field(p, u, name):
    return p[name] + p.get(name + "_u", 0.0) * u


def spencer_parts(x, d, v, p, n):
    """Spencer's internal velocity y' and z' at state x = (z, y, u)."""
    z, y, u = x
    c0, c1, al = _field(p, u, "c0"), _field(p, u, "c1"), _field(p, u, "alpha")
    ydot = (al * z + c0 * v + p["k0"] * (d - y)) / (c0 + c1)
    return ydot, _bw(v - ydot, z, p, n)


def rhs(model: str, x, d, v, cmd, p, n=2):
    """dx/dt of ``model`` (exact laws)."""
    if model == "bouc-wen":
        return np.array([_bw(v, x[0], p, n)])
    if model == "spencer":
        ydot, zdot = spencer_parts(x, d, v, p, n)
        return np.array([zdot, ydot, -p["eta"] * (x[2] - cmd)])
    if model == "dahl":
        return np.array([p["sigma0"] * (v - abs(v) * x[0] / p["Fc"])])
    if model == "lugre":
        return np.array([_lugre_zdot(x[0], v, p)])
    if model in ("bingham", "biviscous"):
        return np.array([-x[0]])
    raise ValueError(model)


def _lugre_zdot(z, v, p):
    g = p["Fc"] + (p["Fs"] - p["Fc"]) * np.exp(-((v / p["vs"]) ** 2))
    return v - p["sigma0"] * np.abs(v) / g * z


def output(model: str, X, d, v, cmd, p, n=2):
    """The force at states X (n_times, n_states)."""
    X = np.atleast_2d(X)
    if model == "bouc-wen":
        return p["c0"] * v + p["k0"] * (d - p["x0"]) + X[:, 0]
    if model == "spencer":
        ydot, _ = spencer_parts(X.T, d, v, p, n)
        return _field(p, X[:, 2], "c1") * ydot + p["k1"] * (d - p["x0"])
    if model == "dahl":
        return X[:, 0] + p["sigma2"] * v
    if model == "lugre":
        return p["sigma0"] * X[:, 0] + p["sigma1"] * _lugre_zdot(X[:, 0], v, p) + p["sigma2"] * v
    if model == "bingham":
        return p["fc"] * np.sign(v) + p["c0"] * v + p["f0"]
    if model == "biviscous":
        return p["c_po"] * v + np.clip((p["c_pr"] - p["c_po"]) * v, -p["fy"], p["fy"]) + p["f0"]
    raise ValueError(model)


N_STATES = {"bouc-wen": 1, "spencer": 3, "dahl": 1, "lugre": 1, "bingham": 1, "biviscous": 1}


def simulate(
    model: str,
    p: dict,
    t,
    drive: Sines,
    command=None,
    *,
    x0=None,
    n=2,
    method="Radau",
    rtol=1e-9,
    atol=1e-10,
    max_step=None,
):
    """States and force at ``t``: scipy ``method`` (Radau by default) on the exact right-hand side."""
    t = np.asarray(t, dtype=float)
    cmd = command if callable(command) else (lambda tt, c=float(command or 0.0): c + 0.0 * tt)
    if x0 is None:
        x0 = np.zeros(N_STATES[model])
        if model == "spencer":
            x0[2] = float(cmd(np.asarray(t[0])))
    x0 = np.asarray(x0, dtype=float)

    def f(tt, x):
        return rhs(model, x, float(drive(tt)), float(drive(tt, 1)), float(cmd(np.asarray(tt))), p, n)

    step = max_step if max_step is not None else float(t[1] - t[0])
    sol = solve_ivp(f, (t[0], t[-1]), x0, method=method, t_eval=t, rtol=rtol, atol=atol, max_step=step)
    if not sol.success:
        raise RuntimeError(f"independent {method} failed: {sol.message}")
    X = sol.y.T
    y = output(model, X, drive(t), drive(t, 1), cmd(t), p, n)
    return X, y


def record(model: str, p: dict, *, duration=2.0, fs=500.0, drive: Sines, command=None, noise=0.01, seed=0, n=2):
    """(t, d, v, command, y, y_clean): a noisy record (white noise, ``noise`` x the force's std)."""
    t = np.arange(0.0, duration, 1.0 / fs)
    _, y = simulate(model, p, t, drive, command, n=n)
    rng = np.random.default_rng(seed)
    cmd = command(t) if callable(command) else np.full(t.size, float(command or 0.0))
    return t, drive(t), drive(t, 1), cmd, y + noise * np.std(y) * rng.standard_normal(t.size), y
