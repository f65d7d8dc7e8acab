"""Sphinx configuration of the coordarm documentation (``make docs``)."""
from __future__ import annotations

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))
os.environ.setdefault("MPLBACKEND", "Agg")

project = "coordarm"
author = "the coordarm developers"
copyright = "coordarm developers, MIT licence"
try:
    from importlib.metadata import version as _version

    release = _version("coordarm")
except Exception:  # pragma: no cover - an uninstalled checkout
    release = "0.1.0"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
    "coordarm_docs",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "figures/README.md", "**/README.md", "auto_examples/*.ipynb",
                    "auto_examples/*.py", "auto_examples/*.zip", "auto_examples/*.json",
                    "auto_examples/*.md5", "auto_examples/*.codeobj.json"]
root_doc = "index"

# MyST: plain Markdown pages (the guide) with $math$, tables, heading anchors for in-page links.
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist", "attrs_inline"]
myst_heading_anchors = 3

# autodoc + numpydoc: the API reference from the docstrings.
autodoc_member_order = "bysource"
autodoc_typehints = "none"          # numpydoc's Parameters sections carry the types
autodoc_default_options = {"members": True}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set = set()

# sphinx-gallery: examples/ at the top of the repository, run when the docs build.
sphinx_gallery_conf = {
    "examples_dirs": str(HERE.parent / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "ignore_pattern": r"__init__\.py|conftest\.py",
    "image_scrapers": ("matplotlib", "gallery_scraper.png_files"),   # docs/_ext/gallery_scraper.py
    "reset_modules": ("matplotlib", "gallery_scraper.reset"),
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "abort_on_example_error": True,
    "show_memory": False,
    "plot_gallery": "True",
}

# Math is typeset by MathJax 3 from its CDN; COORDARM_MATHJAX=file:///.../tex-chtml.js uses a local copy
# (an offline build, e.g. for the screenshots in docs/_static/).
if os.environ.get("COORDARM_MATHJAX"):
    mathjax_path = os.environ["COORDARM_MATHJAX"]

html_theme = "furo"
html_title = f"coordarm {release}"
html_static_path = ["_static"]
html_theme_options = {"source_repository": "", "navigation_with_keys": True}
# Guide pages are plain Markdown written by several hands: a heading that skips a level is cosmetic.
suppress_warnings = ["myst.header"]
nitpicky = False
