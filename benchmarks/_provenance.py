"""What made a results file: the commit, the settings, the machine and its load (issue 27).

Every script that writes ``benchmarks/results/NAME.json`` passes its document through :func:`stamp`, which adds
a ``provenance`` entry: ``git rev-parse HEAD`` of this checkout (and whether the tree had uncommitted changes),
the script's settings (its parsed arguments, or the constants it ran with), the date, Python, the machine and the
load average. One current file per benchmark; earlier runs are in the git history of that file.
"""
from __future__ import annotations

import os
import platform
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, timeout=30, check=True)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip()


def provenance(settings=None) -> dict:
    """The commit, the settings and the machine of this run (settings: a dict or an ``argparse.Namespace``)."""
    if settings is not None and not isinstance(settings, dict):
        settings = vars(settings)
    status = _git("status", "--porcelain", "--untracked-files=no")
    return {
        "commit": _git("rev-parse", "HEAD"),
        "uncommitted_changes": None if status is None else bool(status),
        "settings": {k: (v if isinstance(v, (int, float, str, bool, type(None), list, tuple, dict)) else str(v))
                     for k, v in (settings or {}).items()},
        "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]),
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "python": platform.python_version(),
        "machine": platform.machine(),
        "cpus": os.cpu_count(),
        "load": list(os.getloadavg()),
    }


def stamp(doc: dict, settings=None) -> dict:
    """``doc`` with a ``provenance`` entry first (kept when the document already has one, e.g. on a merge)."""
    if "provenance" in doc:
        return doc
    return {"provenance": provenance(settings), **doc}


def write_result(path, doc: dict, settings=None) -> None:
    """``doc``, stamped (:func:`stamp`), written to ``path`` atomically (a temporary file beside it, then renamed)."""
    import json
    from pathlib import Path

    path = Path(path)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(stamp(doc, settings), indent=1, default=float))
    tmp.replace(path)


def run_long_study(study, out) -> dict:
    """Run ``study`` (a module of ``studies/``) with its ``Config.long()`` into a temporary output root (the paper's
    figures and numbers are not touched), and write its derived JSON, stamped, atomically to ``out``: the document
    of a study's long part that ``duffsym reproduce`` reads back. The study's own provenance, when it has one, is
    kept as ``study_provenance``."""
    import json
    import tempfile
    from dataclasses import asdict

    cfg = study.Config.long()
    print(cfg.summary(), flush=True)
    prov = provenance({**asdict(cfg), "out": str(out)})  # the commit and the load at the start: what ran
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["DUFFSYM_OUTPUT_ROOT"] = tmp
        study.compute(cfg)
        _, meta = study.read()
    meta.pop("run_mode", None)
    own = meta.pop("provenance", None)
    doc = stamp({"provenance": prov, **({"study_provenance": own} if own is not None else {}), **meta,
                 "bench_wall_s": time.perf_counter() - t0})
    print(study.summarize(doc if own is None else {**doc, "provenance": own}))
    out = Path(out)
    tmp_file = out.with_suffix(".tmp")
    tmp_file.write_text(json.dumps(doc, indent=1, default=float) + "\n")
    tmp_file.replace(out)
    print(f"wrote {out} ({doc['bench_wall_s']:.0f} s)")
    return doc
