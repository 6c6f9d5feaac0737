"""Study s11's long part as a benchmark: the whole current-driven study (issue 26: ``duffsym reproduce`` runs a
shorter version and reads this file's results).

    DUFFSYM_EXTERNAL_DATA=... python benchmarks/bench_s11_current_driven.py

Runs ``studies/s11_current_driven.py`` with ``Config.long()``: both field forms fitted to the 30 UTFSM tests,
the six hold-out refits (each amplitude/frequency pair left out at all five currents), the slowest pair fitted
alone, the earthquake-type record, and the Dyke sequence. It computes into a temporary output root (the
paper's figures and numbers are not touched) and writes the study's derived JSON, stamped with the commit,
settings, machine and load, to ``benchmarks/results/s11_current_driven.json``; per-part wall times are in it
(``campaign.forms.*.wall_s``, ``campaign.holdout_wall_s``, ``dyke.forms.*.wall_s``, ``total_s``).
About 30-45 minutes on a shared 2-core machine.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from dataclasses import asdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "studies"))

import s11_current_driven as S  # noqa: E402

from _provenance import provenance, stamp  # noqa: E402  (benchmarks/ is on sys.path: the script's folder)

RESULT = ROOT / "benchmarks" / "results" / f"{S.STUDY}.json"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(RESULT), help="the results file (default: %(default)s)")
    a = ap.parse_args(argv)
    cfg = S.Config.long()
    print(cfg.summary(), flush=True)
    prov = provenance({**asdict(cfg), "out": a.out})  # the commit and the load at the start: what ran
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["DUFFSYM_OUTPUT_ROOT"] = tmp
        S.compute(cfg)
        _, meta = S.read()
    meta.pop("run_mode", None)
    doc = stamp({"provenance": prov, **meta,
                 "bench_wall_s": time.perf_counter() - t0})
    print(S.summarize(doc))
    out = Path(a.out)
    tmp_file = out.with_suffix(".tmp")
    tmp_file.write_text(json.dumps(doc, indent=1, default=float) + "\n")
    tmp_file.replace(out)
    print(f"wrote {out} ({doc['bench_wall_s']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
