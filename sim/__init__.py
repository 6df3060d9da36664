"""Sensor emulation: the DVS (event) emulator, the LDR camera model and the event container.

Names are imported on first use (the kernels' modules load numba), so that importing sim for its errors or
parameters, as `evsim --help` does, stays fast.

Exports:
- the DVS: DVSParams, DVS_PRESETS; DVSEmulator, emulate, emulate_source, EVENT_LABELS, NO_EVENT_US (sim.dvs);
- the LDR camera: CameraParams, CAMERA_PRESETS, LDRCamera, LDRFrame (sim.camera);
- sensor models (a preset name or a sensor file, sim.sensor_file): Sensor, load_sensor, write_sensor; the pixel
  arrays of real sensors by name: SENSOR_SIZES (sim.sensor_sizes);
- events: EVENT_DTYPE, make_events, empty_events, concatenate, slice_time, validate_events, is_sorted,
  first_unsorted_index (sim.events);
- gaps in an event stream (dropped packets, exposure-gated exports): find_gaps, resolve_gaps, describe_gaps
  (sim.gaps);
- errors: EvsimInputError, InvalidParameterError, OptionError, TimeOrderError, UnsortedEventsError; EvsimNote (the
  base of evsim's warnings that the command line prints as one "evsim: note:" line).
"""

from . import numba_cache  # noqa: F401  (first: sets numba's cache folder before any kernel imports numba)
from .dvs_params import PRESETS as DVS_PRESETS
from .dvs_params import DVSParams
from .errors import EvsimInputError, EvsimNote, InvalidParameterError, OptionError, TimeOrderError, UnsortedEventsError
from .lazy import lazy_exports

# name -> "submodule" or "submodule:name in it", imported on first use
_LAZY = {
    "CAMERA_PRESETS": "camera_params:PRESETS", "CameraParams": "camera_params",
    **dict.fromkeys(("LDRCamera", "LDRFrame"), "camera"),
    **dict.fromkeys(("EVENT_LABELS", "NO_EVENT_US", "DVSEmulator", "emulate", "emulate_source"), "dvs"),
    **dict.fromkeys(("Sensor", "load_sensor", "write_sensor"), "sensor_file"),
    **dict.fromkeys(("find_gaps", "resolve_gaps", "describe_gaps"), "gaps"), "SENSOR_SIZES": "sensor_sizes",
    **dict.fromkeys(("EVENT_DTYPE", "concatenate", "empty_events", "first_unsorted_index", "is_sorted", "make_events",
                     "slice_time", "validate_events"), "events"),
}
__all__ = ["DVS_PRESETS", "DVSParams", "EvsimInputError", "EvsimNote", "InvalidParameterError", "OptionError",
           "TimeOrderError", "UnsortedEventsError", *_LAZY]
__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals())
