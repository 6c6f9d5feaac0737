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
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "studies"))

import s11_current_driven as S  # noqa: E402

from _provenance import run_long_study  # noqa: E402  (benchmarks/ is on sys.path: the script's folder)

RESULT = ROOT / "benchmarks" / "results" / f"{S.STUDY}.json"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(RESULT), help="the results file (default: %(default)s)")
    a = ap.parse_args(argv)
    run_long_study(S, a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
