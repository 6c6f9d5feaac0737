"""The README's code blocks run as written, in order, in a fresh folder (issue 11).

Every fenced ``bash`` and ``python`` block of README.md is extracted and run top to bottom in a
temporary folder holding a copy of ``data/`` (the README says to run from the checkout root).
Skipped, with the reason printed: ``pip install`` (the test already runs inside the installed
package), ``duffsym reproduce`` (the studies have their own smoke tests,
``tests/test_studies_*smoke.py``) and the test-suite line (this test is part of it). The long
diagnosis lines (``diagnose``, ``ladder``: 25 s to 2 min on a busy 2-core machine) run only under
``-m slow``; no later line depends on their outputs.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
SKIP = {
    "pip install": "installs the package (the test runs inside the installed package)",
    "duffsym reproduce": "runs the studies (tests/test_studies_*smoke.py cover them)",
    "python -m pytest": "runs the test suite (this test is part of it)",
}
SLOW = ("duffsym diagnose", "duffsym ladder")


def readme_blocks(text: str) -> list[tuple[str, str]]:
    """(language, code) of every fenced bash/python block, in order."""
    return [(m.group(1), m.group(2)) for m in re.finditer(r"^```(bash|python)\n(.*?)^```", text, re.M | re.S)]


def bash_lines(code: str) -> list[str]:
    """The commands of a bash block: continuation lines joined, blank and comment lines dropped."""
    out, cur = [], ""
    for line in code.splitlines():
        if line.rstrip().endswith("\\"):
            cur += line.rstrip()[:-1] + " "
            continue
        cur += line
        if cur.strip() and not cur.lstrip().startswith("#"):
            out.append(cur.strip())
        cur = ""
    return out


#: lines that need the real third-party data (never shipped); skipped, saying so, when it is absent
EXTERNAL = ("DUFFSYM_EXTERNAL_DATA", "real.csv")


def _external() -> str | None:
    from duffsym.data.loaders import external_data_dir
    from duffsym.errors import DuffsymError

    try:
        return str(external_data_dir())
    except DuffsymError:
        return None


def _env(tmp: Path) -> dict:
    env = dict(os.environ, MPLBACKEND="Agg")
    if _external():
        env["DUFFSYM_EXTERNAL_DATA"] = _external()
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    env.setdefault("DUFFSYM_CACHE", str(tmp / ".cache"))
    return env


def _run_readme(tmp_path: Path, include_slow: bool) -> list[str]:
    shutil.copytree(ROOT / "data", tmp_path / "data", ignore=shutil.ignore_patterns("derived"))
    env, skipped, ran = _env(tmp_path), [], 0
    blocks = readme_blocks(README.read_text(encoding="utf-8"))
    assert len(blocks) >= 4, "README.md lost its code blocks"
    for i, (lang, code) in enumerate(blocks):
        if lang == "python":
            script = tmp_path / f"block{i}.py"
            script.write_text(code)
            proc = subprocess.run(
                [sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300
            )
            assert proc.returncode == 0, f"README python block {i} failed:\n{code}\n{proc.stderr[-3000:]}"
            ran += 1
            continue
        for line in bash_lines(code):
            why = next((reason for key, reason in SKIP.items() if key in line), None)
            if why is None and _external() is None and any(key in line for key in EXTERNAL):
                why = "needs the real data (DUFFSYM_EXTERNAL_DATA), absent here"
            if why is None and not include_slow and any(key in line for key in SLOW):
                why = "long (runs under -m slow)"
            if why:
                skipped.append(f"{line[:70]}: {why}")
                continue
            proc = subprocess.run(
                ["bash", "-e", "-o", "pipefail", "-c", line],
                cwd=tmp_path,
                env=env,
                capture_output=True,
                text=True,
                timeout=600,
            )
            assert proc.returncode == 0, f"README line failed (exit {proc.returncode}):\n{line}\n{proc.stderr[-3000:]}"
            ran += 1
    print("README: ran", ran, "blocks/lines; skipped:\n  " + "\n  ".join(skipped))
    return skipped


@pytest.mark.slow
@pytest.mark.ci
def test_readme_blocks_run_in_order(tmp_path):
    skipped = _run_readme(tmp_path, include_slow=False)
    # what the lines made exists and is what they claim (a record, a fit, a plot)
    made = ["sim.csv", "loops.png", "fit.json", "fit.png", "from_mat.csv", "campaign.json", "val.png"]
    for name in made:
        assert (tmp_path / name).stat().st_size > 0, name
    assert all(any(k in s for k in ("pip install", "reproduce", "pytest", "long", "real data")) for s in skipped)


@pytest.mark.slow
def test_readme_blocks_run_in_order_with_the_long_lines(tmp_path):
    _run_readme(tmp_path, include_slow=True)
    assert (tmp_path / "diag" / "diagnosis.md").is_file()


def test_block_extraction_handles_continuations():
    text = "x\n```bash\n# c\nduffsym a \\\n  --b\n\nduffsym c\n```\n```python\nprint(1)\n```\n```\nnot run\n```\n"
    blocks = readme_blocks(text)
    assert [b[0] for b in blocks] == ["bash", "python"]
    assert bash_lines(blocks[0][1]) == ["duffsym a    --b", "duffsym c"]


def test_files_named_in_docstrings_exist():
    """Docstrings point to files of the repository (``docs/contract.md``, ``data/...``), not to missing ones."""
    named = set()
    for path in (ROOT / "src" / "duffsym").rglob("*.py"):
        named |= {(path, m) for m in re.findall(r"``((?:docs|data|paper|studies)/[\w./-]+\.\w+)``", path.read_text())}
    assert any(m == "docs/contract.md" for _, m in named)
    missing = [f"{p.relative_to(ROOT)}: {m}" for p, m in named if not (ROOT / m).exists() and "*" not in m]
    assert not missing, missing
    bare = [str(p.relative_to(ROOT)) for p in (ROOT / "src").rglob("*.py") if "``contract.md``" in p.read_text()]
    assert not bare, f"say docs/contract.md: {bare}"


def test_shipped_synthetic_records_are_what_make_examples_makes():
    """data/make_examples.py regenerates the shipped synthetic records (same samples to 1e-12; the campaign's,
    written with 7 significant digits, to 1e-6) and their truth."""
    import importlib.util
    import json

    import numpy as np

    from duffsym.data import read_csv

    spec = importlib.util.spec_from_file_location("make_examples", ROOT / "data" / "make_examples.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    truth = json.loads((ROOT / "data" / "synthetic_truth.json").read_text())
    for name, rec in mod._records().items():
        shipped = read_csv(ROOT / "data" / f"{name}.csv")
        np.testing.assert_allclose(shipped.y, rec.y, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(shipped.d, rec.d, rtol=1e-12, atol=1e-12)
        assert truth[name]["params"] == dict(rec.metadata["truth"]) and truth[name]["n_samples"] == rec.n_times
    for name, cols in mod._campaign_records().items():  # numpy-only records, written with 7 digits
        shipped = read_csv(ROOT / "data" / f"{name}.csv")
        np.testing.assert_allclose(shipped.y, cols["force"], rtol=1e-6, atol=1e-6 * np.abs(cols["force"]).max())
        np.testing.assert_allclose(shipped.d, cols["displacement"], rtol=1e-6, atol=1e-7)
        assert shipped.current == cols["current"][0] and truth[name]["params"] == mod.CAMPAIGN_TRUTH
