"""Issue 17 item 2: one parameter set for the 30 UTFSM sinusoid tests, mr-damper-current against the path-time
variant mr-damper-current-path-viscous (warm-started from the clock-time fit, ``duffsym.identify.initial.path_start``)
and against mr-damper-current with each test weighted by 1/mean(y^2) (the objective then sums per-test NRMSE^2).

    DUFFSYM_EXTERNAL_DATA=... python benchmarks/bench_current_path_campaign.py VARIANT [--holdout PAIR]

VARIANT: base | path | base-weighted. Settings are s11's (``studies/s11_current_driven.Config()``: 25 samples per
period, eta held at 100, k1 + k2 >= 0 at u = 0 and 1). Prints in-sample free-run NRMSE (median, worst) or, with
``--holdout PAIR`` (e.g. 25mm0x1Hz), the free-run NRMSE of that pair's five tests from a refit without them
(the path variant warm-started from the base refit on the same training tests). Writes JSON to
``benchmarks/results/current_path_<variant>[_<pair>].json``.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "studies"))

import s11_current_driven as S  # noqa: E402

from duffsym.identify import Problem, fit  # noqa: E402
from duffsym.identify.initial import path_start  # noqa: E402
from duffsym.identify.structure import scaled_to  # noqa: E402
from duffsym.model import get_model  # noqa: E402
from _provenance import write_result  # benchmarks/ is on sys.path (the script's folder)

V_EPS0 = 300.0  # mm/s, the start: three times the campaign's fastest drive (94 mm/s), where path ~ clock time


def constraints():
    return [({"k1": 1.0, "k2": 1.0}, 0.0, math.inf), ({"k1": 1.0, "k2": 1.0, "k1_u": 1.0, "k2_u": 1.0}, 0.0, math.inf)]


def fit_base(recs, eta, weighted=False):
    w = [np.full(r.n_times, 1.0 / float(np.mean(np.square(r.y)))) for r in recs] if weighted else None
    return fit(Problem(get_model("mr-damper-current"), recs, fixed={"eta": eta}, constraints=constraints(), weights=w))


def fit_path(recs, eta, clock_params):
    x0 = path_start(clock_params, v_eps=V_EPS0)
    model = scaled_to(get_model("mr-damper-current-path-viscous"), x0)
    free = [k for k in model.param_names if k not in ("A_f", "eta", "k3")]
    prob = Problem(model, recs, free=free, fixed={"eta": eta, "A_f": x0["A_f"], "k3": 0.0}, constraints=constraints())
    return fit(prob, x0={k: x0[k] for k in free}), model


def run(variant: str, pair: str | None) -> dict:
    cfg = S.Config()
    recs = S.campaign_records(cfg)
    train = [r for r in recs if pair is None or not r.name.startswith(pair)]
    test = recs if pair is None else [r for r in recs if r.name.startswith(pair)]
    t0 = time.perf_counter()
    res = fit_base(train, cfg.campaign_eta, weighted=variant == "base-weighted")
    model = get_model("mr-damper-current")
    if variant == "path":
        res, model = fit_path(train, cfg.campaign_eta, res.params)
    e = {r.name: S.free_run(res, r, model)[1] for r in test}
    v = np.array(list(e.values()))
    return dict(variant=variant, holdout=pair, status=res.status, wall_s=time.perf_counter() - t0,
                params=res.params, median=float(np.median(v)), worst=float(v.max()), nrmse=e)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("variant", choices=("base", "path", "base-weighted"))
    ap.add_argument("--holdout", default=None)
    a = ap.parse_args(argv)
    out = run(a.variant, a.holdout)
    print(f"{a.variant}{'' if a.holdout is None else ' held out ' + a.holdout}: {out['status']}, NRMSE median "
          f"{out['median']:.3f} worst {out['worst']:.3f} ({out['wall_s']:.0f} s)")
    path = ROOT / "benchmarks" / "results" / f"current_path_{a.variant}{'' if a.holdout is None else '_' + a.holdout}.json"
    write_result(path, out, a)
    return 0


if __name__ == "__main__":
    sys.exit(main())
