"""Sphinx helpers of the evsim documentation (loaded by docs/conf.py; not part of the package).

- The API reference: one page per public module, generated from its ``__all__`` (`api_modules` finds the modules:
  every package and every submodule that defines ``__all__``; `write_api_pages` writes docs/api/<module>.rst with
  autosummary tables, grouped into classes, functions and data). A name exported by several modules (``sim.dvs``
  re-exports part of ``sim``; ``generators.load`` is ``generators.formats.load``) is documented where it is listed
  first and linked from the others, so every page lists every name of its ``__all__``.
- Module constants: their documentation is the comment beside or above the assignment where they are defined
  (``#:`` comments, plain comments directly above, or a comment at the end of the line), found by `constant_docs`,
  and their value when it is short.
- Missing documentation of a public name is a warning (so an error under ``sphinx-build -W``).
- The examples gallery: `gallery_argv` gives every example ``--out FOLDER`` (a temporary folder per example) and
  `saved_figures_scraper` puts the image files an example wrote there into the page, after the code block that
  wrote them (the examples save their figures with evsim_app.plots.common.save_figure, which closes them, so the
  matplotlib scraper alone would not see them).
"""

from __future__ import annotations

import ast
import importlib
import inspect
import io
import os
import re
import shutil
import tempfile
import tokenize
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
# the packages, in layer order (tests/test_layering.py): a name is documented in the first module that exports it
PACKAGES = ("crf_models", "sim", "akf", "generators", "evsim_eval", "evsim_app")
IMAGE_SUFFIXES = (".png", ".gif", ".jpg", ".svg")


# ----- the API reference -------------------------------------------------------------------------------------------

def _defines_all(path: Path) -> bool:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return any(isinstance(node, (ast.Assign, ast.AnnAssign)) and
               any(isinstance(t, ast.Name) and t.id == "__all__"
                   for t in (node.targets if isinstance(node, ast.Assign) else [node.target]))
               for node in tree.body)


