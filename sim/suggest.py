"""Messages for a mistyped name: the closest allowed names (difflib) and the list of all of them."""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def closest(name: str, allowed: Iterable[str]) -> str | None:
    """The allowed name closest to `name` (difflib's ratio >= 0.6, case-insensitive), or None."""
    by_lower = {str(a).lower(): str(a) for a in allowed}
    close = difflib.get_close_matches(str(name).lower(), list(by_lower), n=1)
    return by_lower[close[0]] if close else None


def similarity(a: str, b: str) -> float:
    """difflib's ratio of two names, case-insensitive: 1 when equal, >= 0.6 for what closest calls close."""
    return difflib.SequenceMatcher(None, a.lower(), b.lower()).ratio()


def did_you_mean(name: str, allowed: Iterable[str]) -> str:
    """" (did you mean 'x'?)" for the allowed name closest to `name` (see closest), else ""."""
    match = closest(name, allowed)
    return f" (did you mean {match!r}?)" if match else ""


def unknown_name(what: str, name: object, allowed: Iterable[str]) -> str:
    """"unknown <what> 'name' (did you mean 'x'?); allowed: a, b, c" (the suggestion only when one is close)."""
    allowed = list(allowed)
    return f"unknown {what} {name!r}{did_you_mean(str(name), allowed)}; allowed: {', '.join(allowed)}"
