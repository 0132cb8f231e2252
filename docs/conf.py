"""Sphinx configuration of the neweul-py documentation.

Build (from the repository root, warnings as errors)::

    pip install -e '.[docs]' && sphinx-build -W -b html docs docs/_build/html

The Markdown pages are read by MyST (through myst-nb), the API reference is generated from the
numpydoc docstrings (autodoc, napoleon, autosummary), and the example scripts of the gallery
(jupytext percent scripts in ``examples/notebooks/``, reached through the link
``docs/examples`` that this file makes) are executed by the build, their figures included.
"""

from __future__ import annotations

import os
from importlib.metadata import version as _version
from pathlib import Path

# The example notebooks live in ``examples/notebooks``; Sphinx reads sources below ``docs``
# only, so the build reaches them through the link ``docs/examples`` (made here, not tracked).
_EXAMPLES = Path(__file__).resolve().parent / "examples"
if not _EXAMPLES.exists():
    _EXAMPLES.symlink_to(Path("..") / "examples", target_is_directory=True)

# The notebooks' kernels start with matplotlib's inline backend, as a Jupyter user's does after
# ``%matplotlib inline``: a cell ending in a Figure (``result_figure``, ``response.plot()``)
# shows it as a picture.
_IPYTHONDIR = Path(__file__).resolve().parent / "_build" / "ipython"
(_IPYTHONDIR / "profile_default" / "startup").mkdir(parents=True, exist_ok=True)
(_IPYTHONDIR / "profile_default" / "startup" / "00-inline-figures.py").write_text(
    'get_ipython().run_line_magic("matplotlib", "inline")\n', encoding="utf-8")
os.environ["IPYTHONDIR"] = str(_IPYTHONDIR)

project = "neweul-py"
author = "the neweul-py authors"
copyright = "neweul-py authors, BSD-3-Clause"
release = _version("neweul-py")
version = release

extensions = [
    "myst_nb",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
]

# --- sources -------------------------------------------------------------------------------
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".py": "myst-nb"}
root_doc = "index"
# Only the pages and the example notebooks; the rest of the linked examples tree (descriptions,
# data builders, studies) is not a page.
include_patterns = [
    "*.md",
    "howto/*.md",
    "api/*.rst",
    "api/generated/*.rst",
    "examples/notebooks/*.py",
]
exclude_patterns = ["_build", "**/.ipynb_checkpoints"]
templates_path = ["_templates"]

# --- MyST and notebooks ----------------------------------------------------------------------
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
nb_custom_formats = {".py": ["jupytext.reads", {"fmt": "py:percent"}]}
nb_execution_mode = "force"
nb_execution_timeout = 600
nb_execution_raise_on_error = True
nb_merge_streams = True

# --- API reference ---------------------------------------------------------------------------
autosummary_generate = True
autosummary_ignore_module_all = True
autosummary_imported_members = False
autodoc_default_options = {"members": True, "show-inheritance": True, "ignore-module-all": True}
autodoc_typehints = "description"
autodoc_member_order = "bysource"
autodoc_mock_imports = ["dask", "distributed", "cffi", "pyarrow"]
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False
# numpydoc types such as ``ndarray (n, k)`` are read as cross-references; ``n`` then matches the
# attribute ``n`` of several classes. Such ambiguous type words are not errors of the pages.
suppress_warnings = ["ref.python"]

# --- HTML ------------------------------------------------------------------------------------
html_theme = "furo"
html_title = f"neweul-py {release}"
html_static_path: list[str] = []

