"""``duffsym reproduce``: run ``studies/run_all.py`` (every figure and number of the paper).

Independent studies run in parallel (``--workers``) and each study's outputs are cached under a hash of
what it depends on, so an unchanged study is skipped with a line saying so (``--force`` reruns it);
``studies/run_all.py`` says how.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from duffsym.cli.common import CLIError, err


def _find_studies(start: Path) -> Path | None:
    for folder in (start, *start.parents):
        candidate = folder / "studies" / "run_all.py"
        if candidate.is_file():
            return candidate
    return None


def cmd_reproduce(args) -> int:
    runner = Path(args.studies) / "run_all.py" if args.studies else _find_studies(Path.cwd())
    if runner is None or not runner.is_file():
        raise CLIError(
            "no studies/run_all.py found from the current folder upwards; run `duffsym reproduce` "
            "inside a duffsym checkout or pass --studies PATH/TO/studies"
        )
    from duffsym.engine import default_workers

    workers = args.workers if args.workers is not None else default_workers()
    if workers < 1:
        raise CLIError(f"--workers must be at least 1; got {workers}")
    cmd = (
        [sys.executable, str(runner), "--workers", str(workers)]
        + (["--smoke"] if args.smoke else [])
        + (["--force"] if args.force else [])
    )
    err(f"running {' '.join(cmd)}")
    proc = subprocess.run(cmd, cwd=runner.parent.parent, env={**os.environ, "MPLBACKEND": "Agg"})
    if proc.returncode != 0:
        raise CLIError(f"the studies failed (exit {proc.returncode}); see the messages above")
    return 0


def register(sub) -> None:
    s = sub.add_parser("reproduce", help="run the studies and regenerate every figure and number")
    s.add_argument("--smoke", action="store_true", help="quick run with small settings (for CI)")
    s.add_argument("--studies", help="path of the studies folder (default: found from the current folder upwards)")
    s.add_argument(
        "--workers",
        type=int,
        default=None,
        help="studies run in parallel on this many local worker "
        "processes (duffsym.engine; default: the cores this process may use; 1: one after another, in "
        "this process)",
    )
    s.add_argument(
        "--force",
        action="store_true",
        help="rerun every study, even those whose inputs are unchanged "
        "(by default an unchanged study is skipped, saying so)",
    )
    s.set_defaults(func=cmd_reproduce)
