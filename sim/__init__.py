"""Sensor emulation: the DVS (event) emulator, the LDR camera model and the event container."""

from .errors import EvsimInputError, InvalidParameterError, TimeOrderError, UnsortedEventsError
from .events import (
    EVENT_DTYPE,
    concatenate,
    empty_events,
    first_unsorted_index,
    is_sorted,
    make_events,
    slice_time,
    validate_events,
)
