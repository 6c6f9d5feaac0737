"""Absolute paths of the studies (one place, so no script depends on the working folder).

Everything a study writes lives under an *output root*: the repository root by default, or the
folder named by the environment variable ``DUFFSYM_OUTPUT_ROOT`` (the smoke tests point it at a
temporary folder). The variable is read on every call, so it can be set after import.

- ``repo_root()``    the duffsym checkout (parent of ``studies/``).
- ``output_root()``  ``$DUFFSYM_OUTPUT_ROOT`` or ``repo_root()``.
- ``derived_dir()``  ``<output root>/data/derived``: computed arrays (``.npz``) and provenance (``.json``).
- ``figures_dir()``  ``<output root>/paper/figures``: the PNG figures.
- ``output_dir()``   ``<output root>/paper/output``: numbers quoted in ``paper/ms.tex`` (``.tex``).
"""
from __future__ import annotations

import os
from pathlib import Path

ENV_VAR = "DUFFSYM_OUTPUT_ROOT"
STUDIES = Path(__file__).resolve().parent
STYLE = STUDIES / "duffsym.mplstyle"


def repo_root() -> Path:
    """The repository root (the folder holding ``studies/``)."""
    return STUDIES.parent


def output_root() -> Path:
    """Root of everything the studies write: ``$DUFFSYM_OUTPUT_ROOT`` if set, else the repository root."""
    env = os.environ.get(ENV_VAR, "").strip()
    return Path(env).expanduser().resolve() if env else repo_root()


def derived_dir() -> Path:
    """``<output root>/data/derived``."""
    return output_root() / "data" / "derived"


def figures_dir() -> Path:
    """``<output root>/paper/figures``."""
    return output_root() / "paper" / "figures"


def output_dir() -> Path:
    """``<output root>/paper/output``."""
    return output_root() / "paper" / "output"
