"""The documentation site (docs/): its generated pages say what the package says, and it builds.

The fast tests check the build-time generators of ``docs/_ext/duffsym_docs.py`` against the package
itself (every CLI command and option is on the CLI page; the theory page carries the LaTeX of
:func:`duffsym.derive.derivation_report`; reST escaping). The full build (``sphinx -W``: zero
warnings, the gallery executed on the shipped data) runs under ``-m slow`` when the ``docs`` extra
is installed; CI runs the same build in ``.ci/run``.
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def _ext():
    spec = importlib.util.spec_from_file_location("duffsym_docs", DOCS / "_ext" / "duffsym_docs.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_cli_page_lists_every_command_and_option():
    from duffsym.cli import build_parser

    page = _ext().cli_page()
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    assert len(sub.choices) >= 13
    for name, parser in sub.choices.items():
        assert f"duffsym {name}\n" in page, name
        for action in parser._actions:
            for opt in action.option_strings:
                if opt not in ("-h", "--help"):
                    assert f"``{opt}" in page or f", {opt}" in page, f"{name} {opt}"


def test_derivation_page_is_the_package_latex():
    from duffsym.derive import derivation_report
    from duffsym.model import get_model

    page = _ext().derivation_page("mr-damper", 5, "MR damper")
    report = derivation_report(get_model("mr-damper", 5))
    for item in report.items:
        assert item.title in page
        for line in item.latex.split(" \\\\ "):
            assert line.strip() in page, (item.key, line[:60])
    # the Lyapunov derivative of Eq. 7/9 for n = 5: only dissipation is left
    assert "\\dot V = - c_{3} x_{2}^{6} - x_{2}^{2} \\left(c_{1} + c_{2}\\right)" in page


def test_rst_escaping():
    ext = _ext()
    assert ext.escape_bars("A_f = max|y| and ``|x|``") == "A_f = max\\|y\\| and ``|x|``"
    assert ext.escape_bars("| a | b |") == "| a | b |"  # a table row stays
    assert ext.rst_text("x*y |a| _b `c`") == "x\\*y \\|a\\| \\_b \\`c\\`"


def test_every_guide_and_api_page_is_in_a_toctree():
    text = "\n".join(p.read_text() for p in DOCS.rglob("*.md")) + "\n".join(p.read_text() for p in DOCS.rglob("*.rst"))
    for page in list((DOCS / "guides").glob("*.md")) + list((DOCS / "api").glob("*.rst")):
        if page.stem != "index":
            assert f"\n{page.stem}\n" in text or f"   {page.stem}\n" in text, page


@pytest.mark.slow
def test_docs_build_without_warnings(tmp_path):
    for mod in ("sphinx", "numpydoc", "sphinx_gallery", "pydata_sphinx_theme", "myst_parser"):
        pytest.importorskip(mod, reason="the docs extra is not installed (pip install -e '.[docs]')")
    out = tmp_path / "html"
    proc = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", str(DOCS), str(out)],
        capture_output=True,
        text=True,
        timeout=900,
        cwd=ROOT,
    )
    assert proc.returncode == 0, proc.stderr[-4000:]
    for page in (
        "index",
        "getting_started",
        "guides/fit_a_record",
        "theory/index",
        "api/identify",
        "reference/cli",
        "_generated/derivations_mr_damper",
        "auto_examples/plot_fit_and_validate",
    ):
        assert (out / f"{page}.html").is_file(), page
    # the gallery ran: the fit example printed its validation and drew its figure
    html = (out / "auto_examples" / "plot_fit_and_validate.html").read_text()
    assert "free-run NRMSE" in html and list((out / "_images").glob("sphx_glr_plot_fit_and_validate_*.png"))
