"""An independent generator of friction-damper records with linkage play (numpy only; no duffsym import).

The device, as the real banded friction damper with a loose linkage is built: an actuator moves along ``a(t)``
(the measured displacement), a linkage with a gap of half-width ``h`` connects it to a friction brake, and the
brake is an elasto-plastic (Jenkins) element: a contact stiffness ``k`` in series with a Coulomb slider of level
``F_c``. With ``e = a - s`` (``s`` the slider position) the force is

    F = k dz(e, h),   dz(e, h) = sign(e) max(|e| - h, 0),

and the slider moves only as far as keeps ``|F| <= F_c``: ``e`` is the stop operator of ``a`` with threshold
``r = h + F_c / k`` (exact, evaluated on a grid ``substeps`` times finer than the samples). A viscous term
``c a'`` acts in parallel. The load cell adds a zero offset and white noise; an optional zero-phase moving
average stands for a pre-filter.

After each reversal the force falls along the contact stiffness to zero, stays at zero while the actuator crosses
the gap (travel ``2h``), and rises along the same stiffness to the opposite sliding level: the zero-force plateaus
of the real records.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FrictionPlay:
    """The device's constants (units: in, kip, s as in the real records)."""

    k: float = 30.0
    h: float = 0.1
    F_c: float = 2.2
    c: float = 0.02
    offset: float = 0.0


def stop_gap_force(a: np.ndarray, dev: FrictionPlay) -> np.ndarray:
    """The force of the gap + Jenkins element along the actuator path ``a`` (exact stop operator)."""
    r = dev.h + dev.F_c / dev.k
    e = 0.0
    out = np.empty_like(a)
    prev = a[0]
    for i, ai in enumerate(a):
        e = min(max(e + ai - prev, -r), r)
        prev = ai
        out[i] = dev.k * np.sign(e) * max(abs(e) - dev.h, 0.0)
    return out


def generate(
    dev: FrictionPlay = FrictionPlay(),
    *,
    amplitude: float = 1.0,
    freq: float = 0.5,
    cycles: float = 6.0,
    rate: float = 128.0,
    noise: float = 0.01,
    smooth: int = 0,
    seed: int = 0,
    substeps: int = 20,
    second: float = 0.0,
):
    """``(t, a, y, y_clean)``: a sine of ``amplitude`` at ``freq`` (plus a ``second`` fraction of its third
    harmonic) through the device, sampled at ``rate``; ``noise`` is relative to the force's RMS."""
    rng = np.random.default_rng(seed)
    n = int(round(cycles * rate / freq)) + 1
    t = np.arange(n) / rate
    tf = np.arange((n - 1) * substeps + 1) / (rate * substeps)
    w = 2 * np.pi * freq
    af = amplitude * (np.sin(w * tf) + second * np.sin(3 * w * tf + 0.7))
    vf = amplitude * w * (np.cos(w * tf) + 3 * second * np.cos(3 * w * tf + 0.7))
    yf = stop_gap_force(af, dev) + dev.c * vf
    a, y_clean = af[::substeps], yf[::substeps]
    y = y_clean + dev.offset + noise * float(np.std(y_clean)) * rng.standard_normal(n)
    if smooth > 1:
        y = np.convolve(y, np.ones(smooth) / smooth, mode="same")
    return t, a, y, y_clean
