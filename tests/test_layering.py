"""The package layering the project's design fixes: one-way dependencies between the layers, no import cycle.

Layers, bottom to top: crf_models -> sim -> akf -> generators.formats (file formats, the Recording) -> generators
(generation) -> evsim_eval (evaluation and benchmarking) -> evsim_app (command line, info, plots). A module may
import its own layer and the layers below it, never one above. Every import counts, including the ones deferred
inside functions: a deferred import still makes a cycle.
"""

import ast
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("crf_models", "sim", "akf", "generators", "evsim_eval", "evsim_app")
LAYERS = ("crf_models", "sim", "akf", "generators.formats", "generators", "evsim_eval", "evsim_app")
# every package folder and its layer: what each folder is for is part of the design (a new folder takes a place here)
FOLDERS = {
    "crf_models": "crf_models",  # camera response curves
    "sim": "sim",  # sensor emulation: DVS, LDR camera, events, noise, event denoising filters
    "akf": "akf",  # reconstruction: the AKF, the smoother, baselines, frame augmentation
    "generators.formats": "generators.formats",  # file formats: the registry, readers, writers, the Recording
    "generators": "generators",  # generation: AHDR sequences, datasets, sweeps, conversion, the DVS pass
    "generators.scenes": "generators",  # scenes: procedural, photos in motion, videos and recordings
    "evsim_eval": "evsim_eval",  # evaluation: metrics, scoring, tuning, protocols, the demo
    "evsim_eval.calibrate": "evsim_eval",  # fitting a sensor to a real recording
    "evsim_eval.realism": "evsim_eval",  # how real simulated events are
    "evsim_app": "evsim_app",  # the command line (a module per subcommand)
    "evsim_app.plots": "evsim_app",  # figures and videos
    "evsim_app.lab": "evsim_app",  # the teaching lab
}
# import-free name modules a lower layer may read (the choices the CLI lists without loading their implementations)
SHARED_NAMES = {"generators.choices"}


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _layer(module: str) -> int:
    """Index in LAYERS of the most specific layer holding module."""
    held = [layer for layer in LAYERS if module == layer or module.startswith(layer + ".")]
    return LAYERS.index(max(held, key=len))


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


def test_layers_depend_one_way():
    bad = [(mod, dep) for mod, deps in _graph().items() for dep in deps
           if _layer(dep) > _layer(mod) and dep not in SHARED_NAMES]
    assert not bad, f"imports of a layer above: {bad}"


def test_every_package_folder_has_its_place_in_the_layers():
    folders = {_module_name(p) for pkg in PACKAGES for p in (ROOT / pkg).rglob("__init__.py")}
    assert folders == set(FOLDERS), f"folders not in FOLDERS: {folders - set(FOLDERS)}; gone: {set(FOLDERS) - folders}"
    for folder, layer in FOLDERS.items():
        assert _layer(folder) == LAYERS.index(layer), folder


def test_layer_order_is_the_designs():
    # the rule the design states in words, checked against the table above
    assert _layer("akf.filter") > _layer("sim.dvs") > _layer("crf_models.base")
    assert _layer("generators.formats.native") < _layer("generators.ahdr") < _layer("evsim_eval.evaluate")
    assert _layer("evsim_eval.evaluate") < _layer("evsim_app.cli")


@pytest.mark.parametrize("package", PACKAGES)
def test_modules_form_no_cycle(package):
    # a package importing its own submodules (an __init__ re-exporting them) is not a cycle
    graph = {m: {d for d in deps if d.split(".")[0] == package} for m, deps in _graph().items()
             if m.split(".")[0] == package}
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


def test_evaluation_and_application_left_generators():
    left = ("evaluation", "evaluation_tasks", "denoising", "cli", "info", "precompile", "plots", "recording")
    assert not [n for n in left if (ROOT / "generators" / f"{n}.py").exists() or (ROOT / "generators" / n).is_dir()]


@pytest.mark.parametrize("package", PACKAGES)
def test_every_public_name_is_exported_and_documented(package):
    module = importlib.import_module(package)
    assert module.__all__, f"{package} has no __all__"
    for name in module.__all__:
        assert getattr(module, name) is not None
        assert name in module.__doc__, f"{package}.__doc__ does not list {name}"
