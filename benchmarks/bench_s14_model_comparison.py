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
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "studies"))

import s14_model_comparison as S  # noqa: E402

from _provenance import run_long_study  # noqa: E402  (benchmarks/ is on sys.path: the script's folder)

RESULT = ROOT / S.STORED_NAME


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(RESULT), help="the results file (default: %(default)s)")
    a = ap.parse_args(argv)
    run_long_study(S, a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
