"""Sphinx configuration of the duffsym documentation.

Build (from the checkout root, after ``pip install -e ".[docs]"``)::

    python -m sphinx -W --keep-going -b html docs docs/_build/html

Why Sphinx: it is what the packages duffsym stands beside use (scikit-learn, pysindy, lmfit, emcee,
PINTS), numpydoc reads the numpy-style docstrings the package already has, sphinx-gallery runs the
examples on the shipped data at every build, the CLI reference is generated from the
parser itself, and MyST lets the guides be Markdown (the same text as the README, so guide text moves
between them unchanged). ``docs/_ext/duffsym_docs.py`` writes the derivation pages from the
package's own LaTeX output (:func:`duffsym.derive.derivation_report`) at build time.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE / "_ext"))
os.environ.setdefault("MPLBACKEND", "Agg")

import duffsym  # noqa: E402

project = "duffsym"
author = "duffsym developers"
copyright = "duffsym developers"
release = version = duffsym.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "sphinx_copybutton",
    "duffsym_docs",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_generated/cli_commands.rst", "_generated/models_table.rst", "auto_examples/*.ipynb",
                    "auto_examples/*.py", "auto_examples/*.zip", "auto_examples/*.md5",
                    "auto_examples/*.codeobj.json", "auto_examples/*.json"]
templates_path = ["_templates"]

myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_typehints = "none"  # numpydoc renders the types written in the docstrings
autodoc_member_order = "bysource"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_validation_checks: set[str] = set()
autosummary_generate = False

sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": str(HERE / "auto_examples"),
    "filename_pattern": r"/plot_",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "abort_on_example_error": True,
    "reset_modules": ("matplotlib",),
    "ignore_pattern": r"(__init__\.py|_data\.py)",
    "matplotlib_animations": False,
}

html_theme = "pydata_sphinx_theme"
html_title = f"duffsym {release}"
html_static_path = ["_static"]
html_css_files = ["duffsym.css"]
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": [],
}
html_sidebars = {"index": [], "getting_started": []}
html_show_sourcelink = False

# MathJax comes from its CDN when the page is read; DUFFSYM_DOCS_MATHJAX may name a local copy
# (a path relative to the built site, e.g. for viewing offline).
if os.environ.get("DUFFSYM_DOCS_MATHJAX"):
    mathjax_path = os.environ["DUFFSYM_DOCS_MATHJAX"]

nitpicky = False
suppress_warnings = ["myst.header"]
