"""``duffsym reproduce``: run ``studies/run_all.py`` (every figure and number of the paper)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from duffsym._cli_common import CLIError, _err


def _find_studies(start: Path) -> Path | None:
    for folder in (start, *start.parents):
        candidate = folder / "studies" / "run_all.py"
        if candidate.is_file():
            return candidate
    return None


def cmd_reproduce(args) -> int:
    runner = Path(args.studies) / "run_all.py" if args.studies else _find_studies(Path.cwd())
    if runner is None or not runner.is_file():
        raise CLIError("no studies/run_all.py found from the current folder upwards; run `duffsym reproduce` "
                       "inside a duffsym checkout or pass --studies PATH/TO/studies")
    cmd = [sys.executable, str(runner)] + (["--smoke"] if args.smoke else [])
    _err(f"running {' '.join(cmd)}")
    proc = subprocess.run(cmd, cwd=runner.parent.parent, env={**os.environ, "MPLBACKEND": "Agg"})
    if proc.returncode != 0:
        raise CLIError(f"the studies failed (exit {proc.returncode}); see the messages above")
    return 0


def register(sub) -> None:
    s = sub.add_parser("reproduce", help="run the studies and regenerate every figure and number")
    s.add_argument("--smoke", action="store_true", help="quick run with small settings (for CI)")
    s.add_argument("--studies", help="path of the studies folder (default: found from the current folder upwards)")
    s.set_defaults(func=cmd_reproduce)
