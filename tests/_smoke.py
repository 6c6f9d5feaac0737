"""Run one study with ``--smoke`` into a temporary output root (shared by the studies' smoke tests)."""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import numpy as np
import pytest


def run_smoke(tmp_path_factory, study: str) -> tuple[Path, int, dict, dict, object]:
    """``(root, exit code, derived JSON, derived arrays, module)`` of ``study``'s smoke run; the derived
    files are ``{}`` when the study wrote none (e.g. its data were absent)."""
    root = tmp_path_factory.mktemp(study.split("_")[0])
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("DUFFSYM_OUTPUT_ROOT", str(root))
        module = importlib.import_module(study)  # studies/ is on the path (conftest)
        code = module.main(["--smoke"])
    derived = root / "data" / "derived" / "smoke"
    meta_file, npz = derived / f"{study}.json", derived / f"{study}.npz"
    meta = json.loads(meta_file.read_text()) if meta_file.is_file() else {}
    arrays = {}
    if npz.is_file():
        with np.load(npz) as f:
            arrays = {k: f[k] for k in f.files}
    return root, code, meta, arrays, module
