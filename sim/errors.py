"""Exceptions raised at evsim's boundaries (all derive from ValueError so that callers can catch broadly), and the
shared check of numeric parameters."""

import math
import numbers


class EvsimInputError(ValueError):
    """Input data is malformed: wrong shape or dtype, NaN/inf/negative radiance, and the like."""


class InvalidParameterError(EvsimInputError):
    """A configuration value is out of its valid range (negative rate, threshold <= 0, ...)."""


class TimeOrderError(EvsimInputError):
    """Timestamps are not (strictly) increasing where they must be."""


class UnsortedEventsError(TimeOrderError):
    """An event array is not sorted by time."""


def check_number(name: str, value: object, *, positive: bool) -> None:
    """Raise InvalidParameterError unless `value` is a finite real number (not a bool), > 0 when `positive`,
    else >= 0. `name` is the parameter's name, quoted in the message."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise InvalidParameterError(f"{name} must be a finite number, got {value!r}")
    if positive and value <= 0:
        raise InvalidParameterError(f"{name} must be > 0, got {value}")
    if value < 0:
        raise InvalidParameterError(f"{name} must be >= 0, got {value}")
