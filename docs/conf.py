"""Sphinx configuration of the evsim documentation.

Build (from the repository root; needs the `docs` extra, ``pip install -e ".[docs]"``):

    sphinx-build -W --keep-going -b html docs docs/_build/html

then open docs/_build/html/index.html. The build needs no network (no intersphinx) and runs the examples gallery
(examples/0*.py, a couple of minutes on two cores); ``-D plot_gallery=0`` skips running it. The results pages
(docs/results/) are committed; ``python docs/make_results.py`` regenerates them.
"""

from __future__ import annotations

import os
import sys
import tomllib
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))  # the checkout's packages, installed or not
sys.path.insert(0, str(DOCS / "_ext"))

import evsim_docs  # noqa: E402

project = "evsim"
author = "the evsim authors"
copyright = "the evsim authors, MIT licence"
release = version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "evsim_docs",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "auto_examples/*.ipynb", "auto_examples/*.py",
                    "auto_examples/*.zip", "auto_examples/*.json", "auto_examples/*.codeobj.json",
                    "auto_lessons/*.ipynb", "auto_lessons/*.py", "auto_lessons/*.zip", "auto_lessons/*.json",
                    "lessons"]  # the lessons' sources: sphinx-gallery builds auto_lessons from them
templates_path = ["_templates"]
# `name` in a docstring is code (the docstrings are plain text; evsim_docs.prose_to_rst keeps their backticks)
default_role = "literal"

# Markdown pages (user guide, models): $...$ and $$...$$ math, ::: fences, heading anchors for links
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist", "attrs_inline"]
myst_heading_anchors = 3

# the API reference: docs/api/<module>.rst written from every module's __all__ (evsim_docs.write_api_pages), and
# one page per name (autosummary, into docs/api/generated/)
evsim_docs.write_api_pages(DOCS / "api")
autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "signature"
autodoc_class_signature = "separated"
autodoc_preserve_defaults = True
# The docstrings are prose first: numpydoc renders them whether or not they use its sections, lists no class
# members on its own (the class template does, with autodoc) and validates nothing (its validator needs every
# object's source, which numba kernels and jitted functions do not have); evsim_docs warns about public names
# without documentation.
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

# no network during the build: no intersphinx inventories
intersphinx_mapping: dict = {}

sphinx_gallery_conf = {
    # the examples, and the lessons (docs/lessons/: the teaching lab's computations, with its panels in Jupyter)
    "examples_dirs": [str(ROOT / "examples"), str(ROOT / "docs" / "lessons")],
    "gallery_dirs": ["auto_examples", "auto_lessons"],
    "filename_pattern": r"/\d\d_[^/]*\.py$",  # run every numbered example
    "ignore_pattern": r"(_shared|make_readme_figures)\.py$",
    "within_subsection_order": "FileNameSortKey",  # the teaching order, 01 to 06
    # names of evsim in the examples' code link to their API pages, and each API page lists the examples using it
    "doc_module": evsim_docs.PACKAGES,
    "reference_url": dict.fromkeys(evsim_docs.PACKAGES),
    "backreferences_dir": "api/backreferences",
    "image_scrapers": ("matplotlib", "evsim_docs.saved_figures_scraper"),
    "reset_argv": "evsim_docs.gallery_argv",
    "download_all_examples": False,
    "remove_config_comments": True,
    "show_memory": False,
    "min_reported_time": 1,
    "abort_on_example_error": True,
    "only_warn_on_example_error": False,
    "capture_repr": (),
    "matplotlib_animations": False,
    "plot_gallery": "True",
    # EVSIM_DOCS_RUN_ALL=1 (tests/test_docs.py) runs every example, not only those changed since the last build
    "run_stale_examples": os.environ.get("EVSIM_DOCS_RUN_ALL") == "1",
}

html_theme = "pydata_sphinx_theme"
html_title = f"evsim {version}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "header_links_before_dropdown": 8,
    "secondary_sidebar_items": ["page-toc", "sourcelink"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_static_path: list[str] = []
html_show_sourcelink = True
html_last_updated_fmt = None

nitpicky = True
# names of other projects (no intersphinx: the build is offline) and typing helpers in signatures
nitpick_ignore_regex = [
    ("py:(class|obj|data|func|meth|attr|exc|mod)", r"(numpy|np|npt|numpy\.typing|scipy|matplotlib|dask|distributed"
                                                   r"|h5py|cv2|colour|tonic|dv_processing|dv|numba|pathlib|os|io"
                                                   r"|typing|collections|types|concurrent|dataclasses)(\..*)?"),
    ("py:(class|obj|data)", r"(ArrayLike|NDArray|Path|Any|Callable|Iterable|Iterator|Sequence|Mapping|Generator"
                            r"|Self|Literal|Figure|Axes|ModuleType|Client|Future|LocalCluster|FloatValues|DTypeLike"
                            r"|Optional|Union|PathLike|BinaryIO|TextIO)"),
    ("py:(class|obj)", r"(int|float|str|bool|bytes|dict|list|tuple|set|frozenset|object|None|type|callable"
                       r"|optional|array|array_like|ndarray|sequence|iterable|mapping|path|file|abc\.ABC)"),
    # private names (a base class, a helper type) and type aliases defined for type checkers only
    ("py:(class|obj|data)", r"(.*\.)?_\w+|Setting|ScoreTable|KeepMask|SceneRecipe|.*\[.*"),
]
