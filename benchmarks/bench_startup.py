"""Start-up of the ``duffsym`` command, the main branch's code against this one in the same run (issue 24).

Times (wall, best and median of ``--repeat`` runs, each a fresh process): ``duffsym --help``,
``duffsym --version``, ``duffsym models`` and ``duffsym fit`` of a 400-sample record (the first 400 rows
of ``data/synthetic_sine.csv``, mr-damper) with the model's compiled code already cached (one warm-up
fit first). ``--before`` is a checkout of the older code with its own ``.venv`` (read-only).

    python benchmarks/bench_startup.py --before /work/main --repeat 5

Results: ``benchmarks/results/bench_startup.json``.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)

ROOT = Path(__file__).resolve().parents[1]


def _time(cmd, env) -> float:
    tic = time.perf_counter()
    subprocess.run(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    return time.perf_counter() - tic


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", type=Path, default=Path("/work/main"))
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp())
    rec = tmp / "sine400.csv"
    rec.write_text("".join((ROOT / "data" / "synthetic_sine.csv").read_text().splitlines(True)[:401]))
    cases = {"--help": ["--help"], "--version": ["--version"], "models": ["models"],
             "fit 400 samples (cached)": ["fit", str(rec), "--quiet", "--json"]}
    rows = []
    for label, code in (("before", a.before), ("after", ROOT)):
        exe = str(code / ".venv" / "bin" / "python")
        env = {**os.environ, "PYTHONPATH": str(code / "src"), "DUFFSYM_CACHE": str(tmp / f"cache-{label}")}
        _time([exe, "-m", "duffsym.cli", *cases["fit 400 samples (cached)"]], env)  # warm the code cache
        for name, args in cases.items():
            ts = [_time([exe, "-m", "duffsym.cli", *args], env) for _ in range(a.repeat)]
            rows.append({"code": label, "case": name, "best_s": min(ts), "median_s": statistics.median(ts)})
            print(f"{label:6s} {name:26s} best {min(ts):6.2f} s  median {statistics.median(ts):6.2f} s", flush=True)
    for name in cases:
        b, n = (next(r for r in rows if r["code"] == c and r["case"] == name) for c in ("before", "after"))
        print(f"ratio {name:26s} before/after (median) {b['median_s'] / n['median_s']:.2f}x")
    out = ROOT / "benchmarks" / "results" / "bench_startup.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps(stamp({"load": os.getloadavg(), "rows": rows}, a), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
