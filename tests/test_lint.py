"""The code passes the project's ruff configuration (pyproject.toml: line length 120; pyflakes, pycodestyle,
bugbear, import order, pyupgrade), so CI, which runs this suite, runs the linter too."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_ruff_finds_nothing():
    pytest.importorskip("ruff")  # in the test extra
    r = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", "."], cwd=ROOT, capture_output=True,
                       text=True)
    assert r.returncode == 0, r.stdout + r.stderr


PACKAGES = ("crf_models", "sim", "akf", "generators", "evsim_eval", "evsim_app")


def _unannotated(path: Path) -> list[str]:
    """Public functions and methods of public classes in path with a parameter or the return unannotated (numba
    kernels and intrinsics excepted: their types come from the call)."""
    out = []

    def visit(body, owner=""):
        for node in body:
            if isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
                visit(node.body, f"{node.name}.")
            elif isinstance(node, ast.FunctionDef) and (not node.name.startswith("_") or node.name == "__init__"):
                if any(k in ast.unparse(d) for d in node.decorator_list for k in ("jit", "intrinsic")):
                    continue
                a = node.args
                params = [p for p in [*a.posonlyargs, *a.args, *a.kwonlyargs, a.vararg, a.kwarg]
                          if p is not None and p.arg not in ("self", "cls")]
                if any(p.annotation is None for p in params) or (node.returns is None and node.name != "__init__"):
                    out.append(f"{path.relative_to(ROOT)}:{node.lineno} {owner}{node.name}")

    visit(ast.parse(path.read_text()).body)
    return out


def test_public_functions_have_type_hints():
    missing = [m for pkg in PACKAGES for p in sorted((ROOT / pkg).rglob("*.py")) for m in _unannotated(p)]
    assert not missing, "public functions without type hints:\n" + "\n".join(missing)


MAX_FUNCTION_LINES = 80  # of code (docstring, blank and comment lines aside); numba kernels excepted


def _long_functions(path: Path) -> list[str]:
    text = path.read_text()
    lines = text.split("\n")
    out = []
    for node in ast.walk(ast.parse(text)):
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        if any("jit" in ast.unparse(d) for d in node.decorator_list):
            continue
        body = node.body
        has_doc = isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) and \
            isinstance(body[0].value.value, str)
        start = body[0].end_lineno + 1 if has_doc else body[0].lineno
        code = [line for line in lines[start - 1:node.end_lineno] if line.strip() and not line.strip().startswith("#")]
        if len(code) > MAX_FUNCTION_LINES:
            out.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({len(code)} lines)")
    return out


def test_no_function_is_longer_than_80_lines():
    long = [f for pkg in PACKAGES for p in sorted((ROOT / pkg).rglob("*.py")) for f in _long_functions(p)]
    assert not long, "split these into named steps:\n" + "\n".join(long)
