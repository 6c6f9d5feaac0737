"""An independent generator of MR-damper records: effects placed where the physics acts.

Written from the paper's equations, *not* from duffsym: this module imports numpy (and scipy for
the optional low-pass filter) only, so that the diagnosis can be tested and benchmarked on data
its own model code did not make. One module serves the tests (``tests/test_independent_sim.py``,
``tests/test_diagnose_independent.py``) and ``benchmarks/bench_diagnose.py``.

The device
----------
An actuator moves along ``a(t)`` (the measured displacement ``d`` is the actuator's LVDT). The
piston follows it through a joint that may have play: the piston position ``p`` is the *exact*
play operator of ``a`` (half-width ``backlash``), computed on the fine integration grid. The fluid
is the paper's normalized Eq. 12, driven by the piston:

    x'' + (c1 + c2) x' + (k1 + k2) x + k3 x^n + c3 x'^n + mu x'/sqrt(x'^2 + eps^2) = k1 p + c1 p'

(the last term on the left: Coulomb-like friction inside the fluid model, on x'; eps = 0.005)
and the fluid force is ``A_f x'`` (times ``1 + a sign(x')`` with an asymmetry: rod-side vs
piston-side areas). On the piston act, besides the fluid force: seal friction
``F_c tanh(p'/eps_s)`` (on the *piston* velocity), piston inertia ``m_p p''`` and the gas
accumulator ``F_0 + k_g p`` (on the piston displacement). The load cell measures their sum through
a first-order lag ``tau_lag`` (sensor/filter dynamics), with a zero offset, an optional drift in
time, white noise, and optionally a zero-phase pre-filter (moving average or Butterworth low-pass)
as in published data sets. A channel delay makes the force respond to ``a(t - tau_delay)``.

Integration: classical RK4 with ``substeps`` (>= 20) steps per sample; the inputs are analytic
(sums of sinusoids), evaluated at every stage; the play operator is evaluated on the half-step grid.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: Table 2 of the paper (3 kN MR damper, 2 Hz): voltage -> c1, c2, c3, k1, k2, k3, n, A_f.
TABLE2 = {
    0.0: (10, 100, 350, 50, 800, 0, 5, 0.25),
    0.2: (10, 10, 330, 40, 650, 0, 5, 1.0),
    0.3: (10, 10, 320, 36, 520, 0, 5, 1.4),
    0.4: (10, 10, 320, 34, 480, 0, 5, 1.6),
    0.5: (10, 10, 280, 33, 470, 0, 5, 1.7),
    0.6: (10, 10, 280, 32, 450, 0, 5, 1.8),
    0.8: (10, 10, 250, 30, 400, 0, 5, 2.0),
}
PARAM_NAMES = ("c1", "c2", "c3", "k1", "k2", "k3", "n", "A_f")


def table2(voltage: float) -> dict:
    """The paper's Table 2 row as a dict."""
    return dict(zip(PARAM_NAMES, map(float, TABLE2[voltage])))


# ---------------------------------------------------------------------------------------------- inputs
@dataclass(frozen=True)
class SumOfSines:
    """a(t) = sum_i A_i sin(2 pi f_i t + phi_i), with exact derivatives."""

    amps: tuple
    freqs: tuple
    phases: tuple

    def __call__(self, t, order: int = 0):
        t = np.asarray(t, dtype=float)
        out = np.zeros_like(t)
        for A, f, ph in zip(self.amps, self.freqs, self.phases):
            w = 2 * math.pi * f
            out += A * w**order * np.sin(w * t + ph + order * math.pi / 2)
        return out

    @property
    def period(self) -> float:
        return 1.0 / min(self.freqs)


def make_input(kind: str, rng: np.random.Generator) -> SumOfSines:
    """A unit-stroke sine (1.5-2.5 Hz), a 6-line random-phase multisine (0.5-4 Hz, RMS 0.6) or a
    band-limited random input (60 lines 0.1-4 Hz, Rayleigh amplitudes, RMS 0.6)."""
    if kind == "sine":
        return SumOfSines((float(rng.uniform(0.8, 1.2)),), (float(rng.choice([1.5, 2.0, 2.5])),), (0.0,))
    if kind == "multisine":
        f = np.linspace(0.5, 4.0, 6)
        amps = np.full(6, 0.6 * math.sqrt(2 / 6))
    elif kind == "random":
        f = np.linspace(0.1, 4.0, 60)
        amps = rng.rayleigh(1.0, f.size)
        amps *= 0.6 / math.sqrt(0.5 * np.sum(amps**2))
    else:
        raise ValueError(f"input kind must be sine, multisine or random; got {kind!r}")
    ph = rng.uniform(0, 2 * math.pi, f.size)
    return SumOfSines(tuple(map(float, amps)), tuple(map(float, f)), tuple(map(float, ph)))


