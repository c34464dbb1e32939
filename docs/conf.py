"""Sphinx configuration of derive's documentation (MyST Markdown, autodoc with numpydoc, furo).

Build: ``sphinx-build -W -b html docs OUT`` (the tests do, warnings as errors).  The pages'
generated parts (the command line, the API, the contract's tables, the errata, the changelog)
come from the code through docs/_ext/derive_docs.py; the tutorial's figures are made by
running the tutorial's scene during the build (docs/_ext/derive_figures.py).
"""
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))
sys.path.insert(0, str(DOCS.parent))          # the checkout's derive, as the tests import it

import derive  # noqa: E402

project = "derive"
author = "the derive authors"
copyright = "the derive authors, MIT licence"
version = release = derive.__version__

extensions = ["myst_parser", "sphinx.ext.autodoc", "numpydoc", "derive_docs", "derive_figures"]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}   # .rst: numpydoc loads autosummary, which asks for it
exclude_patterns = ["_build", "tutorial/*.md"]
myst_enable_extensions = ["colon_fence", "dollarmath"]
myst_heading_anchors = 3
html_theme = "furo"
html_title = f"derive {release}"
autodoc_member_order = "bysource"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
# Flags and options are written as typed: no "--out" turned into an en dash.
smartquotes = False
