"""The documentation site: Sphinx with MyST (the pages are markdown) and the Furo theme.

    pip install ".[docs]" && sphinx-build -W docs site      # then open site/index.html

Strict (-W): a broken link or anchor, a page missing from the table of contents, or a
generated figure whose file or section has gone stops the build (tests/test_docs_site.py
builds it so). Figures come from generated files through _ext/generated.py.
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent / "_ext"))

project = "physval"
author = "the physval developers"
extensions = ["myst_parser", "generated"]
source_suffix = {".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_ext"]

myst_heading_anchors = 4  # [text](page.md#a-heading): GitHub's anchors, checked at build time
suppress_warnings = []

html_theme = "furo"
html_title = "physval"
html_permalinks_icon = "#"
html_show_sourcelink = False
html_copy_source = False
