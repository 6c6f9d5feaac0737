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