def api_modules() -> list[str]:
    """The documented modules: every package of PACKAGES and every public submodule (no ``_`` in its dotted name,
    not ``__main__``) that defines ``__all__``; a package before its submodules, submodules sorted."""
    out = []
    for pkg in PACKAGES:
        out.append(pkg)
        subs = []
        for path in sorted((ROOT / pkg).rglob("*.py")):
            rel = path.relative_to(ROOT).with_suffix("")
            parts = list(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
            name = ".".join(parts)
            if name == pkg or any(p.startswith("_") for p in parts):
                continue
            if _defines_all(path):
                subs.append(name)
        out += sorted(subs)
    return out


def _kind(obj: Any) -> str:
    if inspect.isclass(obj):
        return "exception" if issubclass(obj, BaseException) else "class"
    if callable(obj):
        return "function"
    return "data"


GROUPS = (("class", "Classes"), ("exception", "Exceptions"), ("function", "Functions"), ("data", "Data"))


def api_layout(modules: list[str] | None = None) -> dict[str, list[tuple[str, str, str]]]:
    """module -> [(name, kind, documented at: the full dotted name of the page that documents it)] for every name
    of the module's ``__all__``, in order."""
    modules = api_modules() if modules is None else modules
    first: dict[int, str] = {}
    layout = {}
    for mod_name in modules:
        mod = importlib.import_module(mod_name)
        rows = []
        for name in mod.__all__:
            obj = getattr(mod, name)
            key = id(obj)
            # documented once per object; scalars (ints, strings) are never shared between modules' names
            shared = not isinstance(obj, (int, float, str, bytes, bool, type(None)))
            target = first.setdefault(key, f"{mod_name}.{name}") if shared else f"{mod_name}.{name}"
            rows.append((name, _kind(obj), target))
        layout[mod_name] = rows
    return layout


def module_page(mod_name: str, rows: list[tuple[str, str, str]]) -> str:
    """The rst text of the API page of one module."""
    lines = [mod_name, "=" * len(mod_name), "", f".. automodule:: {mod_name}", "", f".. currentmodule:: {mod_name}",
             ""]
    own = [(n, k) for n, k, t in rows if t == f"{mod_name}.{n}"]
    elsewhere = [(n, k, t) for n, k, t in rows if t != f"{mod_name}.{n}"]
    for kind, title in GROUPS:
        names = [n for n, k in own if k == kind]
        if names:
            lines += [f".. rubric:: {title}", "", ".. autosummary::", "   :toctree: generated", "   :nosignatures:", ""]
            lines += [f"   {n}" for n in names] + [""]
    if elsewhere:
        lines += [".. rubric:: Also exported here", "", "Documented where they are first listed:", "",
                  ".. autosummary::", "   :nosignatures:", ""]
        lines += [f"   ~{t}" for _, _, t in elsewhere] + [""]
    return "\n".join(lines)


def write_api_pages(api_dir: Path) -> list[str]:
    """Write api_dir/<module>.rst for every documented module (only when its text changed, so that an unchanged
    page is not rebuilt), remove pages of modules that are gone and write their toctree, in layer order, to
    api_dir/toctree.inc (included by api/index.md); returns the module names in order."""
    api_dir.mkdir(parents=True, exist_ok=True)
    layout = api_layout()
    for mod_name, rows in layout.items():
        page = api_dir / f"{mod_name}.rst"
        text = module_page(mod_name, rows)
        if not page.is_file() or page.read_text(encoding="utf-8") != text:
            page.write_text(text, encoding="utf-8")
    for page in api_dir.glob("*.rst"):
        if page.stem not in layout:
            page.unlink()
    toc = "\n".join(["```{toctree}", ":maxdepth: 1", "", *layout, "```", ""])
    inc = api_dir / "toctree.inc"
    if not inc.is_file() or inc.read_text(encoding="utf-8") != toc:
        inc.write_text(toc, encoding="utf-8")
    return list(layout)


# ----- plain-text docstrings --------------------------------------------------------------------------------------
#
# evsim's docstrings are plain text, not reStructuredText. Their conventions: paragraphs of wrapped lines; "name:
# text" field lines (several names may share one: "t_start_us, t_mid_us: ..."); "- " list items; a line ending
# in ":" followed by more-indented lines (a heading over fields); a more-indented line continues the item above
# it (hanging indent); a more-indented block after a blank line is verbatim (code, commands, a TOML example);
# `name` quotes code. prose_to_rst turns that into reStructuredText that renders the way the text reads: fields
# and list items become bullet lists (field names in bold), continuations are joined, verbatim blocks become
# literal blocks, and characters that reStructuredText would take as markup (*, |, a trailing _, a backslash)
# are escaped. A docstring that already uses numpydoc sections keeps them as they are (only the text before the
# first section is converted).

_FIELD = re.compile(r"^((?:[A-Za-z_][\w.]*|\*\*?\w+)(?:(?:, |/| / | or )(?:[A-Za-z_][\w.]*|\*\*?\w+))*): (\S.*)$")
_ITEM = re.compile(r"^(- |\* |\d+[.)] )(.*)$")
_SECTION_NAMES = {"Parameters", "Returns", "Yields", "Receives", "Raises", "Warns", "Other Parameters",
                  "Attributes", "Methods", "See Also", "Notes", "References", "Examples", "Warnings"}


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip(" "))


def escape_inline(text: str) -> str:
    """Escape what reStructuredText would read as markup in plain text, outside `code` spans (kept as they are;
    an unmatched backtick is escaped)."""
    parts = text.split("`")
    if len(parts) % 2 == 0:  # an odd number of backticks: none is markup
        parts = ["\\`".join(parts)]
    out = []
    for k, part in enumerate(parts):
        if k % 2:
            out.append(f"`{part}`" if part.strip() else "\\`" + part + "\\`")
            continue
        part = part.replace("\\", "\\\\").replace("*", "\\*").replace("|", "\\|")
        part = re.sub(r"(?<=\w)_(?=\W|$)", r"\\_", part)
        out.append(part)
    return "".join(out)


def _items(lines: list[str]) -> list[tuple[str, list[str]]]:
    """Split a block of non-blank lines (dedented: the first line at indent 0) into items: (kind, lines) with
    kind "field", "item" or "text", each with its more-indented continuation lines."""
    items: list[tuple[str, list[str]]] = []
    for line in lines:
        starts = _FIELD.match(line) or _ITEM.match(line)
        if items and (_indent(line) > 0 or (not starts and not _hanging(items[-1][1]))):
            items[-1][1].append(line)
            continue
        kind = "item" if _ITEM.match(line) else "field" if _FIELD.match(line) else "text"
        items.append((kind, [line]))
    return items


def _hanging(lines: list[str]) -> bool:
    return any(_indent(x) > 0 for x in lines[1:])


def _field(text: str) -> str:
    m = _FIELD.match(text)
    return f"**{escape_inline(m.group(1))}**: {escape_inline(m.group(2))}"


