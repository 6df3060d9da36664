"""Where numba keeps evsim's compiled kernels: a per-user cache folder, not the package's own __pycache__.

numba writes the machine code of every `cache=True` kernel next to its source by default. For an installed copy
that is site-packages/sim/__pycache__ (and akf/, generators/...), which pip does not know of: uninstalling evsim
(as `pip install -e .` does before an editable install) leaves those folders behind, and a package folder holding
only __pycache__ is a namespace package that shadows the editable install (`evsim` then fails with "cannot import
name 'EvsimInputError' from 'sim' (unknown location)"). Set before numba is first imported, NUMBA_CACHE_DIR moves
the cache to <user cache>/evsim/numba (XDG_CACHE_HOME or ~/.cache on POSIX, LOCALAPPDATA on Windows), where numba
keys each kernel by its source file's full path, so an installed and an editable copy never share an entry. A
NUMBA_CACHE_DIR the user set is kept; so is numba's own default once numba is imported before evsim.

References (docs/models/references.md): Lam et al. 2015 [Lam2015], numba (its caching: "Notes on caching" in
the numba documentation, NUMBA_CACHE_DIR).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

__all__ = ["user_cache_dir", "use_user_cache"]


def user_cache_dir() -> Path:
    """<the user's cache folder>/evsim/numba: LOCALAPPDATA on Windows, else XDG_CACHE_HOME or ~/.cache.

    Returns
    -------
    pathlib.Path
        The folder (not created).
    """
    if sys.platform == "win32" and os.environ.get("LOCALAPPDATA"):
        base = Path(os.environ["LOCALAPPDATA"])
    else:
        base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "evsim" / "numba"


def use_user_cache() -> None:
    """Point NUMBA_CACHE_DIR at user_cache_dir() unless it is set or numba is already imported (then it is numba's
    to decide)."""
    if "NUMBA_CACHE_DIR" not in os.environ and "numba" not in sys.modules:
        os.environ["NUMBA_CACHE_DIR"] = str(user_cache_dir())


use_user_cache()  # on import: sim imports this module first
