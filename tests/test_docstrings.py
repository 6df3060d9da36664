"""numpydoc sections of the API reference (issue 36): every public function of docs/_ext/evsim_docs.api_modules()
(the names of every documented module's ``__all__``, and the public methods of the classes among them) that takes
parameters has a Parameters section naming each of them, and one that returns something (a return annotation
other than None) has a Returns or Yields section. numpydoc's docscrape reads the docstrings.

A function is checked on the page that documents it (the first module listing it, as evsim_docs does)."""

from __future__ import annotations

import importlib
import inspect
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs" / "_ext"))
import evsim_docs  # noqa: E402

numpydoc_docscrape = pytest.importorskip("numpydoc.docscrape")


def _functions() -> dict[str, list[tuple[str, object]]]:
    """module -> [(full name, function)] for every public function of the API reference, on the page that
    documents it (each function once)."""
    seen: set[int] = set()
    out: dict[str, list[tuple[str, object]]] = {}
    for mod_name in evsim_docs.api_modules():
        mod = importlib.import_module(mod_name)
        rows = out.setdefault(mod_name, [])
        for name in getattr(mod, "__all__", []):
            obj = getattr(mod, name, None)
            candidates = []
            if inspect.isfunction(obj) or (callable(obj) and hasattr(obj, "py_func")):
                candidates.append((f"{mod_name}.{name}", getattr(obj, "py_func", obj)))
            elif inspect.isclass(obj):
                for attr, member in vars(obj).items():
                    if attr.startswith("_"):
                        continue
                    if isinstance(member, (staticmethod, classmethod)):
                        member = member.__func__
                    if inspect.isfunction(member):  # properties are exempt
                        candidates.append((f"{mod_name}.{name}.{attr}", member))
            for full, func in candidates:
                if id(func) not in seen:
                    seen.add(id(func))
                    rows.append((full, func))
    return out


FUNCTIONS = _functions()


def _param_names(doc) -> set[str]:
    names = set()
    for param in doc["Parameters"]:
        for n in param.name.split(","):
            names.add(n.strip().lstrip("*"))
    return names


def missing_sections(func) -> list[str]:
    """What the docstring of func lacks: "Parameters" or "Parameters: a, b" (undocumented names), "Returns"."""
    try:
        sig = inspect.signature(func)
    except (TypeError, ValueError):
        return []
    params = [p for p in sig.parameters if p not in ("self", "cls")]
    returns = sig.return_annotation not in (None, "None", inspect.Signature.empty)
    doc = numpydoc_docscrape.FunctionDoc(func) if func.__doc__ else None
    out = []
    if params:
        if not (doc and doc["Parameters"]):
            out.append("Parameters")
        else:
            undocumented = [p for p in params if p not in _param_names(doc)]
            if undocumented:
                out.append("Parameters: " + ", ".join(undocumented))
    if returns and not (doc and (doc["Returns"] or doc["Yields"])):
        out.append("Returns")
    return out


def _problems(rows) -> list[str]:
    return [f"{full}: {', '.join(miss)}" for full, func in rows if (miss := missing_sections(func))]


@pytest.mark.parametrize("mod_name", list(FUNCTIONS))
def test_public_functions_have_parameters_and_returns_sections(mod_name):
    problems = _problems(FUNCTIONS[mod_name])
    assert not problems, "numpydoc sections missing:\n" + "\n".join(problems)


def test_the_check_finds_a_missing_section():
    def undocumented(a: int, b: int) -> int:
        """Sum."""
        return a + b

    def documented(a: int, b: int) -> int:
        """Sum.

        Parameters
        ----------
        a, b : int
            The terms.

        Returns
        -------
        int
            a + b.
        """
        return a + b

    assert missing_sections(undocumented) == ["Parameters", "Returns"]
    assert missing_sections(documented) == []
