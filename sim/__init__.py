"""Sensor emulation: the DVS (event) emulator, the LDR camera model and the event container."""

from .camera import PRESETS as CAMERA_PRESETS, CameraParams, LDRCamera, LDRFrame
from .dvs import EVENT_LABELS, NO_EVENT_US, DVSEmulator, emulate, emulate_source
from .dvs_params import PRESETS as DVS_PRESETS, DVSParams
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
