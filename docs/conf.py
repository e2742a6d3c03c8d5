"""Sphinx configuration of the soilbin documentation (`make docs`: docs/_build/html).

Pages are MyST Markdown. The key reference (keys.md) is generated from the scene
records by _ext/scene_keys.py; the API reference imports soilbin (and DOLFINx), so
Sphinx runs with the venv's python. Math is rendered by Debian's MathJax 2, copied
into the build so that the site needs no network.
"""
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path[:0] = [str(DOCS.parent), str(DOCS / "_ext")]

project = "soilbin"
author = "the soilbin developers"
copyright = "the soilbin developers"

extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.mathjax",
              "scene_keys", "api_modules", "offline_mathjax"]
source_suffix = {".md": "markdown"}
exclude_patterns = ["_build", "figures"]   # figures: images only, no pages

# MyST: $...$ and $$...$$ math, \begin{align} blocks, ::: fences, definition lists;
# headings down to ### get anchors, so [x](theory.md#the-interface) links work.
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
# MathJax 2 typesets only what Sphinx marks as math: \(...\) inline, \[...\] displayed.
mathjax_path = "mathjax/MathJax.js?config=TeX-AMS_CHTML"   # _ext/offline_mathjax.py
myst_update_mathjax = False
mathjax2_config = {"tex2jax": {"inlineMath": [["\\(", "\\)"]],
                               "displayMath": [["\\[", "\\]"]]}}

# The docstrings are prose in reStructuredText (no numpy or Google sections: no napoleon).
autodoc_member_order = "bysource"

html_theme = "furo"
html_title = "soilbin"
html_static_path = ["_static"]
html_css_files = ["tables.css"]
html_show_sourcelink = False
