"""The package layering the project's design fixes: one-way dependencies between packages and inside generators/.

Every import counts, including the ones deferred inside functions: a deferred import still makes a cycle.
"""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("sim", "crf_models", "akf", "generators")
# package -> the project packages it must never import
FORBIDDEN = {"crf_models": {"sim", "akf", "generators"}, "sim": {"akf", "generators"}, "akf": {"generators"}}


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> set[str]:
    """Absolute names of the project modules imported anywhere in the file."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[:len(anchor) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            out.add(base)
            out.update(f"{base}.{a.name}" for a in node.names)
    return {m for m in out if m.split(".")[0] in PACKAGES}


def _graph() -> dict[str, set[str]]:
    files = [p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py")]
    modules = {_module_name(p): p for p in files}
    return {name: {m for m in _imports(path) if m in modules and m != name} for name, path in modules.items()}


def test_packages_depend_one_way():
    bad = [(mod, dep) for mod, deps in _graph().items() for dep in deps
           if dep.split(".")[0] in FORBIDDEN.get(mod.split(".")[0], ())]
    assert not bad, f"forbidden imports: {bad}"


def test_generators_modules_form_no_cycle():
    # a package importing its own submodules (an __init__ re-exporting them) is not a cycle
    graph = {m: {d for d in deps if d.startswith("generators")} for m, deps in _graph().items()
             if m.startswith("generators")}
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for d in sorted(graph.get(m, ())):
            if d.startswith(m + "."):
                continue  # a package importing its own submodules
            if state.get(d) == 1:
                cycle = stack[stack.index(d):] + [d]
                if not any(b.startswith(a + ".") for a, b in zip(cycle, cycle[1:])):
                    raise AssertionError(f"import cycle: {' -> '.join(cycle)}")
            elif d not in state:
                visit(d)
        stack.pop()
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m)