def _render_items(lines: list[str]) -> list[str]:
    """Paragraphs, bullet lists (list items, and runs of two or more fields) and headings over nested fields."""
    rendered = []  # (kind, text, nested lines)
    for kind, item in _items(lines):
        rest = [x for x in item[1:] if _indent(x) > 0]
        if len(item) > 1 and item[0].rstrip().endswith(":") and _indent(item[1]) > 0 and kind != "item":
            head = [item[0]] + [x for x in item[1:] if _indent(x) == 0]
            base = min(_indent(x) for x in rest)
            rendered.append((kind, " ".join(x.strip() for x in head), [x[base:] for x in rest]))
        else:
            rendered.append((kind, " ".join(x.strip() for x in item), []))
    out: list[str] = []
    k = 0
    while k < len(rendered):
        kind, text, nested = rendered[k]
        j = k
        while j < len(rendered) and rendered[j][0] != "text" and not rendered[j][2]:
            j += 1
        run = rendered[k:j]
        if run and (len(run) > 1 or kind == "item"):
            for kind_i, text_i, _ in run:
                out.append(f"- {escape_inline(_ITEM.match(text_i).group(2))}" if kind_i == "item" else
                           f"- {_field(text_i)}")
            out.append("")
            k = j
            continue
        out += [_field(text) if kind == "field" else escape_inline(text), ""]
        if nested:
            out += _render_items(nested)
        k += 1
    return out


def prose_to_rst(lines: list[str]) -> list[str]:
    """reStructuredText for a plain-text docstring (autodoc's lines: dedented, trailing blank line)."""
    cut = len(lines)
    for k in range(len(lines) - 1):
        under = lines[k + 1].strip()
        if lines[k].strip() in _SECTION_NAMES and under and set(under) == {"-"} and len(under) >= 3:
            cut = k
            break
    prose, sections = lines[:cut], lines[cut:]
    out: list[str] = []
    k = 0
    base_prev = 0
    while k < len(prose):
        if not prose[k].strip():
            k += 1
            continue
        j = k
        while j < len(prose) and prose[j].strip():
            j += 1
        base = _indent(prose[k])
        if out and base > base_prev:  # indented after a blank line: verbatim, up to the next less-indented line
            while j < len(prose) and (not prose[j].strip() or _indent(prose[j]) >= base):
                j += 1
            block = prose[k:j]
            while block and not block[-1].strip():
                block.pop()
            while out and out[-1] == "":
                out.pop()
            out[-1] = out[-1] + ":" if out[-1].endswith(":") else out[-1] + " ::"
            out += ["", *block, ""]
        else:
            block = prose[k:j]
            out += _render_items([x[base:] if _indent(x) >= base else x.lstrip() for x in block])
            base_prev = base
        k = j
    while out and out[-1] == "":
        out.pop()
    return out + [""] + sections if sections else out + [""]


# ----- documentation of module constants ---------------------------------------------------------------------------

def _comment_docs(path: Path) -> dict[str, list[str]]:
    """name -> comment lines of every top-level assignment of the file: ``#:`` or plain comments on the lines
    directly above it, or a comment at the end of its first line."""
    source = path.read_text(encoding="utf-8")
    comments = {}
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            comments[tok.start[0]] = (tok.start[1], tok.string)
    lines = source.splitlines()
    out = {}
    for node in ast.parse(source).body:
        if isinstance(node, ast.Assign):
            targets = [t.id for t in node.targets if isinstance(t, ast.Name)]
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            targets = [node.target.id]
        else:
            continue
        doc = []
        k = node.lineno - 1
        while k >= 1 and k in comments and comments[k][0] == 0:  # whole-line comments directly above
            doc.insert(0, comments[k][1])
            k -= 1
        if not doc and node.lineno in comments and comments[node.lineno][0] > 0 and \
                lines[node.lineno - 1][:comments[node.lineno][0]].strip():
            doc = [comments[node.lineno][1]]
        text = [c.lstrip("#").removeprefix(":").strip() for c in doc]
        text = [t for t in text if t and not set(t) <= set("-= ")]  # drop ruler lines such as "# ----- x -----"
        if text:
            for t in targets:
                out[t] = text
    return out


_CONSTANT_DOCS: dict[int, list[str]] | None = None


