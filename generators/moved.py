"""Import paths of modules that left generators/ in evsim 0.2, kept importable until 0.3 with a DeprecationWarning.

`import generators.evaluation` (and `from generators.plots import plot_pixel`, ...) gives the module at its new
home, and `python -m generators.cli` runs the new one; the warning names it. Only names are listed here: nothing
of the layers above generators/ is imported until an old path is used.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: old module -> its home since evsim 0.2 (submodules of a moved package follow it)
MOVED = {
    "generators.recording": "generators.formats.recording",
    "generators.evaluation": "evsim_eval.evaluate",
    "generators.evaluation_tasks": "evsim_eval.evaluate",
    "generators.denoising": "evsim_eval.denoisers",
    "generators.cli": "evsim_app.cli",
    "generators.info": "evsim_app.info",
    "generators.precompile": "evsim_app.precompile",
    "generators.plots": "evsim_app.plots",
}
REMOVED_IN = "0.3"


def new_home(old: str) -> str | None:
    """The module an old import path now names, or None when it did not move."""
    for prefix, target in MOVED.items():
        if old == prefix or old.startswith(prefix + "."):
            return target + old[len(prefix):]
    return None


def _notice(old: str) -> str:
    return f"{old} moved to {new_home(old)} in evsim 0.2; the old path goes in {REMOVED_IN}"


class _MovedFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Answers an old path with the module at its new home: the same module object, not a copy."""

    def find_spec(self, fullname, path=None, target=None):
        if new_home(fullname) is None:
            return None
        return importlib.util.spec_from_loader(fullname, self)

    def create_module(self, spec):
        warnings.warn(_notice(spec.name), DeprecationWarning, stacklevel=2)
        module = importlib.import_module(new_home(spec.name))
        self._own_spec = module.__spec__  # the import system sets __spec__ to the alias's; exec_module restores it
        return module

    def exec_module(self, module):
        module.__spec__ = self._own_spec

    def get_code(self, fullname):
        """What `python -m OLD` runs: the module at its new home as __main__, after the same warning."""
        return compile(f"import runpy, warnings\n"
                       f"warnings.warn({_notice(fullname)!r}, DeprecationWarning)\n"
                       f"runpy.run_module({new_home(fullname)!r}, run_name='__main__', alter_sys=True)\n",
                       fullname, "exec")


def install() -> None:
    """Let the old paths import (once per process)."""
    if not any(isinstance(f, _MovedFinder) for f in sys.meta_path):
        # first: the path finder would otherwise load a moved package's submodule a second time under the old name
        sys.meta_path.insert(0, _MovedFinder())
