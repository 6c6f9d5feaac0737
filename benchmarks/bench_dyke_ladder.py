"""`duffsym ladder` on the 6 s Dyke slice with `--workers 2`: an older checkout against this one, in the same run
(issue 23: a command-driven record's ladder within 3 minutes on 2 cores).

    python benchmarks/bench_dyke_ladder.py --before /tmp/wt/base --repeats 2

Each run is the command a user types, in its own process (``--before``'s code through PYTHONPATH, with this
checkout's virtualenv), the runs of the two codes alternating. The record is the shared Dyke record
(``mr_damper_dyke_nees1996/ranran_50_converted.csv``), its first 6 s, every 6th sample (500.8 Hz, 3005 samples),
columns time, displacement, velocity, force, voltage. Reported per run: the wall time, the user CPU time of the
process tree, the phases read from the progress lines, the steps' effects and held-out NRMSE, the final fit's
NRMSE and the verdict's last words. Results: ``benchmarks/results/dyke_ladder.json``.
"""
from __future__ import annotations

import argparse
import csv
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)

ROOT = Path(__file__).resolve().parents[1]
#: progress lines that open a phase, in the order they come
PHASES = (
    ("base fit", "base fit of"),
    ("candidates", "  trying "),
    ("second starts", "  second start for"),
    ("continuing", "  continuing "),
    ("sindy", "  SINDy cross-check"),
    ("discovery", "  discovering a term"),
    ("final fit", "final fit on the whole record"),
)


def _external() -> Path:
    return Path(os.environ.get("DUFFSYM_EXTERNAL_DATA", ROOT.parent / "shared" / "data" / "external"))


def write_slice(path: Path) -> None:
    """The first 6 s of the Dyke record, every 6th sample, as a CSV a user would write."""
    src = _external() / "mr_damper_dyke_nees1996" / "ranran_50_converted.csv"
    with open(src, newline="") as f:
        rows = list(csv.DictReader(f))
    t0 = float(rows[0]["t"])
    out = [r for r in rows[::6] if float(r["t"]) - t0 <= 6.0]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time", "displacement", "velocity", "force", "voltage"])
        w.writerows([r["t"], r["D"], r["V"], r["F"], r["Y"]] for r in out)


def phases(progress: str) -> dict:
    """The second at which each phase started, from the ``[m:ss]`` stamps of the progress lines."""
    starts: dict = {}
    for line in progress.splitlines():
        m = re.match(r"\[(\d+):(\d\d)\]\s?(.*)", line)
        if not m:
            continue
        t = 60 * int(m.group(1)) + int(m.group(2))
        for name, opener in PHASES:
            if m.group(3).strip().startswith(opener.strip()) and name not in starts:
                starts[name] = t
    return starts


def run(code: Path, record: Path, limit: float) -> dict:
    env = {**os.environ, "PYTHONPATH": str(code / "src")}
    cmd = [sys.executable, "-c", "import sys; from duffsym.cli import main; sys.exit(main())", "ladder", str(record),
           "--model", "mr-damper-current", "--workers", "2", "--json"]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    tic = time.perf_counter()
    try:
        p = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=limit)
        ended, out, err = f"exit {p.returncode}", p.stdout, p.stderr
    except subprocess.TimeoutExpired as exc:
        ended, out, err = f"killed at {limit:g} s", "", (exc.stderr or b"").decode(errors="replace")
    wall = time.perf_counter() - tic
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    row = {"code": str(code), "wall_s": round(wall, 1), "user_s": round(after.ru_utime - before.ru_utime, 1),
           "ended": ended, "phase_starts_s": phases(err)}
    try:
        lad = json.loads(out)
    except json.JSONDecodeError:
        return {**row, "stderr_tail": err[-800:]}
    return {**row, "steps": [(s["effects"], round(s["nrmse_heldout"], 4)) for s in lad["steps"]],
            "final_nrmse": lad["final"].get("nrmse"), "final_status": lad["final"].get("status"),
            "ladder_total_s": round(lad["timings"]["total"], 1), "stopped_tail": lad["stopped"][-240:]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", type=Path, required=True, help="a checkout of the older code")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--limit", type=float, default=900.0)
    a = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        record = Path(tmp) / "dyke6.csv"
        write_slice(record)
        for i in range(a.repeats):
            for code in (a.before, ROOT):
                r = run(code, record, a.limit)
                r["which"] = "before" if code == a.before else "after"
                rows.append(r)
                print(f"{r['which']:6s} run {i + 1}: wall {r['wall_s']:6.1f} s  user {r['user_s']:6.1f} s  "
                      f"{r['ended']}  steps {r.get('steps')}  final {r.get('final_nrmse')}  "
                      f"phases {r['phase_starts_s']}", flush=True)
    walls = {w: [r["wall_s"] for r in rows if r["which"] == w] for w in ("before", "after")}
    summary = {w: {"median_wall_s": sorted(v)[len(v) // 2], "walls": v} for w, v in walls.items()}
    print(json.dumps(summary))
    doc = stamp({"benchmark": "dyke_ladder", "load": os.getloadavg(), "summary": summary, "runs": rows}, a)
    out = ROOT / "benchmarks" / "results" / "dyke_ladder.json"
    out.write_text(json.dumps(doc, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
