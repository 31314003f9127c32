"""Sphinx configuration of kr210_sim's documentation site (``make docs`` builds it into
``docs/_build/html``; CI builds it with warnings as errors)."""

from __future__ import annotations

import kr210_sim

project = "kr210_sim"
author = "the kr210_sim developers"
copyright = "2026, the kr210_sim developers"
release = kr210_sim.__version__
version = ".".join(release.split(".")[:2])

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.viewcode",
    "sphinxarg.ext",
]
source_suffix = {".md": "markdown"}
exclude_patterns = ["_build", "look", "Thumbs.db", ".DS_Store"]
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3

# The docstrings are Google style (Args/Returns/Raises), with units in the text.
napoleon_google_docstring = True
napoleon_numpy_docstring = False
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "show-inheritance": False}

html_theme = "furo"
html_title = f"kr210_sim {release}"
html_static_path: list[str] = []
