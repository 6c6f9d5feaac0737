"""Benchmark: the effect of the smoothing setting ``eps`` of the classical models (|v| ~ sqrt(v^2 + eps^2),
sign v ~ tanh(v/eps)) on their accuracy, against the exact nonsmooth law (scipy Radau of
``tests/independent_classical_sim.py``), and the cost of simulating each model (compiled RK4, substeps met).

Run from the repository root::

    python benchmarks/bench_classical_smoothing.py

It prints a table (NRMSE of duffsym's smooth model against the sharp reference, per eps, relative to the
velocity amplitude of the drive) and writes ``benchmarks/results/classical_smoothing.json``. The drives: a
two-sine damper stroke (amplitude velocity ~20 cm/s) for Bouc-Wen, Spencer, Bingham and biviscous, a slow
two-sine friction stroke (~0.6 m/s) for Dahl and LuGre (Stribeck velocity 1e-3 m/s there), 2 s at 1 kHz, the
Bingham sine phase chosen so that no sample sits exactly at a reversal.
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

import independent_classical_sim as ics  # noqa: E402

from duffsym.identify.result import nrmse  # noqa: E402
from duffsym.model import classical  # noqa: E402
from duffsym.simulate import simulate  # noqa: E402
from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)

EPS = (1e-1, 1e-2, 1e-3, 1e-4, 1e-5)
DAMPER = ics.Sines((1.0, 0.4), (2.5, 7.0), (0.3, 1.1))
FRICTION = ics.Sines((0.1, 0.03), (1.0, 3.0), (0.3, 1.1))
CASES = {
    "bouc-wen": (classical.bouc_wen, dict(c0=20.0, k0=40.0, x0=0.0, A=4e4, gamma=0.015, beta=0.01), DAMPER, None),
    "spencer": (classical.spencer, None, DAMPER, lambda t: 0.5 + 0.5 * np.sin(2 * np.pi * 1.3 * t)),
    "dahl": (classical.dahl, dict(sigma0=1e3, Fc=1.0, sigma2=0.4), FRICTION, None),
    "lugre": (classical.lugre, None, FRICTION, None),
    "bingham": (classical.bingham, None, DAMPER, None),
    "biviscous": (classical.biviscous, None, DAMPER, None),
}


def one(name: str, ctor, params, drive, cmd, t, y_ref) -> list[dict]:
    rows = []
    vmax = float(np.max(np.abs(drive(t, 1))))
    for eps in EPS:
        kw = {"eps": eps} if name in ("dahl", "lugre", "bingham", "biviscous") else {"eps": eps, "eps_z": eps}
        model = ctor(**kw)
        p = params or model.defaults()
        U = {"d": drive(t), "d_dot": drive(t, 1)}
        x0 = np.zeros(model.n_states)
        if cmd is not None:
            U["command"] = cmd(t)
            x0[-1] = cmd(np.asarray(0.0))
        simulate(model, p, t, U, x0=x0, on_failure="return")
        t0 = time.perf_counter()
        tr = simulate(model, p, t, U, x0=x0, on_failure="return")
        sec = time.perf_counter() - t0
        rows.append({"model": name, "eps": eps, "eps_over_vmax": eps / vmax, "nrmse_vs_sharp": nrmse(y_ref, tr.y),
                     "us_per_sample": sec / t.size * 1e6, "substeps_mean": float(np.mean(tr.substeps)),
                     "substeps_max": int(np.max(tr.substeps)), "method": tr.method})
    return rows


def main() -> int:
    t = np.arange(0.0, 2.0, 1e-3)
    rows = []
    for name, (ctor, params, drive, cmd) in CASES.items():
        p = params or ctor().defaults()
        t0 = time.perf_counter()
        _, y_ref = ics.simulate(name, p, t, drive, cmd, rtol=1e-9, atol=1e-10, max_step=1e-3)
        radau = time.perf_counter() - t0
        for r in one(name, ctor, params, drive, cmd, t, y_ref):
            r["radau_seconds_sharp"] = radau
            rows.append(r)
            print(f"{name:10s} eps {r['eps']:.0e} (eps/vmax {r['eps_over_vmax']:.1e})  NRMSE vs sharp "
                  f"{r['nrmse_vs_sharp']:.2e}  {r['us_per_sample']:.3f} us/sample  substeps "
                  f"{r['substeps_mean']:.1f}/{r['substeps_max']}  (sharp Radau {radau:.2f} s)")
    out = HERE / "results" / "classical_smoothing.json"
    out.write_text(json.dumps(stamp({"rows": rows}, {"cases": list(CASES)}), indent=2))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
