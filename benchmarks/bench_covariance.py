"""The standard errors' cost and their agreement, this checkout against an older one in the same run (issue 24).

For each case (a shipped record and real records of ``$DUFFSYM_EXTERNAL_DATA``) a fit (from the model's start;
the command start for a command record), then ``--repeat`` fits from its optimum, their
standard errors computed (the Laplace covariance, :mod:`duffsym.identify.covariance`), with this checkout's
code and with ``--before``'s (a checkout of the older code; its ``src`` is put on ``PYTHONPATH``, this checkout's
venv runs both). The solver code is the same in both, so both fits end at the same parameters; the table gives
the seconds of the standard errors (``timings["stderr"]``, best of ``--repeat``) and the largest relative
difference of the standard errors between the two.

    DUFFSYM_EXTERNAL_DATA=../shared/data/external python benchmarks/bench_covariance.py --before /tmp/wt/base

Results: ``benchmarks/results/covariance_forward.json``.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)

ROOT = Path(__file__).resolve().parents[1]
#: IPOPT iterations of each fit: the standard errors are computed where the fit stops, and both versions stop at
#: the same point (the solver is the same)
MAX_ITER = 150


def _cases(ext: Path) -> dict:
    """name -> (how to read the record, model name, fixed parameters)."""
    utfsm = sorted((ext / "mr_damper_utfsm_quiroz2022" / "sinusoidal_preprocessed").glob("*.txt"))
    brfd = ext / "friction_damper_brfd_artslab" / "0.5Hz30lbtension1amplitude.json"
    return {
        "shipped sine, mr-damper": (("csv", str(ROOT / "data" / "synthetic_sine.csv")), "mr-damper", {}),
        "Dyke 6 s slice, mr-damper-current": (
            ("dyke", str(ext / "mr_damper_dyke_nees1996" / "ranran_50_converted.csv")),
            "mr-damper-current",
            {"k3": 0.0, "A_f": 1908.0},
        ),
        "UTFSM first test, mr-damper": (("utfsm", str(utfsm[0])), "mr-damper", {}),
        "BRFD 0.5 Hz, mr-damper-path": (("brfd", str(brfd)), "mr-damper-path", {}),
    }


def _read(how):
    import numpy as np

    from duffsym.data import Record
    from duffsym.data.decimate import decimate_record, prepare_for_fit
    from duffsym.data.loaders import load_friction_damper_json, load_mr_damper_utfsm, read_csv

    kind, path = how
    if kind == "csv":
        return read_csv(path)
    if kind == "utfsm":
        return prepare_for_fit(load_mr_damper_utfsm(path))[1]
    if kind == "brfd":
        return prepare_for_fit(load_friction_damper_json(path))[1]
    rows = np.genfromtxt(path, delimiter=",", names=True)
    sel = rows[rows["t"] < rows["t"][0] + 6.0][::6]  # 6 s at 500 Hz, then at 250 Hz as the diagnosis decimates it
    rec = Record(t=sel["t"] - sel["t"][0], d=sel["D"], y=sel["F"], d_dot=sel["V"], command=sel["Y"],
                 command_name="voltage", name="dyke-6s")
    return decimate_record(rec, 2)


def worker(out: str, repeat: int) -> None:
    """Fit every case and write its parameters, standard errors and their seconds to ``out`` (JSON)."""
    from duffsym.identify import Problem, fit
    from duffsym.identify.initial import command_start
    from duffsym.model.library import get_model

    rows = {}
    for name, (how, model_name, fixed) in _cases(Path(os.environ["DUFFSYM_EXTERNAL_DATA"])).items():
        rec, model = _read(how), get_model(model_name)
        problem = Problem(model, rec, fixed=fixed)
        start = command_start(rec, model, fixed=fixed) if rec.command is not None else None
        first = fit(problem, start, max_iter=MAX_ITER, compute_stderr=False, bound_restart=False)
        runs = [fit(problem, first.params, max_iter=MAX_ITER, bound_restart=False) for _ in range(repeat)]
        rows[name] = {"n": rec.n_times, "params": runs[0].params, "stderr": runs[0].stderr,
                      "status": str(runs[0].status), "seconds": min(r.timings["stderr"] for r in runs)}
        print(f"{name:40s} n {rec.n_times:5d} stderr {rows[name]['seconds']:6.2f} s", flush=True)
    Path(out).write_text(json.dumps(rows))


def _rel(a: float, b: float) -> float:
    return 0.0 if a == b else abs(a - b) / max(abs(a), abs(b))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", type=Path, required=True)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.worker:
        worker(a.worker, a.repeat)
        return 0
    tmp = Path(tempfile.mkdtemp())
    res = {}
    for label, code in (("before", a.before), ("after", ROOT)):
        env = {**os.environ, "PYTHONPATH": str(code / "src"), "DUFFSYM_CACHE": str(tmp / f"cache-{label}")}
        print(f"-- {label}: {code}", flush=True)
        subprocess.run([sys.executable, __file__, "--before", str(a.before), "--repeat", str(a.repeat),
                        "--worker", str(tmp / f"{label}.json")], env=env, check=True)
        res[label] = json.loads((tmp / f"{label}.json").read_text())
    rows = []
    for name, b in res["before"].items():
        n = res["after"][name]
        same = max(_rel(b["params"][k], n["params"][k]) for k in b["params"])
        dse = max(_rel(b["stderr"][k], n["stderr"][k]) for k in b["stderr"])
        rows.append({"case": name, "samples": b["n"], "status": n["status"], "stderr_s_before": b["seconds"],
                     "stderr_s_after": n["seconds"], "ratio": b["seconds"] / n["seconds"],
                     "params_max_rel_diff": same, "stderr_max_rel_diff": dse})
        print(f"{name:40s} {b['seconds']:6.2f} -> {n['seconds']:6.2f} s ({b['seconds'] / n['seconds']:.2f}x); "
              f"params differ {same:.1e}, standard errors {dse:.1e}")
    out = ROOT / "benchmarks" / "results" / "covariance_forward.json"
    out.write_text(json.dumps(stamp({"load": os.getloadavg(), "rows": rows}, a), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
