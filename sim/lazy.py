"""Package attributes imported on first use, so that importing a package for its light parts (errors, parameters,
`evsim --help`) does not load numba, h5py or OpenCV."""

from __future__ import annotations

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
