"""Exceptions raised at evsim's boundaries (all derive from ValueError so that callers can catch broadly), the base
class of evsim's notes (EvsimNote, a UserWarning), and the
shared checks of parameters: one helper per kind (number, integer, real-valued array), each naming the parameter."""

from __future__ import annotations

import dataclasses
import math
import numbers
from typing import TYPE_CHECKING

from .suggest import unknown_name

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt


class EvsimInputError(ValueError):
    """Input data is malformed: wrong shape or dtype, NaN/inf/negative radiance, and the like."""


class InvalidParameterError(EvsimInputError):
    """A configuration value is out of its valid range (negative rate, threshold <= 0, ...)."""


class OptionError(EvsimInputError):
    """Bad input whose remedy is an option: str() names it as the Python keyword (overwrite=True), cli_message as
    the command-line flag (--overwrite), so that each interface speaks only its own names."""

    def __init__(self, message: str, cli_message: str):
        super().__init__(message)
        self.cli_message = cli_message

    def __reduce__(self):  # pickled whole (an error from a worker process)
        return type(self), (str(self), self.cli_message)


class EvsimNote(UserWarning):
    """A note to the user (the input is used, but something in it deserves a look). The evsim command line prints it
    as one line "evsim: note: ...": str() names a remedy in Python keywords, cli_message in command-line flags (as
    OptionError); without a cli_message both say the same."""

    def __init__(self, message: str, cli_message: str | None = None):
        super().__init__(message)
        self.cli_message = message if cli_message is None else cli_message

    def __reduce__(self):
        return type(self), (str(self), self.cli_message)


class TimeOrderError(EvsimInputError):
    """Timestamps are not (strictly) increasing where they must be."""


class UnsortedEventsError(TimeOrderError):
    """An event array is not sorted by time."""


def toml_type(value: object) -> str:
    """The TOML name of a value's type as a configuration file wrote it ("a string", "an integer", "a table", ...),
    for messages about configuration and sensor files, which speak TOML rather than Python."""
    for kind, name in ((bool, "a boolean"), (str, "a string"), (int, "an integer"), (float, "a number"),
                       (dict, "a table"), (list, "an array")):
        if isinstance(value, kind):
            return name
    return "a date or time" if hasattr(value, "isoformat") else f"a {type(value).__name__}"


def _kind(value: object) -> str:
    return f"{type(value).__name__} {value!r:.60}"


def check_number(name: str, value: object, *, positive: bool) -> float:
    """`value` as a float; InvalidParameterError unless it is a finite real number (an int, float or numpy number;
    not a bool, string or complex), > 0 when `positive`, else >= 0. `name` is the parameter's name, quoted in the
    message."""
    v = check_real(name, value)
    if positive and v <= 0:
        raise InvalidParameterError(f"{name} must be > 0, got {value}")
    if v < 0:
        raise InvalidParameterError(f"{name} must be >= 0, got {value}")
    return v


def check_real(name: str, value: object) -> float:
    """`value` as a float; InvalidParameterError unless it is a finite real number of any sign (not a bool,
    string or complex)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise InvalidParameterError(f"{name} must be a finite number, got {_kind(value)}")
    return float(value)


def check_int(name: str, value: object, *, minimum: int | None = None, maximum: int | None = None,
              unit: str = "") -> int:
    """`value` as an int; InvalidParameterError unless it is an integer (int or numpy integer; not a bool, a float
    or a string) within [minimum, maximum] (either bound optional). `unit` (e.g. "microseconds") is quoted."""
    what = "an integer" + (f" ({unit})" if unit else "")
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise InvalidParameterError(f"{name} must be {what}, got {_kind(value)}")
    v = int(value)
    if (minimum is not None and v < minimum) or (maximum is not None and v > maximum):
        span = (f"in [{minimum}, {maximum}]" if minimum is not None and maximum is not None
                else f">= {minimum}" if minimum is not None else f"<= {maximum}")
        raise InvalidParameterError(f"{name} must be {what} {span}, got {v}")
    return v


def check_real_array(name: str, value: object, *, error: type[EvsimInputError] = EvsimInputError
                     ) -> npt.NDArray[np.float64]:
    """`value` as a float64 array; `error` unless its values are real numbers: an integer or floating dtype, not
    bool, complex, object (e.g. a list mixing numbers and strings) or strings. Finiteness and range are the
    caller's to check (their meaning differs: radiance, contrast, ...)."""
    import numpy as np  # here, so that importing sim (for its errors) stays light

    try:
        a = np.asarray(value)
    except (TypeError, ValueError) as e:  # ragged nested lists
        raise error(f"{name} must be an array of real numbers: {e}") from None
    if a.dtype.kind not in "iuf":
        raise error(f"{name} must hold real numbers (integer or float), got dtype {a.dtype}"
                    + (f" ({_kind(value)})" if a.ndim == 0 else ""))
    return a.astype(np.float64, copy=False)


def check_override_names(where: str, cls: type, overrides: dict) -> None:
    """InvalidParameterError naming the first keyword of `overrides` that is not a field of the dataclass `cls`,
    with the closest field and the list of them (a preset's overrides)."""
    fields = [f.name for f in dataclasses.fields(cls) if f.init]
    for key in overrides:
        if key not in fields:
            raise InvalidParameterError(f"{where}: {unknown_name(f'{cls.__name__} field', key, fields)}")
