"""Helpers shared by the studies: provenance, derived files, quoted numbers, figure saving, CLI."""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from contextlib import contextmanager
from dataclasses import asdict
from pathlib import Path

import numpy as np

import paths
from duffsym._json import jsonable
from duffsym.errors import show_notes

show_notes()  # the package's warnings as one-line notes in the study output


def external_folder(name: str) -> Path | None:
    """The external data set ``name`` (a folder under ``duffsym.data.external_data_dir()``), or None when absent."""
    from duffsym.data import external_data_dir
    from duffsym.errors import DataError

    try:
        p = external_data_dir() / name
    except DataError:
        return None
    return p if p.is_dir() else None


def git_sha() -> str | None:
    """The checkout's commit (with ``-dirty`` if the tree has changes), or ``None`` without git."""
    try:
        root = str(paths.repo_root())
        sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True,
                             timeout=10).stdout.strip()
        if not sha:
            return None
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root,
                               capture_output=True, text=True, timeout=10).stdout.strip()
        return sha + ("-dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return None


def provenance(cfg) -> dict:
    """Config, git SHA and versions of the packages a study depends on."""
    import matplotlib
    import scipy
    import sympy as sp

    import duffsym

    return dict(config=asdict(cfg), git_sha=git_sha(), python=sys.version.split()[0],
                versions=dict(duffsym=duffsym.__version__, numpy=np.__version__, sympy=sp.__version__,
                              scipy=scipy.__version__, matplotlib=matplotlib.__version__))


def write_derived(study: str, arrays: dict[str, np.ndarray], meta: dict) -> list[Path]:
    """Write ``data/derived/<study>.npz`` (arrays) and ``<study>.json`` (metadata); return the paths."""
    out = paths.derived_dir()
    out.mkdir(parents=True, exist_ok=True)
    npz, js = out / f"{study}.npz", out / f"{study}.json"
    np.savez_compressed(npz, **{k: np.asarray(v) for k, v in arrays.items()}, run_mode=np.array(paths.mode()))
    js.write_text(json.dumps(jsonable({**meta, "run_mode": paths.mode()}), indent=2) + "\n")
    return [npz, js]


def read_derived(study: str) -> tuple[dict[str, np.ndarray], dict]:
    """Read what :func:`write_derived` wrote (the only input of a study's ``plot``)."""
    out = paths.derived_dir()
    npz, js = out / f"{study}.npz", out / f"{study}.json"
    if not npz.is_file() or not js.is_file():
        raise FileNotFoundError(f"{npz} or {js} is missing; run `python studies/{study}.py` (compute) first")
    with np.load(npz) as f:
        arrays = {k: f[k] for k in f.files if k != "run_mode"}
    return arrays, json.loads(js.read_text())


def write_number(study: str, name: str, text: str) -> Path:
    """Write one quoted number (or a small LaTeX snippet) to ``paper/output/<study>_<name>.tex``."""
    out = paths.output_dir()
    out.mkdir(parents=True, exist_ok=True)
    p = out / f"{study}_{name}.tex"
    text = text.strip("\n")
    # a one-line value ends with "%" so that \input leaves no space after it; a table is written as is;
    # the last line, a TeX comment, records the run that made the file
    p.write_text(text + ("\n" if "\n" in text else "%\n") + mode_comment(study))
    return p


def mode_comment(study: str) -> str:
    """The TeX comment line ending every number file: which study and which run (full/smoke) made it."""
    return f"% made by {study}, {paths.mode()} run\n"


@contextmanager
def style():
    """The studies' matplotlib style, Agg backend, no global rcParams changes."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    with plt.style.context(str(paths.STYLE)):
        yield plt


def save(fig, study: str, panel: str) -> Path:
    """Save ``fig`` as ``paper/figures/<study>_<panel>.png`` and close it."""
    from duffsym.plot import save_figure

    return save_figure(fig, paths.figures_dir() / f"{study}_{panel}.png",
                       metadata={"Description": f"made by {study}, {paths.mode()} run"})


def parse_args(argv, description: str) -> argparse.Namespace:
    """The command line of every study: ``--smoke`` and ``--plot-only``."""
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--smoke", action="store_true", help="small settings for CI (a few seconds)")
    p.add_argument("--plot-only", action="store_true", help="redraw the figures from data/derived only")
    p.add_argument("--workers", type=int, default=None, help="worker processes for studies that run independent "
                   "fits through duffsym.engine.Engine (those with a Config.workers; 0: in this process)")
    args = p.parse_args(argv)
    paths.set_mode("smoke" if args.smoke else "full")
    return args


def run_study(argv, *, doc: str, label: str, config, compute, plot, write_numbers, summarize, read,
              announce: bool = False, args=None) -> int:
    """The ``main`` of every study: compute (unless ``--plot-only``), plot from the derived files, write
    the quoted numbers, print the summary and what was written.

    ``config`` is the study's Config class (``.smoke()`` for ``--smoke``); ``read()`` returns the
    derived ``(arrays, meta)``; ``announce`` prints the config summary first (long studies).
    """
    args = args if args is not None else parse_args(argv, doc.splitlines()[0])
    cfg = config.smoke() if args.smoke else config()
    if getattr(args, "workers", None) is not None and hasattr(cfg, "workers"):
        from dataclasses import replace

        cfg = replace(cfg, workers=args.workers)
    t0 = time.perf_counter()
    if not args.plot_only:
        if announce:
            print(cfg.summary(), flush=True)
        compute(cfg)
    _, meta = read()
    files = plot() + write_numbers(meta)
    print(summarize(meta))
    print(f"{label}: wrote {len(files) + 2} files in {time.perf_counter() - t0:.1f} s")
    return 0