# ---------------------------------------------------------------------------------------------- physics
@dataclass
class Physics:
    """Everything the device does besides Eq. 12 (zeros: absent)."""

    backlash: float = 0.0  # half-width of the play between actuator and piston (input units)
    internal_friction: float = 0.0  # mu, on the fluid velocity x' (x'' units)
    internal_friction_eps: float = 0.005
    seal_friction: float = 0.0  # F_c, on the piston velocity (force units)
    seal_friction_eps: float = 0.0  # eps_s (input units / s); 0: 1 % of max |a'|
    inertia: float = 0.0  # m_p, on the piston acceleration
    gas_preload: float = 0.0  # F_0
    gas_stiffness: float = 0.0  # k_g, on the piston displacement
    asymmetry: float = 0.0  # a: force (1 + a sign x')
    lag: float = 0.0  # tau of the load cell (s)
    delay: float = 0.0  # channel delay (s): the force responds to a(t - delay)
    offset: float = 0.0  # load-cell zero error
    drift: float = 0.0  # load-cell drift (force units / s)
    damping_drift: float = 0.0  # relative fall of c1, c3 over the record (warming fluid; not catalogued)
    d_offset: float = 0.0  # displacement-sensor zero error (benign: the model absorbs it)


def play(a: np.ndarray, h: float, p0: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The exact play operator: p_k = min(max(p_{k-1}, a_k - h), a_k + h); and whether engaged."""
    p = np.empty_like(a)
    prev = a[0] if p0 is None else p0
    for k in range(a.size):
        prev = min(max(prev, a[k] - h), a[k] + h)
        p[k] = prev
    engaged = np.abs(np.abs(a - p) - h) <= 1e-12 * max(1.0, float(np.max(np.abs(a))))
    return p, engaged


def simulate_device(params: dict, phys: Physics, inp: SumOfSines, t: np.ndarray, *, substeps: int = 20):
    """Noise-free measured force at times ``t`` (uniform), by RK4 with ``substeps`` steps per sample.

    Returns ``(force, extras)`` with the piston path and fluid velocity on the sample grid.
    """
    if substeps < 20:
        raise ValueError("the independent generator integrates with at least 20 substeps per sample")
    c1, c2, c3, k1, k2, k3 = (float(params[k]) for k in ("c1", "c2", "c3", "k1", "k2", "k3"))
    n, Af = int(params["n"]), float(params["A_f"])
    t = np.asarray(t, dtype=float)
    dt = float(t[1] - t[0])
    h = dt / substeps
    tf = t[0] + 0.5 * h * np.arange(2 * substeps * (t.size - 1) + 1)  # half-step grid
    ts = tf - phys.delay
    a, a1, a2 = inp(ts), inp(ts, 1), inp(ts, 2)
    if phys.backlash > 0:
        p, eng = play(a, phys.backlash)
        p1, p2 = np.where(eng, a1, 0.0), np.where(eng, a2, 0.0)
    else:
        p, p1, p2 = a, a1, a2
    T = float(t[-1] - t[0]) or 1.0
    eps_s = phys.seal_friction_eps or 0.01 * float(np.max(np.abs(a1)))

    def rhs(j, s):
        # states x, u = x' - c1(t) p (so that the jump of p' at an engagement of the play does not
        # enter the integration: the forcing is p, continuous) and the load-cell state z
        x, u, z = s
        scale = 1 - phys.damping_drift * (tf[j] - t[0]) / T
        cc1, cc3 = c1 * scale, c3 * scale
        v = u + cc1 * p[j]
        acc = k1 * p[j] - (cc1 + c2) * v - (k1 + k2) * x - k3 * x**n - cc3 * v**n
        acc += c1 * phys.damping_drift / T * p[j]  # -(d c1/dt) p
        if phys.internal_friction:
            acc -= phys.internal_friction * v / math.sqrt(v * v + phys.internal_friction_eps**2)
        f = piston_force(j, v)
        dz = (f - z) / phys.lag if phys.lag > 0 else 0.0
        return np.array([v, acc, dz])

    def velocity(j, s):
        return s[1] + c1 * (1 - phys.damping_drift * (tf[j] - t[0]) / T) * p[j]

    def piston_force(j, v):
        f = Af * v * (1 + phys.asymmetry * math.copysign(1.0, v)) if phys.asymmetry else Af * v
        f += phys.seal_friction * math.tanh(p1[j] / eps_s) if phys.seal_friction else 0.0
        f += phys.inertia * p2[j] + phys.gas_preload + phys.gas_stiffness * p[j]
        return f

    s = np.array([0.0, -c1 * p[0], piston_force(0, 0.0)])
    out = np.empty(t.size)
    vel = np.empty(t.size)
    out[0] = s[2] if phys.lag > 0 else piston_force(0, 0.0)
    vel[0] = 0.0
    for k in range(t.size - 1):
        for m in range(substeps):
            j = 2 * (k * substeps + m)
            k1_ = rhs(j, s)
            k2_ = rhs(j + 1, s + 0.5 * h * k1_)
            k3_ = rhs(j + 1, s + 0.5 * h * k2_)
            k4_ = rhs(j + 2, s + h * k3_)
            s = s + h / 6 * (k1_ + 2 * k2_ + 2 * k3_ + k4_)
        J = 2 * (k + 1) * substeps
        vel[k + 1] = velocity(J, s)
        out[k + 1] = s[2] if phys.lag > 0 else piston_force(J, vel[k + 1])
    out = out + phys.offset + phys.drift * (t - t[0])
    idx = 2 * substeps * np.arange(t.size)
    return out, {"piston": p[idx], "piston_velocity": p1[idx], "x_dot": vel}


def prefilter(y: np.ndarray, kind: str | None, width: float, dt: float) -> np.ndarray:
    """Zero-phase pre-filter of the force: ``movavg`` (centred, ``width`` samples) or ``lowpass``
    (4th-order Butterworth, cut-off ``width`` Hz, forward-backward)."""
    if not kind:
        return y
    if kind == "movavg":
        w = int(width)
        ker = np.ones(w) / w
        pad = np.pad(y, (w // 2, w - 1 - w // 2), mode="edge")
        return np.convolve(pad, ker, mode="valid")
    if kind == "lowpass":
        from scipy.signal import butter, filtfilt

        b, a = butter(4, width / (0.5 / dt))
        return filtfilt(b, a, y)
    raise ValueError(f"prefilter must be movavg or lowpass; got {kind!r}")


@dataclass
class Generated:
    """A generated record: arrays plus the truth."""

    t: np.ndarray
    d: np.ndarray
    y: np.ndarray
    y_clean: np.ndarray
    noise_std: float  # std of the noise left in y (after any pre-filter)
    truth: dict = field(default_factory=dict)


def generate(params: dict, phys: Physics, inp: SumOfSines, *, dt: float = 0.005, duration: float = 4.0,
             noise: float = 0.01, rng=0, substeps: int = 20, filter_kind: str | None = None,
             filter_width: float = 5, time_jitter: float = 0.0) -> Generated:
    """A record: the device simulated, 1 % (``noise``) white noise of the clean force's RMS added,
    optionally pre-filtered; time stamps nominal (``k dt``) even when the true sampling instants
    jitter by ``time_jitter`` (std, s)."""
    rng = np.random.default_rng(rng)
    n = int(round(duration / dt)) + 1
    t = dt * np.arange(n)
    y0, extra = simulate_device(params, phys, inp, t, substeps=substeps)
    d = inp(t) + phys.d_offset
    if time_jitter:
        t_true = t + rng.normal(0, time_jitter, n)
        y0 = np.interp(t_true, t, y0)
        d = np.interp(t_true, t, d)
    sigma = noise * float(np.std(y0))
    e = rng.normal(0.0, sigma, n)
    y = prefilter(y0 + e, filter_kind, filter_width, dt)
    e_f = prefilter(e, filter_kind, filter_width, dt)
    truth = dict(params=dict(params), physics=dict(phys.__dict__), noise_std_raw=sigma,
                 filter=filter_kind, filter_width=filter_width, substeps=substeps)
    truth.update(extra_summary(extra))
    return Generated(t=t, d=d, y=y, y_clean=prefilter(y0, filter_kind, filter_width, dt),
                     noise_std=float(np.std(e_f)), truth=truth)


def extra_summary(extra: dict) -> dict:
    return {"max_piston_velocity": float(np.max(np.abs(extra["piston_velocity"]))),
            "max_x_dot": float(np.max(np.abs(extra["x_dot"])))}


# ---------------------------------------------------------------------------------------------- scenarios
#: The effects of the scenarios, by the catalogue name that should be called for each
#: (``seal-friction`` and ``coulomb-friction`` are the piston-side and fluid-side frictions).
EFFECTS = ("force-offset", "gas-accumulator", "inertia", "coulomb-friction", "seal-friction", "asymmetry",
           "output-lag", "input-delay", "backlash")
ROWS = (0.2, 0.3, 0.4, 0.5, 0.6, 0.8)
KINDS = ("sine", "multisine", "random")


def physics_for(effects, rng: np.random.Generator, peak: float, stroke: float, acc: float) -> Physics:
    """Random magnitudes of each effect in ``effects``, from ranges of real dampers relative to the
    clean record's peak force ``peak``, input amplitude ``stroke`` and peak acceleration ``acc``."""
    ph = Physics()
    u = rng.uniform
    for e in effects:
        if e == "force-offset":
            ph.offset = float(rng.choice([-1, 1]) * u(0.06, 0.15) * peak)
        elif e == "gas-accumulator":
            ph.gas_preload = float(u(0.03, 0.08) * peak)
            ph.gas_stiffness = float(u(0.06, 0.15) * peak / stroke)
        elif e == "inertia":
            ph.inertia = float(u(0.06, 0.12) * peak / acc)
        elif e == "coulomb-friction":
            ph.internal_friction = float(u(12.0, 25.0))
        elif e == "seal-friction":
            ph.seal_friction = float(u(0.05, 0.10) * peak)
        elif e == "asymmetry":
            ph.asymmetry = float(rng.choice([-1, 1]) * u(0.10, 0.20))
        elif e == "output-lag":
            ph.lag = float(u(0.006, 0.015))
        elif e == "input-delay":
            ph.delay = float(u(0.006, 0.015))
        elif e == "backlash":
            ph.backlash = float(u(0.03, 0.07) * stroke)
        elif e == "drift":
            ph.damping_drift = 0.5
        elif e != "clean":
            raise ValueError(f"unknown effect {e!r}; choose from {EFFECTS + ('clean', 'drift')}")
    return ph


def scenario(effects, seed: int, *, kind: str | None = None, voltage: float | None = None, noise: float = 0.01,
             filter_kind: str | None = None, filter_width: float = 5, dt: float = 0.005, duration: float = 4.0,
             substeps: int = 20) -> Generated:
    """A record with ``effects`` (a name or a tuple of names; "clean", "drift") hidden, the Table 2
    row (perturbed by +-10 %), input kind and magnitudes drawn from ``seed``."""
    effects = (effects,) if isinstance(effects, str) else tuple(effects)
    rng = np.random.default_rng(7919 * seed + sum(map(ord, "+".join(effects))))
    volt = ROWS[seed % len(ROWS)] if voltage is None else voltage
    kind = KINDS[seed % len(KINDS)] if kind is None else kind
    params = table2(volt)
    for k in ("c1", "c2", "c3", "k1", "k2"):
        params[k] *= float(rng.uniform(0.9, 1.1))
    inp = make_input(kind, rng)
    t = dt * np.arange(int(round(duration / dt)) + 1)
    clean, _ = simulate_device(params, Physics(), inp, t, substeps=substeps)
    stroke = float(np.max(np.abs(inp(t))))
    acc = float(np.max(np.abs(inp(t, 2))))
    phys = physics_for(effects, rng, float(np.max(np.abs(clean))), stroke, acc)
    g = generate(params, phys, inp, dt=dt, duration=duration, noise=noise, rng=rng, substeps=substeps,
                 filter_kind=filter_kind, filter_width=filter_width)
    g.truth.update(effects=list(effects), voltage=volt, kind=kind, seed=seed, period=inp.period)
    return g
