"""Sphinx configuration of the fenics-plast user guide (``make docs``; Debian's python3-sphinx and
python3-myst-parser: Sphinx 5.3 / MyST 0.18 on Debian 12, Sphinx 8.1 / MyST 4.0 on Debian 13).

The pages are the Markdown files of ``docs/`` (``docs/guide/*.md`` and the reference pages beside
them); ``make docs`` builds them into ``docs/_build/html`` with warnings as errors, so a broken link,
a missing page or a literal include whose marker text has gone fails the build. The Python API page
shows each docstring as written (a literal block, its cross-reference roles and literal quotes read off),
not parsed as reStructuredText: the package's docstrings are plain text with units and shapes, read in the
source as often as here, and a docstring need not be valid reStructuredText for the guide to build.
"""
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
import fenics_plast  # noqa: E402  (the version, and autodoc imports the package)

project = "fenics-plast"
author = "the fenics-plast developers"
copyright = "2026, " + author
version = release = fenics_plast.__version__

extensions = ["myst_parser", "sphinx.ext.autodoc"]
source_suffix = {".md": "markdown"}
root_doc = master_doc = "index"                  # master_doc: Sphinx 5's name for it
exclude_patterns = ["_build", "studies/*/study.md", "tutorial"]
myst_heading_anchors = 3                         # [text](page.md#a-heading) links to headings

html_theme = "alabaster"
html_title = "fenics-plast user guide"
html_theme_options = {"description": "Finite-strain elastoplasticity for metal forming and impact, on FEniCSx",
                      "fixed_sidebar": True, "page_width": "1200px", "sidebar_width": "250px"}
html_sidebars = {"**": ["about.html", "navigation.html", "searchbox.html"]}
html_show_sourcelink = False

autodoc_member_order = "bysource"
autodoc_default_options = {"members": True}


#: a cross-reference role in a docstring, :class:`~a.b.C` or :func:`a.b.f`, shown as its target's name
_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|data|attr|exc|obj):`(~?)([^`]+)`")


def _plain(line: str) -> str:
    """A docstring line with its reStructuredText markup read off: roles as their names (``~`` keeps the
    last part, as Sphinx shows it), ``literal`` as literal."""
    line = _ROLE.sub(lambda m: m.group(2).rsplit(".", 1)[-1] if m.group(1) else m.group(2), line)
    return line.replace("``", "")


def _docstring_as_written(app, what, name, obj, options, lines):
    """Show a docstring as a literal block, as the source has it less its markup (see the module docstring)."""
    if lines:
        lines[:] = [".. code-block:: text", ""] + ["    " + _plain(line) for line in lines] + [""]


def setup(app):
    app.connect("autodoc-process-docstring", _docstring_as_written)
