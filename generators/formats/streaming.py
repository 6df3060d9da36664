"""The events of any readable file as one stream: time-ordered chunks, time windows, count and span, sensor size.

open_event_stream(path) reads native HDF5, Prophesee EVT 3.0 / EVT 2.0 .raw and .dat, and AEDAT 2.0 files a chunk
at a time (memory does not grow with the stream); the other layouts are loaded whole (load()) and then cut into
chunks. EventStream.of_array wraps events already in memory. Plots (`evsim plot events`), the DVS video writer
and any other pass over a file's events read them through EventStream. Every chunk of a file read a chunk at a
time is checked as load() checks the whole file (common.check_event_chunk): a stream never yields an event that
load() would refuse.

A native file is read as little as the pass needs: chunks(columns) reads only the named columns (e.g. t and p
for an event rate), window(t0, t1) only the milliseconds of its ms_to_idx index that overlap the window, and the
count and span come from the length and the first and last entries of events/t.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from pathlib import Path

import numpy as np

from .aedat2 import iter_aedat2_events
from .aedat2 import sensor_size as aedat2_sensor_size
from .common import EVENT_CHUNK, checked_event_chunks, event_chunks, open_h5, reading
from .native import (
    _t_offset,
    iter_native_columns,
    iter_native_events,
    open_native_images,
    read_native_window,
)
from .prophesee import PROPHESEE_FORMATS, _read_header, iter_prophesee_events
from .prophesee import _geometry as _prophesee_geometry

Chunk = np.ndarray | Mapping[str, np.ndarray]

__all__ = ["EventStream", "open_event_stream"]


class EventStream:
    """The events of one recording, read a chunk or a window at a time.

    count and t_range are known without a pass over the stream for native files and events in memory, else counted
    by one pass the first time they are asked for. Build one with open_event_stream or EventStream.of_array.

    Parameters
    ----------
    height, width : int
        Sensor size (pixels).
    chunks : callable
        chunks(columns) -> a new iterator over the events in time order (see the chunks method).
    window : callable, optional
        window(t0, t1) -> the events with t0 <= t < t1 (us); default: cut from the chunks.
    count : int, optional
        The number of events, when known.
    t_range : tuple of int, optional
        The first and last event times (us), when known.
    streamed : bool, optional
        Whether chunks() reads the file a chunk at a time (default True; False: the events are in memory).

    Attributes
    ----------
    height, width : int
        Sensor size (pixels).
    streamed : bool
        As the parameter.
    count : int
        The number of events.
    t_range : tuple of int or None
        First and last event time (us); None without events.
    known_t_range : tuple of int or None
        t_range when it is known without a pass, else None.
    """

    def __init__(self, height: int, width: int, chunks: Callable[[tuple[str, ...] | None], Iterator[Chunk]], *,
                 window: Callable[[int, int], np.ndarray] | None = None, count: int | None = None,
                 t_range: tuple[int, int] | None = None, streamed: bool = True):
        self.height, self.width, self.streamed = int(height), int(width), streamed
        self._chunks, self._window = chunks, window
        self._count, self._t_range = count, t_range

    @classmethod
    def of_array(cls, events: np.ndarray, height: int, width: int, size: int = EVENT_CHUNK) -> EventStream:
        """The stream of events in memory.

        Parameters
        ----------
        events : numpy.ndarray
            sim.EVENT_DTYPE events (t int64 us), time-sorted.
        height, width : int
            Sensor size (pixels).
        size : int, optional
            Events per chunk (default EVENT_CHUNK).

        Returns
        -------
        EventStream
            The stream (streamed False).
        """
        from sim import slice_time

        n = int(events.size)
        return cls(height, width, lambda columns: event_chunks(events, size),
                   window=lambda t0, t1: slice_time(events, t0, t1), count=n,
                   t_range=(int(events["t"][0]), int(events["t"][-1])) if n else None, streamed=False)

    def chunks(self, columns: tuple[str, ...] | None = None) -> Iterator[Chunk]:
        """The events in time order, chunk by chunk: a new iterator at each call.

        Parameters
        ----------
        columns : tuple of str, optional
            The fields needed, e.g. ("t", "p"): chunks then need hold only those fields (indexable by name: a
            native file reads only those columns). Default None: whole events.

        Returns
        -------
        iterator of numpy.ndarray or mapping
            sim.EVENT_DTYPE chunks (t int64 us), or mappings of the named columns.
        """
        return self._chunks(columns)

    def window(self, t_start_us: int, t_end_us: int) -> np.ndarray:
        """The events of a time window.

        Parameters
        ----------
        t_start_us, t_end_us : int
            The window [t_start_us, t_end_us) (us).

        Returns
        -------
        numpy.ndarray
            sim.EVENT_DTYPE events with t_start_us <= t < t_end_us.
        """
        if self._window is not None:
            return self._window(int(t_start_us), int(t_end_us))
        from sim import EVENT_DTYPE, slice_time

        parts = []
        for chunk in self.chunks():
            if chunk.size and chunk["t"][-1] >= t_start_us:
                parts.append(slice_time(chunk, t_start_us, t_end_us))
                if chunk["t"][-1] >= t_end_us:
                    break
        return np.concatenate(parts) if parts else np.zeros(0, EVENT_DTYPE)

    @property
    def known_t_range(self) -> tuple[int, int] | None:
        return self._t_range

    @property
    def count(self) -> int:
        if self._count is None:
            self._count_pass()
        return self._count

    @property
    def t_range(self) -> tuple[int, int] | None:
        if self._count is None:
            self._count_pass()
        return self._t_range

    def _count_pass(self) -> None:
        n, first, last = 0, None, None
        for chunk in self.chunks(("t",)):
            t = chunk["t"]
            if t.size:
                n, first, last = n + t.size, int(t[0]) if first is None else first, int(t[-1])
        self._count, self._t_range = n, (first, last) if n else None


def open_event_stream(path: str | Path, size: int = EVENT_CHUNK) -> EventStream:
    """The event stream of a file or folder; bad files raise DatasetFormatError naming them, as load() does.

    Parameters
    ----------
    path : str or Path
        A file or folder in any layout generators.formats.load reads.
    size : int, optional
        Events per chunk (default EVENT_CHUNK).

    Returns
    -------
    EventStream
        The stream.
    """
    from . import detect, load

    path = Path(path)
    kind = detect(path)
    if kind == "native":
        with open_native_images(path) as rec:  # the file checked as load() checks it, images left unread
            h, w = rec.height, rec.width
        with open_h5(path) as f, reading(path):
            t = f["events/t"]
            n, offset = int(t.shape[0]), _t_offset(f)
            t_range = (int(t[0]) + offset, int(t[n - 1]) + offset) if n else None

        def native_chunks(columns):
            if columns is None:
                return (c for c, _ in iter_native_events(path, size))
            return iter_native_columns(path, tuple(columns), size)

        return EventStream(h, w, native_chunks, window=lambda t0, t1: read_native_window(path, t0, t1), count=n,
                           t_range=t_range)
    if kind in PROPHESEE_FORMATS:
        with open(path, "rb") as f:
            keys, _ = _read_header(path, f)
        h, w = _prophesee_geometry(path, keys)
        if h is not None:
            return EventStream(h, w, lambda columns: checked_event_chunks(path, iter_prophesee_events(path, size), h,
                                                                          w))
    if kind == "aedat2":
        h, w = aedat2_sensor_size(path)
        return EventStream(h, w, lambda columns: checked_event_chunks(path, iter_aedat2_events(path, size), h, w))
    rec = load(path)
    return EventStream.of_array(rec.events, rec.height, rec.width, size)
