"""Make the synthetic example records of ``data/`` (the README's quick start uses them).

    python data/make_examples.py            # rewrites the files below, deterministically (fixed seeds)

Every record is simulated by duffsym from the MR damper model of Tu, Lin & Cheng (Eq. 12, n = 5)
with the paper's Table 2 parameters at 0.4 V, sampled at dt = 0.005 s (the paper's sampling), in
normalised units (displacement 1 = the stroke amplitude; force in the model's units). The truth
of each record (model, effects, parameters, excitation, noise, seed) is written to
``synthetic_truth.json``, so a fit can be scored against it.

- ``synthetic_sine.csv``    2 Hz unit sine, 3 s (600 samples) after 2 s of settling, 2 % noise.
- ``synthetic_random.csv``  the same damper under band-limited random displacement (0-5 Hz), 8 s
                            (1600 samples), 2 % noise: for validating a fit made on the sine.
- ``synthetic_hidden.csv``  the 2 Hz sine record of the same damper with a seal (Coulomb)
                            friction of 20 and a load-cell offset of 0.2 hidden in it, 3 s, 1 %
                            noise: for ``duffsym diagnose`` / ``duffsym ladder``.
- ``synthetic_sine.mat``    ``synthetic_sine.csv`` as a MATLAB matrix ``data`` with columns
                            displacement, force and no time column (the form of many lab
                            exports), for ``duffsym convert --format mat``.
- ``campaign_0A.csv``, ``campaign_0.5A.csv``, ``campaign_1A.csv``, ``campaign_0.75A.csv``: a campaign,
                            one damper whose coefficients depend on the coil current, measured at four
                            constant currents (3 s at 200 Hz after 1 s of settling, 1 % noise; the
                            README fits three and predicts the fourth). These are *not* made by
                            duffsym: :func:`campaign_record` integrates the written-out equations
                            with numpy alone (RK4, 10 steps per sample, exact inputs at every stage).

Real records are not shipped (third-party data); ``data/README.md`` says how the README reaches one.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DT = 0.005
VOLTAGE = 0.4
#: the campaign's device: Eq. 12 (n = 5) with c1, c2, c3, k1, k2 = theta + theta_u * u and the force scale
#: A_f (1 + A_f_u u), the field u following the coil current i through u' = -eta (u - i); per ampere
CAMPAIGN_TRUTH = dict(c1=10.0, c2=30.0, c3=330.0, k1=45.0, k2=600.0, k3=0.0, A_f=1.5, c1_u=-4.0, c2_u=-20.0,
                      c3_u=-80.0, k1_u=-15.0, k2_u=-200.0, A_f_u=0.8, eta=60.0)
#: displacement of every campaign record: sum of A sin(2 pi f t + phase) over (A, f, phase)
CAMPAIGN_SINES = ((1.0, 1.0, 0.0), (0.3, 2.3, 0.7))
CAMPAIGN_CURRENTS = (0.0, 0.5, 1.0, 0.75)  # the last is the held-out one in the README


def _records():
    from duffsym.data import synthetic_record
    from duffsym.effects import CATALOGUE, apply_effects
    from duffsym.excitation import BandLimitedRandom, Sine
    from duffsym.model.library import mr_damper
    from duffsym.model.presets import table2_params

    base = mr_damper(n=5)
    p = table2_params(VOLTAGE)
    sine = synthetic_record(base, p, Sine(1.0, 2.0), dt=DT, duration=3.0, settle=2.0, noise=0.02, rng=1,
                            name="synthetic_sine")
    rand = synthetic_record(base, p, BandLimitedRandom(rms=1 / np.sqrt(2), f_max=5.0, duration=10.0, seed=2),
                            dt=DT, duration=8.0, settle=2.0, noise=0.02, rng=3, name="synthetic_random")
    hidden_model = apply_effects(base, [CATALOGUE["coulomb-friction"], CATALOGUE["force-offset"]])
    hp = {**p, "fric_mu": 20.0, "off_y0": 0.2}
    hidden = synthetic_record(hidden_model, hp, Sine(1.0, 2.0), dt=DT, duration=3.0, settle=2.0, noise=0.01,
                              rng=4, name="synthetic_hidden")
    return {"synthetic_sine": sine, "synthetic_random": rand, "synthetic_hidden": hidden}


def campaign_record(current: float, seed: int, *, duration: float = 3.0, settle: float = 1.0,
                    noise: float = 0.01, substeps: int = 10) -> dict[str, np.ndarray]:
    """One constant-current record of the campaign device, numpy only (no duffsym code): columns
    ``time, displacement, velocity, force, current`` after ``settle`` s from rest, ``noise`` x RMS added."""
    p, n = CAMPAIGN_TRUTH, 5

    def disp(t, order=0):
        return sum(a * (2 * np.pi * f) ** order * np.sin(2 * np.pi * f * t + ph + order * np.pi / 2)
                   for a, f, ph in CAMPAIGN_SINES)

    def f(s, t):
        x, v, u = s
        c = {k: p[k] + p[k + "_u"] * u for k in ("c1", "c2", "c3", "k1", "k2")}
        acc = (-(c["c1"] + c["c2"]) * v - (c["k1"] + c["k2"]) * x - p["k3"] * x**n - c["c3"] * v**n
               + c["k1"] * disp(t) + c["c1"] * disp(t, 1))
        return np.array([v, acc, -p["eta"] * (u - current)])

    n_settle, n_keep, h = int(round(settle / DT)), int(round(duration / DT)), DT / substeps
    t = (np.arange(n_settle + n_keep) - n_settle) * DT
    s, states = np.array([0.0, 0.0, current]), np.empty((t.size, 3))
    states[0] = s
    for k in range(t.size - 1):
        for j in range(substeps):
            t0 = t[k] + j * h
            q1 = f(s, t0)
            q2 = f(s + h / 2 * q1, t0 + h / 2)
            q3 = f(s + h / 2 * q2, t0 + h / 2)
            q4 = f(s + h * q3, t0 + h)
            s = s + h / 6 * (q1 + 2 * q2 + 2 * q3 + q4)
        states[k + 1] = s
    keep = slice(n_settle, None)
    y = p["A_f"] * (1 + p["A_f_u"] * states[keep, 2]) * states[keep, 1]
    y = y + noise * float(np.sqrt(np.mean(y**2))) * np.random.default_rng(seed).standard_normal(y.size)
    tk = t[keep]
    return {"time": tk - tk[0], "displacement": disp(tk), "velocity": disp(tk, 1), "force": y,
            "current": np.full(tk.size, float(current))}


def campaign_name(current: float) -> str:
    return f"campaign_{current:g}A"


def _campaign_records() -> dict[str, dict[str, np.ndarray]]:
    return {campaign_name(c): campaign_record(c, seed=10 + k) for k, c in enumerate(CAMPAIGN_CURRENTS)}


def write_campaign(name: str, cols: dict[str, np.ndarray]) -> Path:
    """A campaign record as CSV, 7 significant digits (the files stay small; the noise is 1 %)."""
    path = HERE / f"{name}.csv"
    np.savetxt(path, np.column_stack(list(cols.values())), delimiter=",", header=",".join(cols), comments="",
               fmt="%.7g")
    return path


def _truth(rec, excitation: str) -> dict:
    m = rec.metadata
    return {"model": m["model"], "effects": m["effects"], "params": m["truth"], "excitation": excitation,
            "dt": DT, "n_samples": rec.n_times, "noise_fraction_of_rms": m["noise"], "noise_std": m["noise_std"],
            "table2_voltage": VOLTAGE}


def main() -> list[Path]:
    from scipy.io import savemat

    from duffsym.data import write_csv

    recs = _records()
    written = []
    for name, rec in recs.items():
        written.append(write_csv(rec, HERE / f"{name}.csv"))
    sine = recs["synthetic_sine"]
    mat = HERE / "synthetic_sine.mat"
    savemat(mat, {"data": np.column_stack([sine.d, sine.y])}, do_compression=True)
    written.append(mat)
    excitations = {"synthetic_sine": "sine, amplitude 1, 2 Hz, 2 s settled", "synthetic_hidden":
                   "sine, amplitude 1, 2 Hz, 2 s settled",
                   "synthetic_random": "band-limited random, RMS 1/sqrt(2), 0-5 Hz, seed 2, 2 s settled"}
    truth = {name: _truth(rec, excitations[name]) for name, rec in recs.items()}
    sines = " + ".join(f"{a:g} sin(2 pi {f:g} t + {ph:g})" for a, f, ph in CAMPAIGN_SINES)
    for name, cols in _campaign_records().items():
        written.append(write_campaign(name, cols))
        truth[name] = {"model": "mr-damper-current", "effects": [], "params": CAMPAIGN_TRUTH,
                       "excitation": f"displacement {sines}, 1 s settled; current {cols['current'][0]:g} A held",
                       "dt": DT, "n_samples": int(cols["time"].size), "noise_fraction_of_rms": 0.01,
                       "simulator": "numpy RK4 of the written-out equations (data/make_examples.py campaign_record)"}
    tj = HERE / "synthetic_truth.json"
    tj.write_text(json.dumps(truth, indent=2, sort_keys=True) + "\n")
    written.append(tj)
    return written


if __name__ == "__main__":
    for path in main():
        print(f"wrote {path.relative_to(HERE.parent)}")
