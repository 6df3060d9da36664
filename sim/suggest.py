"""Messages for a mistyped name: the closest allowed names (difflib) and the list of all of them."""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def did_you_mean(name: str, allowed: Iterable[str]) -> str:
    """" (did you mean 'x'?)" for the allowed name closest to `name` (difflib's ratio >= 0.6, case-insensitive),
    else ""."""
    allowed = [str(a) for a in allowed]
    by_lower = {a.lower(): a for a in allowed}
    close = difflib.get_close_matches(str(name).lower(), list(by_lower), n=1)
    return f" (did you mean {by_lower[close[0]]!r}?)" if close else ""


def unknown_name(what: str, name: object, allowed: Iterable[str]) -> str:
    """"unknown <what> 'name' (did you mean 'x'?); allowed: a, b, c" (the suggestion only when one is close)."""
    allowed = list(allowed)
    return f"unknown {what} {name!r}{did_you_mean(str(name), allowed)}; allowed: {', '.join(allowed)}"
