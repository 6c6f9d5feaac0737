"""Run every study in order: ``python studies/run_all.py [--smoke]`` (what ``duffsym reproduce`` calls).

The studies are the files ``studies/sNN_<name>.py``, run in order of NN. Each study's ``main`` is
called in turn (``--smoke`` is passed through); one line per study gives
its status, wall time and the files it wrote. A failing study is reported with its traceback and the
others still run; the exit status is 1 if any study failed, else 0.
"""
from __future__ import annotations

import importlib
import sys
import time
import traceback
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import paths  # noqa: E402

#: every ``studies/sNN_<name>.py`` in order of NN (each has ``main(argv)`` taking ``--smoke``)
STUDIES = tuple(sorted(p.stem for p in Path(__file__).resolve().parent.glob("s[0-9][0-9]_*.py")))
#: typical full-run seconds per study (2 cores, fresh virtualenv; paper/README.md): the weights of the
#: estimate of the time left, scaled by how fast this run has been so far; 60 s for a study not listed
TYPICAL_SECONDS = {"s01": 20, "s02": 8, "s03": 4, "s04": 3, "s05": 23, "s06": 220, "s07": 230, "s08": 127,
                   "s09": 42, "s10": 143, "s11": 1500, "s12": 35, "s13": 165,
                   "s14": 2670}  # s14: measured under load average ~20 (the Spencer campaign fit: 1822 s)


def _estimate(done: list[str], left: list[str], elapsed: float, smoke: bool) -> str:
    """``about m:ss left`` from the typical times of the studies done and left (equal weights for smoke)."""
    def weight(name):
        return 1.0 if smoke else float(TYPICAL_SECONDS.get(name[:3], 60))

    if not done or elapsed <= 0:
        return ""
    seconds = int(elapsed / sum(map(weight, done)) * sum(map(weight, left)))
    return f", about {seconds // 60}:{seconds % 60:02d} left"


def _outputs_since(start: float, prefixes: tuple[str, ...]) -> list[str]:
    """Files named ``<prefix>...`` under the output folders modified since ``start`` (epoch seconds)."""
    found = []
    for folder in (paths.derived_dir(), paths.figures_dir(), paths.output_dir()):
        if folder.is_dir():
            for f in sorted(folder.iterdir()):
                if f.is_file() and f.name.startswith(prefixes) and f.stat().st_mtime >= start - 1e-3:
                    found.append(str(f.relative_to(paths.output_root())))
    return found


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    unknown = [a for a in argv if a != "--smoke"]
    if unknown:
        print(f"run_all.py: unknown argument(s) {unknown}; the only option is --smoke", file=sys.stderr)
        return 2
    paths.set_mode("smoke" if "--smoke" in argv else "full")  # each study sets it again from its own argv
    failed, lines = [], []
    t_run = time.perf_counter()
    for k, name in enumerate(STUDIES):
        elapsed = time.perf_counter() - t_run
        print(f"[{int(elapsed) // 60}:{int(elapsed) % 60:02d}] {name} ({k + 1} of {len(STUDIES)}"
              f"{_estimate(list(STUDIES[:k]), list(STUDIES[k:]), elapsed, '--smoke' in argv)})", file=sys.stderr,
              flush=True)
        t_wall, t0 = time.time(), time.perf_counter()
        try:
            mod = importlib.import_module(name)
            rc = mod.main(argv)
            ok = rc in (0, None)
        except Exception:  # report and go on with the other studies
            traceback.print_exc()
            ok = False
        dt = time.perf_counter() - t0
        files = _outputs_since(t_wall, (name, name[:3] + "_"))
        line = f"{name}: {'ok' if ok else 'FAILED'} in {dt:.1f} s; {len(files)} files: {', '.join(files)}"
        lines.append(line)
        print(line, flush=True)
        if not ok:
            failed.append(name)
    print("\n".join(["", "summary:"] + lines))
    if failed:
        print(f"run_all.py: {len(failed)} of {len(STUDIES)} studies failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
