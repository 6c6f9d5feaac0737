"""Study s14's long part as a benchmark: the whole comparison of the Duffing-like model with the classical models
(issue 26: ``duffsym reproduce`` runs a shorter version and shows this file's results beside it).

    DUFFSYM_EXTERNAL_DATA=... python benchmarks/bench_s14_model_comparison.py

Runs ``studies/s14_model_comparison.py`` with ``Config.long()``: Spencer's model as well as mr-damper-current,
bouc-wen-current and bingham-current, three starts each, on the UTFSM campaign (5 mm 3 Hz held out) and on the
Dyke record. The Spencer fit of the UTFSM campaign is the long part (1822 s of the last 2670 s run, at load
9-27 on 2 cores; it ends at IPOPT's iteration limit). It computes into a temporary output root (the paper's
files are not touched) and writes the study's derived JSON, stamped with the commit, settings, machine and load,
to ``benchmarks/results/s14_model_comparison.json`` (each model's fit time is in ``*.models[*].fit_seconds``).
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

import s14_model_comparison as S  # noqa: E402

from _provenance import provenance, stamp  # noqa: E402  (benchmarks/ is on sys.path: the script's folder)

RESULT = ROOT / S.STORED_NAME


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
    study = meta.pop("provenance", {})
    doc = stamp({"provenance": prov, "study_provenance": study, **meta, "bench_wall_s": time.perf_counter() - t0})
    print(S.summarize({**doc, "provenance": study}))
    out = Path(a.out)
    tmp_file = out.with_suffix(".tmp")
    tmp_file.write_text(json.dumps(doc, indent=1, default=float) + "\n")
    tmp_file.replace(out)
    print(f"wrote {out} ({doc['bench_wall_s']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
