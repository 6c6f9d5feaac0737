"""Rerun a fuzz corpus through the command line, in-process, and count what goes wrong (issue 15).

    nice -n 10 python benchmarks/fuzz_corpus.py [--csv 3000] [--fits 400] [--options 300] [--real-fits 40]
                                                [--samples 30] [--out results/fuzz_corpus.json]

- ``--csv`` mutated CSV files (tests/_fuzz_mutations.py: each labelled broken or benign) through
  ``duffsym validate FIT.json FILE``: the loader and the free run; ``--real-fits`` of them through
  ``duffsym fit`` (IPOPT).
- ``--fits`` tampered FIT.json files through ``duffsym validate``; ``--samples`` of them through
  ``duffsym sample --steps 3``.
- ``--options`` random option sets of ``simulate`` and ``fit``.

Counted: internal errors (an exception escaping ``main``, "internal error" on stderr, exit 2 with more
than one line), hangs (no answer within 120 s), broken files accepted silently (exit 0), valid files
refused.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import random
import signal
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from _fuzz_mutations import mutate_csv, tamper_fit  # noqa: E402

from duffsym.cli import main  # noqa: E402
from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)


class Hang(BaseException):
    pass


def run(argv, seconds=120):
    """``(kind, code, stderr)`` of one in-process CLI run; kind is ok / error / failed / usage / internal / hang."""
    err, out = io.StringIO(), io.StringIO()

    def on_alarm(signum, frame):
        raise Hang

    signal.signal(signal.SIGALRM, on_alarm)
    signal.alarm(seconds)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            code = main(argv)
    except Hang:
        return "hang", None, err.getvalue()
    except SystemExit as stop:
        return ("usage" if stop.code == 2 else "internal"), stop.code, err.getvalue()
    except BaseException as exc:  # noqa: BLE001 - anything escaping main is an internal error
        return "internal", None, f"{type(exc).__name__}: {exc}"
    finally:
        signal.alarm(0)
    text = err.getvalue()
    if "internal error" in text or "Traceback" in text:
        return "internal", code, text
    if code == 2 and len(text.strip().splitlines()) != 1:
        return "internal", code, text
    return {0: "ok", 1: "failed", 2: "error", 130: "internal"}.get(code, "internal"), code, text


def csv_corpus(n, fit_json, folder, real_fits, rng):
    counts, problems = Counter(), []
    real = set(rng.sample(range(n), min(real_fits, n)))
    for seed in range(n):
        name, data, broken = mutate_csv(seed)
        p = folder / f"c{seed}.csv"
        p.write_bytes(data)
        argv = (["fit", str(p), "--quiet"] if seed in real else ["validate", str(fit_json), str(p)])
        kind, code, err = run(argv)
        counts[kind] += 1
        label = "broken" if broken else "benign"
        counts[f"{label}:{kind}"] += 1
        if kind in ("internal", "hang") or (broken and kind == "ok") or (not broken and kind == "error"):
            problems.append({"seed": seed, "mutation": name, "argv0": argv[0], "kind": kind, "stderr": err[:300]})
        p.unlink()
    return counts, problems


def fit_corpus(n, good, record, folder, n_sample, rng):
    counts, problems = Counter(), []
    sample_seeds = set(rng.sample(range(n), min(n_sample, n)))
    for seed in range(n):
        what, value = tamper_fit(good, seed)
        p = folder / f"f{seed}.json"
        try:
            p.write_text(json.dumps(value))
        except (RecursionError, ValueError):
            p.write_text("[" * 100_000 + "]" * 100_000)
        if seed in sample_seeds:
            argv = ["sample", str(record), "--fit", str(p), "--steps", "3", "--walkers", "16", "--quiet"]
        else:
            argv = ["validate", str(p), str(record)]
        kind, code, err = run(argv)
        counts[kind] += 1
        if kind in ("internal", "hang"):
            problems.append({"seed": seed, "tamper": what, "argv0": argv[0], "kind": kind, "stderr": err[:300]})
    return counts, problems


def option_corpus(n, record, folder, rng):
    numbers = ["0", "-1", "1", "0.5", "1e-9", "1e9", "nan", "inf", "-inf", "1e400", "x", "", "3", "2", "0.005",
               "5", "99999", "-0", "0.01"]
    counts, problems = Counter(), []
    for i in range(n):
        if rng.random() < 0.5:
            argv = ["simulate", "--out", str(folder / "s.csv")]
            for opt in ("--dt", "--duration", "--frequency", "--amplitude", "--lines", "--f-max", "--substeps",
                        "--periods"):
                if rng.random() < 0.5:
                    argv += [opt, rng.choice(numbers)]
            argv += ["--excitation", rng.choice(["sine", "multisine", "random"])]
        else:
            argv = ["fit", str(record), "--quiet", "--out", str(folder / "f.json")]
            for _ in range(rng.randint(0, 3)):
                argv += ["--fix", f"{rng.choice(['c1', 'c2', 'c3', 'k1', 'k2', 'k3', 'A_f', 'zz'])}={rng.choice(numbers)}"]
            if rng.random() < 0.5:
                argv += ["--af", rng.choice(numbers + ["max"])]
            if rng.random() < 0.3:
                argv += ["--n", rng.choice(numbers)]
            if rng.random() < 0.3:
                argv += ["--starts", rng.choice(["1", "0", "-1", "2"])]
            if rng.random() < 0.3:
                argv += ["--add", rng.choice(["backlash", "nope", ",", "backlash,backlash"])]
        kind, code, err = run(argv)
        counts[kind] += 1
        if kind in ("internal", "hang"):
            problems.append({"argv": argv, "kind": kind, "stderr": err[:300]})
    return counts, problems


def main_corpus() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--csv", type=int, default=3000)
    ap.add_argument("--fits", type=int, default=400)
    ap.add_argument("--options", type=int, default=300)
    ap.add_argument("--real-fits", type=int, default=40)
    ap.add_argument("--samples", type=int, default=30)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "fuzz_corpus.json"))
    a = ap.parse_args()
    rng = random.Random(a.seed)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        record = folder / "record.csv"
        assert main(["simulate", "--voltage", "0.4", "--periods", "4", "--out", str(record)]) == 0
        fit_json = folder / "fit.json"
        assert main(["fit", str(record), "--out", str(fit_json), "--quiet"]) == 0
        good = json.loads(fit_json.read_text())
        report = {}
        t0 = time.perf_counter()
        for label, fn, args in [
            ("options", option_corpus, (a.options, record, folder, rng)),
            ("fit_json", fit_corpus, (a.fits, good, record, folder, a.samples, rng)),
            ("csv", csv_corpus, (a.csv, fit_json, folder, a.real_fits, rng)),
        ]:
            t = time.perf_counter()
            counts, problems = fn(*args)
            report[label] = {"counts": dict(counts), "problems": problems[:50], "n_problems": len(problems),
                             "seconds": time.perf_counter() - t}
            print(label, dict(counts), f"{len(problems)} problem(s)", f"{time.perf_counter() - t:.0f} s",
                  file=sys.stderr, flush=True)
        report["seconds"] = time.perf_counter() - t0
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(stamp(report, a), indent=2))
    print(json.dumps({k: v["counts"] if isinstance(v, dict) else v for k, v in report.items()}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main_corpus())
