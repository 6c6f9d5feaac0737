"""An independent generator of MR-damper records whose mechanical element runs in the *path* of the drive.

Written from the equations, *not* from duffsym (numpy only; it reuses the analytic drive and command signals
of ``independent_current_sim``, numpy only too), to test ``mr-damper-current-path-viscous`` on data its own
model code did not make. The device (time derivatives; rho the regularised path rate of d):

    rho = sqrt(d'^2 + v_eps^2)
    x'  = rho v
    v'  = rho [ -(c1(u) + c2(u)) v - (k1(u) + k2(u)) x - k3 x^n - c3(u) v^n + k1(u) d ] + c1(u) d'
    u'  = -eta (u - i(t))
    y   = A_f (1 + A_f_u u) v + (c0 + c0_u u) d'     (+ white noise)

i.e. Eq. 12 read in the path time s (ds = rho dt, v = dx/ds), the field u in clock time, and a viscous force
on the piston velocity. Each theta(u) = theta + theta_u u. RK4 with ``substeps`` steps per sample, the
drive and command evaluated analytically at every stage.
"""

from __future__ import annotations

import numpy as np

from independent_current_sim import FIELD, Sines, Switching, constant, integrate  # noqa: F401  (numpy-only helpers)

#: O(1) coefficients per unit of path (drive amplitude ~0.5, velocity ~3), a transition velocity v_eps inside
#: the drive's velocity range and a viscous force comparable to the element's.
TRUTH = dict(
    c1=6.0,
    c2=3.0,
    c3=4.0,
    k1=20.0,
    k2=8.0,
    k3=0.0,
    A_f=1.5,
    c1_u=-2.0,
    c2_u=-1.0,
    c3_u=-1.5,
    k1_u=-6.0,
    k2_u=-3.0,
    A_f_u=0.8,
    eta=60.0,
    c0=0.15,
    c0_u=0.25,
    v_eps=1.0,
)


def rhs(p: dict, n: int, x, v, u, d, dd, i):
    c = {k: p[k] + p[k + "_u"] * u for k in FIELD}
    rho = np.sqrt(dd**2 + p["v_eps"] ** 2)
    dv = (
        rho * (-(c["c1"] + c["c2"]) * v - (c["k1"] + c["k2"]) * x - p["k3"] * x**n - c["c3"] * v**n + c["k1"] * d)
        + c["c1"] * dd
    )
    return rho * v, dv, -p["eta"] * (u - i)


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
    """Simulate and sample: ``{"t", "d", "d_dot", "command", "y", "y_clean", "field"}`` after ``settle`` s."""
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
    u, dd = out[keep, 2], disp(t[keep], 1)
    y_clean = p["A_f"] * (1 + p["A_f_u"] * u) * out[keep, 1] + (p["c0"] + p["c0_u"] * u) * dd
    rng = np.random.default_rng(seed)
    y = y_clean + noise * float(np.sqrt(np.mean(y_clean**2))) * rng.standard_normal(y_clean.size)
    tk = t[keep] - t[n_settle]
    return {
        "t": tk,
        "d": disp(t[keep]),
        "d_dot": dd,
        "command": command(t[keep]),
        "y": y,
        "y_clean": y_clean,
        "field": u,
    }
