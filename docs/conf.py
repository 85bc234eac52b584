"""Sphinx configuration: the guides are MyST Markdown, the API reference autodoc.

Build with ``make docs`` (``sphinx-build -W --keep-going -b html docs docs/_build/html``).
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import humanoid  # noqa: E402

project = "humanoid"
author = "the humanoid authors"
copyright = "the humanoid authors, BSD-3-Clause"  # noqa: A001
version = release = humanoid.__version__

extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.napoleon"]
source_suffix = {".md": "markdown"}
root_doc = "index"
# the tables that the benchmarks, the studies and the walks write (pasted into the guides by
# scripts/readme_tables.py) are sources of the guides, not pages of their own
exclude_patterns = ["_build", "bench/*.md", "studies/*.md", "walks/*.md"]

myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath"]

napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_ivar = True  # a dataclass's fields are documented once, as its fields

autodoc_member_order = "bysource"
autodoc_typehints = "none"
# a module documents what it defines: a name it imports (and lists in __all__) is documented
# where it is defined
autodoc_default_options = {"members": True, "show-inheritance": True, "ignore-module-all": True}

html_theme = "alabaster"
html_title = f"humanoid {release}"
html_static_path: list[str] = []


# The docstrings are prose with formulas in them (|J v|, a * b): outside inline literals, roles
# and literal blocks, a | or a * is the character itself, not reStructuredText's substitution
# or emphasis (and the _ before a * no reference). A backslash put in takes one space out of
# the next run of spaces, so that the columns of a simple table stay where they were.
_LITERAL = re.compile(r"(``.+?``|:[\w:]+:`[^`]*`|`[^`]*`_?)")
_SPECIAL = re.compile(r"_?\*|\|")
_SECTION = re.compile(r"^(\s*)(Args|Arguments|Attributes|Returns|Raises|Yields):\s*$")


def _plain(line: str) -> str:
    parts = _LITERAL.split(line)
    for i in range(0, len(parts), 2):  # the even parts lie outside literals and roles
        parts[i] = _SPECIAL.sub(lambda m: "".join("\0" + c for c in m.group()), parts[i])
    out, debt = [], 0
    for run in re.split(r"(\0|  +)", "".join(parts)):
        if run == "\0":
            out.append("\\")
            debt += 1
        elif run.startswith("  ") and debt:
            cut = min(debt, len(run) - 1)
            out.append(run[cut:])
            debt -= cut
        else:
            out.append(run)
    return "".join(out)


def _docstring(app, what, name, obj, options, lines: list[str]) -> None:
    out, literal, section, fixing = [], None, None, None
    for line in lines:
        indent = len(line) - len(line.lstrip())
        if literal is not None and line.strip() and indent <= literal:
            literal = None
        if not line.strip():
            section = fixing = None
        elif fixing or (section is not None and indent <= section):
            line = "    " + line  # a section whose entries are not indented under it
            fixing = True
        section = None
        if literal is not None or line.lstrip().startswith(">>>"):
            out.append(line)
            continue
        out.append(_plain(line))
        if line.rstrip().endswith("::"):
            literal = indent
        match = _SECTION.match(line)
        if match:
            section = len(match.group(1))
    lines[:] = out


def setup(app):
    app.connect("autodoc-process-docstring", _docstring, priority=400)
