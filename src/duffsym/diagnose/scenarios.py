"""Synthetic records with a hidden effect: the test bench of the diagnosis.

Each scenario simulates the MR damper model (a Table 2 row) with one catalogued effect added at a
known value — or with none (clean), or with an effect *outside* the catalogue (the damping
drifting as the fluid warms over the record) — under a sine, a multisine or a band-limited
random input, with white output noise. The truth is kept in ``record.metadata["truth"]`` and
``record.metadata["hidden"]``. Used by the tests, ``benchmarks/bench_diagnose.py`` and the
hidden-effect study.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from duffsym.data.record import Record
from duffsym.errors import ModelError
from duffsym.excitation import BandLimitedRandom, Multisine, Sine
from duffsym.model.symbols import ParamSpec

#: hidden value(s) of each catalogued effect: large enough to matter against 1 % noise at 2 Hz,
#: unit stroke (the loops of the paper), small enough to be a correction, not a new model.
HIDDEN = {
    "force-offset": {"off_y0": 0.25},
    "gas-accumulator": {"off_y0": 0.1, "gas_k": 0.25},
    "inertia": {"inertia_m": 0.003},
    "coulomb-friction": {"fric_mu": 20.0},
    "asymmetry": {"asym_a": 0.15},
    "output-lag": {"lag_tau": 0.01},
    "input-delay": {"delay_tau": 0.01},
    "input-shift": {"shift_tau": 0.004},
    "backlash": {"bl_h": 0.05},
}
#: Table 2 rows (coil voltage, V) the seeds cycle through
ROWS = (0.2, 0.3, 0.4, 0.5, 0.6, 0.8)
EXCITATIONS = ("sine", "multisine", "random")
#: relative drop of c1 and c3 over a record in the out-of-catalogue scenario
DRIFT = 0.5


@dataclass(frozen=True)
class Scenario:
    """What was hidden in a record."""

    hidden: str  # an effect name, "clean" or "drift"
    voltage: float
    excitation: str
    seed: int
    noise: float


def excitation(kind: str, seed: int, duration: float):
    """The input of a scenario: unit-stroke sine at 2 Hz, a 6-line random-phase multisine
    (0.5–4 Hz) or band-limited random input (up to 4 Hz), both of RMS 0.6."""
    if kind == "sine":
        return Sine(1.0, 2.0)
    if kind == "multisine":
        return Multisine.random_phase(0.6, 0.5, 4.0, 6, rng=seed)
    if kind == "random":
        return BandLimitedRandom(rms=0.6, f_max=4.0, duration=duration, seed=seed)
    raise ModelError(f"excitation must be one of {EXCITATIONS}; got {kind!r}")


def drifting_model(base, duration: float):
    """``base`` with c1 and c3 falling linearly by ``DRIFT`` over ``duration`` (a warming fluid):
    an effect outside the catalogue, built with the same extension mechanism (a clock state)."""
    clock = sp.Symbol("clock", real=True)
    a = ParamSpec("drift_a", "a", DRIFT / duration, 0.0, 10.0, unit="1/s", description="relative drift rate")
    subs = {}
    for name in ("c1", "c3"):
        sym = base.param(name).symbol
        subs[sym] = sym * (1 - a.symbol * clock)
    return base.extend(effect="temperature-drift", params=(a,), states=((clock, sp.Integer(1)),), substitute=subs)


def hidden_effect_record(
    hidden: str,
    seed: int = 0,
    *,
    excitation_kind: str | None = None,
    voltage: float | None = None,
    noise: float = 0.01,
    dt: float = 0.005,
    duration: float = 4.0,
) -> Record:
    """A synthetic record with ``hidden`` ("clean", "drift" or a catalogued effect) inside.

    The Table 2 row and the excitation cycle with ``seed`` unless given; the noise is white,
    ``noise`` times the RMS of the clean output.
    """
    from duffsym.data.synthetic import synthetic_record
    from duffsym.effects import CATALOGUE, apply_effects
    from duffsym.model.library import mr_damper
    from duffsym.model.presets import table2_params

    volt = ROWS[seed % len(ROWS)] if voltage is None else voltage
    kind = EXCITATIONS[seed % len(EXCITATIONS)] if excitation_kind is None else excitation_kind
    truth = table2_params(volt)
    base = mr_damper()
    if hidden == "clean":
        model = base
    elif hidden == "drift":
        model = drifting_model(base, duration)
        truth["drift_a"] = DRIFT / duration
    elif hidden in CATALOGUE:
        model = apply_effects(base, [CATALOGUE[hidden]])
        truth.update(HIDDEN[hidden])
    else:
        raise ModelError(f"hidden must be 'clean', 'drift' or one of {sorted(CATALOGUE)}; got {hidden!r}")
    rec = synthetic_record(
        model,
        truth,
        excitation(kind, seed, duration),
        dt=dt,
        duration=duration,
        noise=noise,
        rng=1000 + seed,
        name=f"{hidden}-{kind}-{volt:g}V-s{seed}",
    )
    meta = dict(rec.metadata)
    meta["hidden"] = hidden
    meta["scenario"] = Scenario(hidden, volt, kind, seed, noise).__dict__
    return rec.replace(metadata=meta)


def noise_nrmse(record: Record, part: slice = slice(None)) -> float:
    """The NRMSE that white noise alone gives on ``record[part]`` (the floor of any model)."""
    y = np.asarray(record.y)[part]
    return float(record.metadata["noise_std"]) / float(np.std(y))
