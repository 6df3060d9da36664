"""The application: `main` (the `evsim` command line, also `python -m evsim_app`), `describe` (what `evsim info`
prints), figures and animations in `evsim_app.plots` (needs matplotlib), and the demo's background compiler
(`evsim_app.precompile`). Every name is imported on first use.
"""

from sim.lazy import lazy_exports

_EXPORTS = {"main": "cli", "describe": "info"}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
