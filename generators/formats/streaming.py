"""The events of any readable file as a stream of time-ordered chunks, with the sensor size.

Native HDF5, Prophesee EVT 3.0 / EVT 2.0 .raw and .dat, and AEDAT 2.0 files are read a chunk at a time (memory does
not grow with the stream); the other layouts are loaded whole (load()) and then cut into chunks.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .aedat2 import iter_aedat2_events
from .aedat2 import sensor_size as aedat2_sensor_size
from .common import EVENT_CHUNK, open_h5, reading
from .native import _resolution, _t_offset, iter_native_events, recording_event_chunks
from .prophesee import PROPHESEE_FORMATS, _read_header, iter_prophesee_events
from .prophesee import _geometry as _prophesee_geometry


@dataclass
class EventStream:
    """height, width: sensor size (pixels). chunks(): a new iterator over sim.EVENT_DTYPE chunks in time order.
    t_range: (first, last) event time in microseconds when known without reading the stream (native files), else
    None. streamed: whether chunks() reads the file a chunk at a time (False: the file was loaded whole)."""

    height: int
    width: int
    chunks: Callable[[], Iterator[np.ndarray]]
    t_range: tuple[int, int] | None
    streamed: bool


def open_event_stream(path: str | Path, size: int = EVENT_CHUNK) -> EventStream:
    """The event stream of the file or folder `path` (any layout generators.formats.load reads); bad files raise
    DatasetFormatError naming them, as load() does."""
    from . import detect, load

    path = Path(path)
    kind = detect(path)
    if kind == "native":
        with open_h5(path) as f, reading(path):
            h, w = _resolution(f, path)
            t = f["events/t"]
            t_range = (int(t[0]) + _t_offset(f), int(t[-1]) + _t_offset(f)) if t.shape[0] else None
        return EventStream(h, w, lambda: (c for c, _ in iter_native_events(path, size)), t_range, True)
    if kind in PROPHESEE_FORMATS:
        with open(path, "rb") as f:
            keys, _ = _read_header(path, f)
        h, w = _prophesee_geometry(path, keys)
        if h is not None:
            return EventStream(h, w, lambda: iter_prophesee_events(path, size), None, True)
    if kind == "aedat2":
        h, w = aedat2_sensor_size(path)
        return EventStream(h, w, lambda: iter_aedat2_events(path, size), None, True)
    rec = load(path)
    t_range = (int(rec.events["t"][0]), int(rec.events["t"][-1])) if rec.events.size else None
    return EventStream(rec.height, rec.width, lambda: (c for c, _ in recording_event_chunks(rec, size)), t_range,
                       False)
