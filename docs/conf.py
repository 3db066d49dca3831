"""Sphinx configuration of the rigid_env manual (MyST Markdown pages, furo theme).

Build: ``.venv/bin/python -m sphinx -W --keep-going -b html docs docs/_build/html``.
The references (scene file, env keywords, training config, command line, each env's
docstring) are written from the code at every build by ``_ext/rigid_docs.py``.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE / "_ext"), str(HERE.parent)]
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("MPLBACKEND", "Agg")

project = "rigid_env"
author = "rigid_env contributors"
copyright = "2026, rigid_env contributors"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "rigid_docs",
]
myst_enable_extensions = ["colon_fence", "dollarmath"]
myst_heading_anchors = 3
source_suffix = {".md": "markdown"}
exclude_patterns = ["_build", "_generated", "results", "figures", "README.md"]
suppress_warnings = ["myst.header"]  # a generated docstring may start below level 1

html_theme = "furo"
html_title = "rigid_env"
html_static_path = ["_static"]
html_css_files = ["custom.css"]

autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_type_aliases = {"ArrayLike": "ArrayLike"}
autodoc_default_options = {"members": True, "undoc-members": False}
napoleon_google_docstring = True
napoleon_numpy_docstring = False
nitpicky = False
