"""Absolute paths of the studies (one place, so no script depends on the working folder).

Everything a study writes lives under an *output root*: the repository root by default, or the
folder named by the environment variable ``DUFFSYM_OUTPUT_ROOT`` (the smoke tests point it at a
temporary folder). The variable is read on every call, so it can be set after import.

- ``repo_root()``    the duffsym checkout (parent of ``studies/``).
- ``output_root()``  ``$DUFFSYM_OUTPUT_ROOT`` or ``repo_root()``.
- ``derived_dir()``  ``<output root>/data/derived``: computed arrays (``.npz``) and provenance (``.json``).
- ``figures_dir()``  ``<output root>/paper/figures``: the PNG figures.
- ``output_dir()``   ``<output root>/paper/output``: numbers quoted in ``paper/ms.tex`` (``.tex``).

A smoke run (``--smoke``, :func:`set_mode`) writes apart from the full run, so it can never replace
the full run's figures or numbers (the report reads only the full run's folders):
``data/derived/smoke/``, ``paper/smoke/figures/``, ``paper/smoke/output/``.
"""
from __future__ import annotations

import os
from pathlib import Path

ENV_VAR = "DUFFSYM_OUTPUT_ROOT"
MODES = ("full", "smoke")
_mode = "full"
STUDIES = Path(__file__).resolve().parent
STYLE = STUDIES / "duffsym.mplstyle"


def set_mode(mode: str) -> None:
    """``"full"`` or ``"smoke"``: which run the following outputs belong to (set by every study's ``main``)."""
    global _mode
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}; got {mode!r}")
    _mode = mode


def mode() -> str:
    """The current run's mode, ``"full"`` or ``"smoke"``."""
    return _mode


def repo_root() -> Path:
    """The repository root (the folder holding ``studies/``)."""
    return STUDIES.parent


def output_root() -> Path:
    """Root of everything the studies write: ``$DUFFSYM_OUTPUT_ROOT`` if set, else the repository root."""
    env = os.environ.get(ENV_VAR, "").strip()
    return Path(env).expanduser().resolve() if env else repo_root()


def derived_dir() -> Path:
    """``<output root>/data/derived`` (``.../smoke`` in a smoke run)."""
    base = output_root() / "data" / "derived"
    return base / "smoke" if _mode == "smoke" else base


def figures_dir() -> Path:
    """``<output root>/paper/figures`` (``paper/smoke/figures`` in a smoke run)."""
    return output_root() / "paper" / ("smoke/figures" if _mode == "smoke" else "figures")


def output_dir() -> Path:
    """``<output root>/paper/output`` (``paper/smoke/output`` in a smoke run)."""
    return output_root() / "paper" / ("smoke/output" if _mode == "smoke" else "output")