def constant_docs() -> dict[int, list[str]]:
    """id(value) -> comment lines, for every module-level value of the packages that has a comment where it is
    assigned (the module that defines it, or one that re-assigns it under a comment)."""
    global _CONSTANT_DOCS
    if _CONSTANT_DOCS is None:
        _CONSTANT_DOCS = {}
        for pkg in PACKAGES:
            for path in sorted((ROOT / pkg).rglob("*.py")):
                rel = path.relative_to(ROOT).with_suffix("")
                parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
                if parts[-1] == "__main__":
                    continue
                docs = _comment_docs(path)
                if not docs:
                    continue
                try:
                    mod = importlib.import_module(".".join(parts))
                except ImportError:
                    continue
                for name, text in docs.items():
                    if name in vars(mod):
                        _CONSTANT_DOCS.setdefault(id(vars(mod)[name]), text)
    return _CONSTANT_DOCS


_PUBLIC: set[str] | None = None


def public_names() -> set[str]:
    """The full names of the API reference's entries: module.name for every name of every documented module."""
    global _PUBLIC
    if _PUBLIC is None:
        _PUBLIC = {f"{m}.{n}" for m, rows in api_layout().items() for n, _, _ in rows}
    return _PUBLIC


def process_docstring(app, what: str, name: str, obj: Any, options: Any, lines: list[str]) -> None:
    """Constants get their comment (and their value when short); plain text becomes reStructuredText
    (prose_to_rst); a public name without documentation is a warning."""
    from sphinx.util import logging

    value = None
    if what in ("data", "attribute") and "." in name:
        # the docstring a value inherits from its type, as the type states it and as the value reads it (numpy's
        # ndarray keeps a text signature there, "ndarray(shape, ...)\n--\n", that the type's own __doc__ drops)
        type_docs = {inspect.getdoc(type(obj)) or "", inspect.cleandoc(getattr(obj, "__doc__", None) or "")}
        if not [x for x in lines if x.strip()] or "\n".join(lines).strip() in {d.strip() for d in type_docs}:
            lines[:] = list(constant_docs().get(id(obj), []))
            if lines and what == "data" and len(repr(obj)) <= 160 and "`" not in repr(obj):
                value = repr(obj)
    lines[:] = prose_to_rst(lines)
    if value is not None:
        lines += [f"Value: `{value}`", ""]
    if name in public_names() and not [x for x in lines if x.strip()]:
        logging.getLogger("evsim_docs").warning(f"{name} is public (listed in __all__) and has no documentation",
                                                type="evsim", subtype="undocumented")


# ----- the examples gallery ----------------------------------------------------------------------------------------

GALLERY_OUT = Path(os.environ.get("EVSIM_GALLERY_OUT") or tempfile.mkdtemp(prefix="evsim-gallery-"))


def _example_out(src_file: str) -> Path:
    return GALLERY_OUT / Path(src_file).stem


def gallery_argv(gallery_conf: dict, script_vars: dict) -> list[str]:
    """Command-line arguments of an example run by sphinx-gallery: ``--out`` a fresh folder for it."""
    out = _example_out(script_vars["src_file"])
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    return ["--out", str(out)]


_SEEN: dict[Path, float] = {}


def saved_figures_scraper(block: Any, block_vars: dict, gallery_conf: dict) -> str:
    """The image files the code block wrote to its example's --out folder (new or rewritten since the previous
    block), oldest first, copied to sphinx-gallery's image paths; returns their rst."""
    from sphinx_gallery.scrapers import figure_rst

    out = _example_out(block_vars["src_file"])
    if not out.is_dir():
        return ""
    new = []
    for path in out.rglob("*"):
        if path.suffix.lower() in IMAGE_SUFFIXES and path.is_file():
            mtime = path.stat().st_mtime_ns
            if _SEEN.get(path) != mtime:
                _SEEN[path] = mtime
                new.append((mtime, str(path), path))
    paths = []
    for (_, _, path), target in zip(sorted(new), block_vars["image_path_iterator"]):
        target = Path(target).with_suffix(path.suffix.lower())
        shutil.copyfile(path, target)
        paths.append(str(target))
    return figure_rst(paths, gallery_conf["src_dir"])


def _cleanup(app, exception) -> None:
    if not os.environ.get("EVSIM_GALLERY_OUT"):
        shutil.rmtree(GALLERY_OUT, ignore_errors=True)


def setup(app) -> dict:
    app.connect("autodoc-process-docstring", process_docstring, priority=100)  # before numpydoc's
    app.connect("build-finished", _cleanup)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
