"""Sphinx configuration of the inertiafit documentation.

Build with ``make docs`` or ``python -m sphinx -W --keep-going -b html docs docs/_build/html``.
Offline by design: no intersphinx inventories, no external images, no CDN math.
"""

from __future__ import annotations

import sys
from pathlib import Path

import inertiafit

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))

project = "inertiafit"
author = "inertiafit developers"
copyright = "inertiafit developers, MIT license"
release = inertiafit.__version__
version = ".".join(release.split(".")[:2])

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "inertiafit_docs",  # docs/_ext: CLI reference and shipped-priors table, built from the code
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "**/GALLERY_HEADER.rst", "auto_examples/*.ipynb", "**.py.md5"]
templates_path: list[str] = []
html_static_path = ["_static"]
html_css_files = ["inertiafit.css"]

# --- Markdown (MyST) -------------------------------------------------------------------------
# The team writes the pages in Markdown with GitHub-style links between them ([cli.md](cli.md));
# MyST resolves those to documents. Headings get anchors so "page.md#section" links work.
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3

# --- API reference ---------------------------------------------------------------------------
autodoc_typehints = "none"  # numpydoc sections carry the types, in words and with units
autodoc_member_order = "bysource"
autodoc_default_options: dict[str, object] = {}
autosummary_generate = False  # reference pages are written by hand; nothing is generated
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_attributes_as_param_list = True

# --- Examples gallery ------------------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": "../examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r".*\.py$",  # run every example: the gallery shows real output
    "ignore_pattern": r"__init__\.py",
    # Examples draw onto matplotlib Figure objects (no pyplot, no windows); this scraper finds
    # the Figures an example holds and saves them for the page.
    "image_scrapers": ("inertiafit_docs.figure_scraper",),
    "write_computation_times": False,  # no sg_execution_times.rst in the source tree
    "download_all_examples": False,
    "remove_config_comments": True,
    "show_memory": False,
    "capture_repr": ("_repr_html_", "__repr__"),
    "min_reported_time": 1,
    "abort_on_example_error": True,
    "plot_gallery": "True",
}

# --- HTML ------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"inertiafit {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "navbar_align": "left",
    "header_links_before_dropdown": 7,
    "icon_links": [],
    "use_edit_page_button": False,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_sidebars = {"index": [], "getting-started": []}
html_show_sourcelink = False
html_last_updated_fmt = None
