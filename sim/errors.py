"""Exceptions raised at evsim's boundaries. All derive from ValueError so that callers can catch broadly."""


class EvsimInputError(ValueError):
    """Input data is malformed: wrong shape or dtype, NaN/inf/negative radiance, and the like."""


class InvalidParameterError(EvsimInputError):
    """A configuration value is out of its valid range (negative rate, threshold <= 0, ...)."""


class TimeOrderError(EvsimInputError):
    """Timestamps are not (strictly) increasing where they must be."""


class UnsortedEventsError(TimeOrderError):
    """An event array is not sorted by time."""
