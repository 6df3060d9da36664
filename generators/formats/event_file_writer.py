"""What the streamed event-file writers share (AEDAT 2.0, Prophesee EVT 3.0 / EVT 2.0 / .dat): the file written
through a temporary sibling and moved onto its path when closed (atomic.atomic_path), the checks every chunk of
events passes, and close, abort and the `with` block (a full disk becomes DiskFullError naming the path).
"""

from __future__ import annotations

from pathlib import Path
from typing import Self

import numpy as np

from sim import EvsimInputError

from .atomic import DiskFullError, atomic_path, disk_full_error, is_disk_full


class EventFileWriter:
    """Base of a writer of one event file of height x width pixels. A subclass writes its header in
    _start(offset), called with the time offset (us) fixed by the first event, or with 0 by close() when no event
    came; it sets self._offset there."""

    def __init__(self, path: str | Path, height: int, width: int):
        self.path, self.height, self.width = Path(path), int(height), int(width)
        self._atomic = atomic_path(self.path)
        self._tmp = self._atomic.__enter__()
        self._f = open(self._tmp, "wb")
        self._offset: int | None = None
        self._t_last: int | None = None  # the last event time written (absolute us)

    def _start(self, offset: int) -> None:
        raise NotImplementedError

    def _checked_times(self, events: np.ndarray) -> np.ndarray | None:
        """The int64 times of a chunk of sim.EVENT_DTYPE events (None when it is empty), after checking that it
        starts no earlier than the previous chunk ended and lies inside the sensor (EvsimInputError)."""
        if events.size == 0:
            return None
        t = events["t"].astype(np.int64)
        if self._t_last is not None and t[0] < self._t_last:
            raise EvsimInputError(f"event chunk starts at t={t[0]} us, before the previous chunk's last event")
        if events["x"].max() >= self.width or events["y"].max() >= self.height:
            raise EvsimInputError(f"event coordinates exceed the sensor size {self.width}x{self.height}")
        return t

    def close(self) -> None:
        """Finish the file and move it onto its path."""
        if self._f is None:
            return
        try:
            if self._offset is None:
                self._start(0)
            self._f.close()
            self._f = None
        except BaseException as e:
            self.abort(e)
            if is_disk_full(e):
                raise disk_full_error(e, self.path) from e
            raise
        self._atomic.__exit__(None, None, None)

    def abort(self, exc: BaseException | None = None) -> None:
        """Drop the temporary file; the path is left untouched."""
        if self._f is not None:
            try:
                self._f.close()  # flushes: a full disk raises again (the file descriptor is closed anyway)
            except OSError:
                pass
            self._f = None
        exc = exc or RuntimeError("aborted")
        try:
            self._atomic.__exit__(type(exc), exc, None)
        except BaseException:  # atomic_path re-raises the exception it was given
            pass

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort(exc)
            if is_disk_full(exc) and not isinstance(exc, DiskFullError):
                raise disk_full_error(exc, self.path) from exc
