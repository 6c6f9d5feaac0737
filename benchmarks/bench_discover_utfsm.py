"""Benchmark: term discovery on the four worst UTFSM 0 A sinusoid tests (real MR damper, Quiroz 2022).

``studies/s06_real_mr_damper.py`` names them: 2 mm 5 Hz, 25 mm 0.5 Hz, 0.25 Hz and 0.1 Hz at 0 A
(single-test NRMSE 0.113-0.133 there; the loops are asymmetric between compression and extension).
For each: the record decimated to about ``--per-period`` samples per period (as s06 does), a
diagnosis with no catalogued candidate (the base fit on the first 70 %, held-out tail = the rest),
then :func:`duffsym.diagnose.discover.discover_term`: the held-out NRMSE before and after the
discovered term, the term, whether it passes the diagnosis's evidence. Measured, not promised.

    nice python benchmarks/bench_discover_utfsm.py [--per-period 100] [--only 25mm0x5Hz]

Writes ``benchmarks/results/discover_utfsm_tries{N}.json`` and prints the table.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)

WORST = ("2mm5Hz", "25mm0x5Hz", "25mm0x25Hz", "25mm0x1Hz")
HERE = Path(__file__).resolve().parent


def load(test: str, per_period: int):
    from duffsym.data import Record, external_data_dir, load_mr_damper_utfsm

    path = external_data_dir() / "mr_damper_utfsm_quiroz2022" / "sinusoidal_preprocessed" / f"{test}0A.txt"
    rec = load_mr_damper_utfsm(path, velocity="derive")
    q = max(1, int(math.floor(1.0 / (rec.dt * rec.metadata["frequency_hz"] * per_period))))
    v = np.asarray(rec.velocity())
    return Record(t=np.asarray(rec.t)[::q], d=np.asarray(rec.d)[::q], y=np.asarray(rec.y)[::q], d_dot=v[::q],
                  current=rec.current, units=dict(rec.units), name=f"{test}0A")


def run(test: str, per_period: int, tries: int = 3) -> dict:
    from duffsym.diagnose import diagnose
    from duffsym.diagnose.discover import discover_term

    rec = load(test, per_period)
    t0 = time.perf_counter()
    model = _model()
    dg = diagnose(rec, model, candidates=[], sindy=False)
    disc = discover_term(rec, model, dg, tries=tries)
    print(disc.summary(), flush=True)
    out = dict(test=f"{test} 0 A", samples=rec.n_times, base_heldout=dg.nrmse_heldout, noise=dg.noise,
               total_seconds=time.perf_counter() - t0, **{k: v for k, v in disc.to_dict().items()
                                                   if k not in ("stderr", "selection")})
    return out


def _model():
    from duffsym.model.library import mr_damper

    return mr_damper()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-period", type=int, default=100)
    ap.add_argument("--only", default=None)
    ap.add_argument("--tries", type=int, default=3, help="term sets fitted per record (discover_term's tries)")
    args = ap.parse_args(argv)
    rows = [run(t, args.per_period, args.tries) for t in WORST if args.only in (None, t)]
    print(f"{'test':<16}{'n':>6}{'before':>9}{'after':>9}{'dBIC':>9}{'expl.':>7}  term")
    for r in rows:
        print(f"{r['test']:<16}{r['samples']:>6}{r['nrmse_before']:>9.4f}{r['nrmse_after']:>9.4f}"
              f"{r['delta_bic']:>9.1f}{100 * r['explained']:>6.0f}%  {r['effect'] or r['message']}"
              f"{'  [needed]' if r['needed'] else ('  [supported]' if r['supported'] else '')}")
    out = HERE / "results" / f"discover_utfsm_tries{args.tries}.json"
    tmp = out.with_suffix(".json.tmp")
    doc = {"per_period": args.per_period, "tries": args.tries, "rows": rows}
    tmp.write_text(json.dumps(stamp(doc, args), indent=1, default=float))
    tmp.replace(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
