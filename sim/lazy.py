"""Package attributes imported on first use, and numba kernels compiled on first call, so that importing a package
for its light parts (errors, parameters, event containers; `evsim --help`, `evsim info`) does not load numba, h5py
or OpenCV."""

from __future__ import annotations

import functools
import importlib
from collections.abc import Callable


def lazy_exports(package: str, table: dict[str, str], eager: dict) -> tuple[Callable, Callable]:
    """(__getattr__, __dir__) for a package module: name -> "submodule" or "submodule:attribute" (relative to
    package) in table is imported on first access and then kept in the package's namespace (eager, its
    globals())."""

    def __getattr__(name: str):
        if name not in table:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module, _, attr = table[name].partition(":")
        value = getattr(importlib.import_module(f".{module}", package), attr or name)
        eager[name] = value
        return value

    def __dir__():
        return sorted({*eager, *table})

    return __getattr__, __dir__


def lazy_njit(**options: object) -> Callable[[Callable], Callable]:
    """numba.njit(**options) applied on the function's first call (numba is imported then, not with the module).
    For kernels called from Python only: a kernel that other numba kernels call needs numba.njit itself."""

    def decorate(py_func: Callable) -> Callable:
        compiled = None

        @functools.wraps(py_func)
        def call(*args):
            nonlocal compiled
            if compiled is None:
                from numba import njit

                compiled = njit(**options)(py_func)
            return compiled(*args)

        return call

    return decorate
