"""Lever measurement: compile once, call the model's functions through pointers.

Each model's explicit integrator (``integrate`` in ``codegen/_integrator_template.py``) is compiled per model,
with the right-hand side inlined four times per RK4 substep. In a ladder or a diagnosis every candidate is a new
model, and compiling dominates: py-spy over two benchmark workers running ladders (bench_discover_independent,
2026-11-28) put 63-70 % of their samples in numba's compiler, all under ``simulate_record -> _compiled_run``.

This script measures the alternative, used by ``simulate`` since 2894bf3 (``duffsym.codegen.generic``): one
integrator compiled once, which takes the model's ``rhs_ptr``, ``jac_ptr`` and ``output_ptr`` as first-class
functions (numba ``FunctionType`` arguments, called through pointers), so that a new model compiles only its three
small functions (on import of its generated module, counted in the generic arm's time). For each model it reports, in fresh processes with an empty numba
cache (one process per arm):

- the compile time of the model's own integrator (first call of ``integrate``) against the compile time of its
  three functions with explicit signatures (the shared integrator compiled once, reported apart);
- the run time of one free run (best of ``--repeat``);
- the largest difference between the two free runs, relative to max|y| (the same RK4 with the same adaptive
  substeps; fastmath and the order of operations differ).

    nice -n 10 python benchmarks/lever_generic_integrator.py [--samples 3000] [--repeat 20]

Writes ``benchmarks/results/lever_generic_integrator.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)

ROOT = Path(__file__).resolve().parents[1]
MODELS = (
    (),
    ("force-offset",),
    ("seal-friction",),
    ("gas-accumulator",),
    ("cubic-damping", "parallel-damping"),
    ("backlash",),
    ("output-lag",),
    ("seal-friction", "coulomb-friction", "asymmetry"),
)

ARM = '''
import importlib, json, sys, time
import numpy as np
sys.path.insert(0, sys.argv[1])
arm, n_models, repeat = sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
data = np.load(sys.argv[1] + "/inputs.npz")
out = {"arm": arm, "models": []}
t0 = time.perf_counter()
import numba
out["import_numba_s"] = time.perf_counter() - t0
if arm == "generic":
    t0 = time.perf_counter()
    from duffsym.codegen import generic as G  # the shared integrator (compiled here: the cache is fresh)
    out["shared_integrator_compile_s"] = time.perf_counter() - t0
for i in range(n_models):
    U, t, x0, p = data[f"U{i}"], data["t"], data[f"x0{i}"], data[f"p{i}"]
    for a in (U, t, x0, p):
        a.setflags(write=False)
    if arm != "generic":  # the import compiles rhs_ptr, jac_ptr, output_ptr: counted for the generic arm only
        mod = importlib.import_module(f"gen_{i}")
    tic = time.perf_counter()
    if arm == "generic":
        mod = importlib.import_module(f"gen_{i}")
    X = np.empty((t.size, mod.N_STATES)); Y = np.empty(t.size); M = np.zeros(t.size - 1, dtype=np.int64)
    if arm == "generic":
        run = lambda: G.integrate(mod, t, U, x0, p, G.Settings(0, 1.0, 2000, False, 1e12), X, Y, M)
    else:
        run = lambda: mod.integrate(t, U, x0, p, 0, 1.0, 2000, False, 1e12, X, Y, M)
    status = run()
    first = time.perf_counter() - tic
    best = min((lambda a: (run(), time.perf_counter() - a)[1])(time.perf_counter()) for _ in range(repeat))
    np.save(sys.argv[1] + f"/Y_{arm}_{i}.npy", Y)
    out["models"].append({"compile_and_first_run_s": first, "run_s": best, "status": [int(s) for s in status],
                          "substeps": int(M.sum())})
print(json.dumps(out))
'''


def _prepare(folder: Path, n: int) -> list[dict]:
    import numpy as np

    from duffsym.codegen.compiled import generate_source
    from duffsym.data.record import Record
    from duffsym.effects import CATALOGUE, apply_effects
    from duffsym.model.library import mr_damper

    t = np.arange(n) * 0.002
    d = np.sin(2 * np.pi * 1.5 * t) + 0.3 * np.sin(2 * np.pi * 4.1 * t)
    rec = Record(t=t, d=d, y=np.cos(t), name="lever", source="lever")
    arrays: dict = {"t": t}
    rows = []
    for i, effects in enumerate(MODELS):
        model = apply_effects(mr_damper(), [CATALOGUE[e] for e in effects])
        (folder / f"gen_{i}.py").write_text(generate_source(model))
        p = np.array([float(s.default) for s in model.params])
        arrays[f"p{i}"] = p
        arrays[f"x0{i}"] = np.zeros(model.n_states)
        arrays[f"U{i}"] = np.ascontiguousarray(rec.input_matrix(model), dtype=float)
        rows.append({"model": " + ".join(("mr-damper",) + effects), "n_states": model.n_states,
                     "n_params": len(model.params)})
    np.savez(folder / "inputs.npz", **arrays)
    (folder / "arm.py").write_text(ARM)
    return rows


def main(argv=None) -> int:
    import numpy as np

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=3000)
    ap.add_argument("--repeat", type=int, default=20)
    a = ap.parse_args(argv)
    folder = Path(tempfile.mkdtemp(prefix="lever-generic-"))
    rows = _prepare(folder, a.samples)
    arms = {}
    for arm in ("specialized", "generic"):
        env = {**os.environ, "NUMBA_CACHE_DIR": str(folder / f"numba-{arm}"), "PYTHONDONTWRITEBYTECODE": "1"}
        tic = time.perf_counter()
        res = subprocess.run([sys.executable, str(folder / "arm.py"), str(folder), arm, str(len(rows)), str(a.repeat)],
                             env=env, capture_output=True, text=True, check=True)
        arms[arm] = json.loads(res.stdout.strip().splitlines()[-1])
        arms[arm]["wall_s"] = time.perf_counter() - tic
    for i, row in enumerate(rows):
        s, g = arms["specialized"]["models"][i], arms["generic"]["models"][i]
        ys, yg = np.load(folder / f"Y_specialized_{i}.npy"), np.load(folder / f"Y_generic_{i}.npy")
        row.update(specialized=s, generic=g,
                   rel_diff=float(np.max(np.abs(ys - yg)) / (np.max(np.abs(ys)) or 1.0)),
                   compile_ratio=s["compile_and_first_run_s"] / g["compile_and_first_run_s"],
                   run_ratio=g["run_s"] / s["run_s"])
        print(f"{row['model']:48s} compile {s['compile_and_first_run_s']:6.2f} s vs {g['compile_and_first_run_s']:5.2f} s "
              f"({row['compile_ratio']:4.1f}x less); run {1e3 * s['run_s']:6.2f} ms vs {1e3 * g['run_s']:6.2f} ms "
              f"({row['run_ratio']:.2f}x); max rel diff {row['rel_diff']:.1e}", flush=True)
    print(f"shared integrator compiled once: {arms['generic']['shared_integrator_compile_s']:.2f} s; "
          f"arm wall: specialized {arms['specialized']['wall_s']:.1f} s, generic {arms['generic']['wall_s']:.1f} s")
    out = ROOT / "benchmarks" / "results" / "lever_generic_integrator.json"
    doc = {"load": os.getloadavg(), "samples": a.samples, "arms": {k: {kk: vv for kk, vv in v.items() if kk != "models"}
                                                                 for k, v in arms.items()}, "rows": rows}
    out.write_text(json.dumps(stamp(doc, a), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
