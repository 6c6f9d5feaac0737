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

Real records are not shipped (third-party data); ``data/README.md`` says how the README reaches one.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DT = 0.005
VOLTAGE = 0.4


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
    tj = HERE / "synthetic_truth.json"
    tj.write_text(json.dumps(truth, indent=2, sort_keys=True) + "\n")
    written.append(tj)
    return written


if __name__ == "__main__":
    for path in main():
        print(f"wrote {path.relative_to(HERE.parent)}")
