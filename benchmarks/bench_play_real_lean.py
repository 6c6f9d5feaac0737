"""Lean play fit on a real friction damper record (issue 22 measurements): base fit, then base + play (smooth form
first, then the sharp one) on the record decimated by q, held-out NRMSE of the free runs at that rate.

    NOMASK=1 FIXH=0.10 python benchmarks/bench_play_real_lean.py 0.5Hz30lbtension1amplitude 16 [seal-friction]

Results of the issue-22 runs: benchmarks/results/play_real_lean.json.
"""
import sys, time, json
import numpy as np
from duffsym.data.loaders import load_friction_damper_json
from duffsym.diagnose.prepare import decimate_record
from duffsym.diagnose.search import _fit, _part, split_record, with_default_af
from duffsym.effects import CATALOGUE, apply_effects
from duffsym.effects.inputs import plateau_half_width
from duffsym.identify.initial import auto_mask
from duffsym.identify.result import nrmse
from duffsym.model.library import mr_damper
from duffsym.simulate import simulate_record
name, q = sys.argv[1], int(sys.argv[2])
import os; NOMASK = os.environ.get("NOMASK") == "1"
rec0 = load_friction_damper_json(f"/work/shared/data/external/friction_damper_brfd_artslab/{name}.json")
rec = decimate_record(rec0, q)
mask, info = auto_mask(rec)
k = split_record(rec, 0.3); rf = _part(rec, k); y = np.asarray(rec.y)
t0, c0 = time.perf_counter(), time.process_time()
m0 = mr_damper(); fx = with_default_af(m0, None, rf)
b = _fit(m0, rf, fx, None, mask=None if NOMASK else mask[:k], bound_restart=True)
yb = simulate_record(m0, b.params, rec, x0=b.x0[0], on_failure="return").y
print("base", b.status, nrmse(y[k:], yb[k:]), time.perf_counter() - t0, flush=True)
extra = sys.argv[3].split(",") if len(sys.argv) > 3 else []
m1 = apply_effects(m0, [CATALOGUE["backlash"]] + [CATALOGUE[e] for e in extra])
h0 = plateau_half_width(rec0)
start = {**b.params, "bl_h": h0}
if "seal-friction" in extra:
    vmax = float(np.max(np.abs(rec.velocity())))
    start.update(seal_F=0.9 * float(np.median(np.abs(y))), seal_eps=0.05 * vmax)
import dataclasses
soft = apply_effects(m0, [dataclasses.replace(CATALOGUE["backlash"], kappa=2.0, offset=0.5)] + [CATALOGUE[e] for e in extra])
FIXH = os.environ.get("FIXH")
if FIXH:
    fx = {**fx, "bl_h": float(FIXH)}
fs = _fit(soft, rf, fx, start, mask=None if NOMASK else mask[:k], max_iter=300, flags=False)
print("smooth", fs.status, fs.params["bl_h"], time.perf_counter() - t0, flush=True)
fr = _fit(m1, rf, fx, {**start, **fs.params}, mask=None if NOMASK else mask[:k], max_iter=300, flags=False)
tr = simulate_record(m1, fr.params, rec, x0=fr.x0[0], on_failure="return")
yp = tr.y if tr.success else None
secs, cpu = time.perf_counter() - t0, time.process_time() - c0
print(json.dumps(dict(record=name, q=q, rate=1 / rec.dt, n_fit=k, n=rec.n_times, seconds=secs, cpu=cpu,
      base=dict(status=b.status, heldout=nrmse(y[k:], yb[k:]), fit=nrmse(y[:k], yb[:k])),
      play=dict(status=fr.status, success=fr.success, heldout=nrmse(y[k:], yp[k:]) if yp is not None else None,
                fit=nrmse(y[:k], yp[:k]) if yp is not None else None, h=fr.params["bl_h"], se=fr.stderr.get("bl_h")),
      h_start=h0, mask_width=info["median_displacement_width"])), flush=True)
np.savez(f"/tmp/lad/play_lean_{name}_q{q}_{'+'.join(extra)}.npz", t=rec.t, d=rec.d, y=y, yb=yb, yp=yp if yp is not None else y * np.nan, k=k, h=fr.params["bl_h"])
