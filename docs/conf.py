"""Sphinx configuration of the scara_robust documentation (``make docs``)."""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).parent))  # _cli.py

import scara_robust  # noqa: E402

project = "scara_robust"
author = "scara_robust developers"
copyright = "scara_robust developers, BSD-3-Clause"  # noqa: A001
release = version = scara_robust.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "myst_nb",
    "sphinxarg.ext",
]

# the gallery is ../notebooks, reached through the committed symlink docs/gallery
exclude_patterns = ["_build", "**/figures", "**/.ipynb_checkpoints", "gallery/.jupyter_cache"]
templates_path = ["_templates"]
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
root_doc = "index"

# -- API reference ------------------------------------------------------------------------
autosummary_generate = True
autosummary_imported_members = True
autodoc_typehints = "none"  # the numpydoc Parameters sections carry the types, with shapes and units
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
add_module_names = False

# Nitpicky on the package's own names: every reference to scara_robust.* must resolve;
# names of other libraries (numpy, control, pandas...) are not linked (no network here).
nitpicky = True
nitpick_ignore_regex = [(r"py:.*", r"^(?!scara_robust\b).*")]

# -- Notebooks (myst-nb) ------------------------------------------------------------------
# Executed during the build, cached in _build/.jupyter_cache: a rebuild without changes
# executes nothing. SCARA_ROBUST_DOCS_EXECUTE=off renders them unexecuted (the browser test).
nb_execution_mode = os.environ.get("SCARA_ROBUST_DOCS_EXECUTE", "cache")
nb_execution_cache_path = str(Path(__file__).parent / "_build" / ".jupyter_cache")
nb_execution_timeout = 1800
nb_execution_raise_on_error = True
nb_execution_show_tb = True
myst_enable_extensions = ["colon_fence"]  # no dollarmath: MathJax would come from a CDN
myst_heading_anchors = 3

# -- HTML ---------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"scara_robust {release}"
html_static_path = ["_static"]
html_favicon = "_static/favicon.svg"  # also spares the browser a 404 on /favicon.ico
html_theme_options = {
    "navbar_end": ["navbar-icon-links"],
    "show_toc_level": 2,
    "navigation_with_keys": False,
    "footer_start": ["copyright"],
    "footer_end": [],
}
html_show_sourcelink = False
# a page per public name: no section navigation in their sidebar (the theme renders it for every
# page, some 40 % of the build); each keeps its breadcrumbs and its section's index page lists its names
html_sidebars = {"api/generated/*": []}
html_context = {"default_mode": "light"}  # the theme logs an error on a first visit without it


# -- Constants ----------------------------------------------------------------------------
# A public constant is documented by its `#:` comment in the module that defines it; the
# package namespace re-exports it without the comment, so autodoc would show its type's doc.
def _constant_docs() -> dict[str, list[str]]:
    import importlib.util
    import inspect
    import pkgutil

    from sphinx.pycode import ModuleAnalyzer

    constants = [name for name in scara_robust.__all__
                 if not (callable(getattr(scara_robust, name)) or inspect.ismodule(getattr(scara_robust, name)))]
    # only the modules that assign one of them at the top level are parsed (parsing all takes seconds)
    assigns = re.compile(r"^(?:" + "|".join(map(re.escape, constants)) + r")\s*[:=]", re.MULTILINE)
    docs: dict[str, list[str]] = {}
    for info in pkgutil.walk_packages(scara_robust.__path__, prefix="scara_robust."):
        if info.name.endswith("__main__"):
            continue
        origin = importlib.util.find_spec(info.name).origin  # type: ignore[union-attr]
        if origin is None or not assigns.search(Path(origin).read_text(encoding="utf-8")):
            continue
        for (owner, name), lines in ModuleAnalyzer.for_module(info.name).find_attr_docs().items():
            if owner == "" and name in scara_robust.__all__:
                docs.setdefault(name, list(lines))
    return docs


CONSTANT_DOCS = _constant_docs()


#: `|e|`, `|ṗ|`, `|Tc|`: an absolute value in a docstring, not a reST substitution.
ABSOLUTE_VALUE = re.compile(r"(?<![\\\w|])\|([^|\s`][^|\s]{0,11})\|(?![\w|])")


def _constant_docstring(app, what, name, obj, options, lines):  # noqa: ANN001
    short = name.removeprefix("scara_robust.")
    if what in ("data", "attribute") and short in CONSTANT_DOCS:
        lines[:] = CONSTANT_DOCS[short]
    lines[:] = [ABSOLUTE_VALUE.sub(r"\\|\1\\|", line) for line in lines]


def setup(app):  # noqa: ANN001
    app.connect("autodoc-process-docstring", _constant_docstring)
