"""Campaign discovery on the UTFSM damper: what one parameter set of ``mr-damper-current`` lacks across the 30 tests.

The tests of one amplitude/frequency pair (``--fold``, default ``25mm0x1Hz``, the worst fold of study s11's
hold-out by excitation) are held out at all five currents before any fit; the other 25 train
(:func:`duffsym.diagnose.campaign.discover_campaign`, s11's records at ~25 samples per period, eta held at 100 /s,
k1 + k2 >= 0 at 0 and 1 A).

    python benchmarks/bench_utfsm_campaign_discovery.py [--fold 25mm0x1Hz]

Writes ``benchmarks/results/utfsm_campaign_discovery.json``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from _provenance import write_result  # benchmarks/ is on sys.path (the script's folder)

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "studies"))


def main(argv=None) -> int:
    import s11_current_driven as s11

    from duffsym.diagnose.campaign import discover_campaign
    from duffsym.model import get_model

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fold", default="25mm0x1Hz")
    ap.add_argument("--out", default=str(HERE / "results" / "utfsm_campaign_discovery.json"))
    args = ap.parse_args(argv)
    cfg = s11.Config()
    recs = s11.campaign_records(cfg)
    model = get_model("mr-damper-current")
    held = [r.name for r in recs if r.name.startswith(args.fold)]
    t0 = time.perf_counter()
    res = discover_campaign(recs, model, held, fixed={"eta": cfg.campaign_eta}, constraints=s11._constraints(model),
                            progress=lambda m: print(f"[{time.perf_counter() - t0:.0f} s] {m}", flush=True))  # fmt: skip
    print(res.summary())
    write_result(args.out, dict(benchmark="utfsm_campaign_discovery", fold=args.fold, result=res.to_dict()), args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
