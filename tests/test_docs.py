"""The documentation: the API reference lists every public name, every public name is documented, docstring
examples run, plain-text docstrings convert to valid reStructuredText, and (slow) the Sphinx site builds with
warnings as errors, its examples gallery executed and rendered."""

import doctest
import importlib
import inspect
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
sys.path.insert(0, str(DOCS / "_ext"))
import evsim_docs  # noqa: E402

PACKAGES = ("crf_models", "sim", "akf", "generators", "evsim_eval", "evsim_app")


def test_the_reference_documents_every_package_and_every_module_with_all():
    modules = evsim_docs.api_modules()
    assert set(PACKAGES) <= set(modules)
    for pkg in PACKAGES:  # every submodule that declares a public API
        for path in (ROOT / pkg).rglob("*.py"):
            rel = path.relative_to(ROOT).with_suffix("")
            parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
            if not any(p.startswith("_") for p in parts) and "__all__" in path.read_text():
                assert ".".join(parts) in modules, f"{'.'.join(parts)} defines __all__ but has no API page"


def test_every_name_of_every_all_is_listed_on_its_page():
    layout = evsim_docs.api_layout()
    for mod_name, rows in layout.items():
        page = evsim_docs.module_page(mod_name, rows)
        entries = set(re.findall(r"^   ~?([\w.]+)$", page, flags=re.M))
        for name in importlib.import_module(mod_name).__all__:
            assert name in entries or any(e.endswith(f".{name}") for e in entries), f"{mod_name}.{name} not listed"


def test_every_public_name_is_documented():
    docs = evsim_docs.constant_docs()
    missing = []
    for mod_name, rows in evsim_docs.api_layout().items():
        mod = importlib.import_module(mod_name)
        if not (mod.__doc__ or "").strip():
            missing.append(mod_name)
        for name, kind, _ in rows:
            obj = getattr(mod, name)
            doc = docs.get(id(obj)) if kind == "data" else inspect.getdoc(obj)
            if not doc:
                missing.append(f"{mod_name}.{name}")
    assert not missing, "public names without documentation (a docstring, or a comment where a constant is set):\n" \
                        + "\n".join(missing)


def test_docstring_examples_run():
    finder, runner = doctest.DocTestFinder(), doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    for mod_name in evsim_docs.api_modules():
        for test in finder.find(importlib.import_module(mod_name)):
            runner.run(test)
    assert runner.summarize(verbose=False).failed == 0


def test_plain_text_docstrings_become_restructuredtext():
    text = """Summary line.

A paragraph with **kwargs, |t| and name_ that
wraps.
alpha, beta: two fields
gamma: a field whose text
    continues here.
Heading:
    delta: nested
    epsilon: nested too
- a list item
  continued

An example:

    python run.py --flag
        indented more
"""
    rst = evsim_docs.prose_to_rst(text.splitlines() + [""])
    assert "A paragraph with \\*\\*kwargs, \\|t\\| and name\\_ that wraps." in rst
    assert "- **alpha, beta**: two fields" in rst
    assert "- **gamma**: a field whose text continues here." in rst
    assert "- **delta**: nested" in rst and "Heading:" in rst
    assert "- a list item continued" in rst
    k = rst.index("An example::")
    assert rst[k + 1:k + 4] == ["", "    python run.py --flag", "        indented more"]


def test_an_array_constant_is_documented_by_its_comment_not_by_numpy():
    # autodoc gives a module-level array the docstring of numpy.ndarray (with its text signature); the API page
    # shows the comment where the constant is set instead
    sphinx_inspect = pytest.importorskip("sphinx.util.inspect")
    from sphinx.util.docstrings import prepare_docstring

    realism = importlib.import_module("evsim_eval.realism")
    lines = prepare_docstring(sphinx_inspect.getdoc(realism.INTERVAL_EDGES_US, getattr, True, realism,
                                                    "INTERVAL_EDGES_US"))
    assert "ndarray" in "\n".join(lines)
    evsim_docs.process_docstring(None, "data", "evsim_eval.realism.INTERVAL_EDGES_US", realism.INTERVAL_EDGES_US,
                                 None, lines)
    text = "\n".join(lines)
    assert "log bins of the same-pixel inter-event-interval histogram" in text and "ndarray" not in text


def _have_sphinx() -> bool:
    for name in ("sphinx", "sphinx_gallery", "numpydoc", "myst_parser", "pydata_sphinx_theme", "matplotlib"):
        try:
            importlib.import_module(name)
        except ImportError:
            return False
    return True


@pytest.mark.slow  # the whole site, with the examples gallery executed: a minute or two
@pytest.mark.skipif(not _have_sphinx(), reason="the docs extra is not installed (pip install -e '.[docs]')")
def test_the_site_builds_with_warnings_as_errors(tmp_path):
    out = tmp_path / "html"
    r = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", "-d",
                        str(tmp_path / "doctrees"), str(DOCS), str(out)], cwd=ROOT, capture_output=True, text=True,
                       env={**os.environ, "EVSIM_DOCS_RUN_ALL": "1"})
    assert r.returncode == 0, r.stdout[-5000:] + r.stderr[-20000:]
    assert (out / "index.html").is_file()
    # the gallery: at least six executed examples, each page showing the figures it drew
    pages = sorted((out / "auto_examples").glob("0*.html"))
    assert len(pages) >= 6
    for page in pages:
        images = re.findall(r'<img[^>]+src="(\.\./_images/sphx_glr_[^"]+)"', page.read_text())
        assert images, f"{page.name} shows no figure"
        assert all((page.parent / src).resolve().is_file() for src in images)
    # the API reference: every name of every __all__ has its page or a link to where it is documented
    for mod_name, rows in evsim_docs.api_layout().items():
        html = (out / "api" / f"{mod_name}.html").read_text()
        for name, _, target in rows:
            assert f'href="generated/{target}.html' in html, f"{mod_name}.{name}: no link to {target}"
            assert (out / "api" / "generated" / f"{target}.html").is_file()
    # the results pages say where, when and from which commit they were measured
    for page in ("index", "benchmarks", "evaluation"):
        text = (DOCS / "results" / f"{page}.md").read_text()
        assert "Measured on" in text and "git commit" in text and "date:" in text
    # every model page ends with its references
    for page in (DOCS / "models").glob("*.md"):
        if page.stem not in ("index", "references"):
            assert re.search(r"^#+ References", page.read_text(), flags=re.M), f"models/{page.name}: no References"
