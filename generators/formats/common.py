"""Shared pieces of the format modules: the error type, safe HDF5 access and small conversions."""

from __future__ import annotations

import gc
import json
import os
import select
import signal
import sys
import time
import warnings
import zlib
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import h5py
import numpy as np

from sim import EVENT_DTYPE, EvsimInputError, EvsimNote, TimeOrderError, validate_events

from . import held_interrupts
from .atomic import GuardedSink, is_disk_full
from .recording import MAX_SENSOR_PX, MAX_TIME_US, Recording, validate_recording

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

EVENT_CHUNK = 1 << 20  # events per chunk when streaming between files (about 13 MB as EVENT_DTYPE)


class DatasetFormatError(EvsimInputError):
    """A dataset file or folder cannot be read: missing, truncated, malformed or of an unknown layout."""


class ReaderNoteWarning(EvsimNote):
    """A file is read, but something in it deserves a look (a long silence that a corrupt time word would also
    give)."""


def fail(path: str | Path, problem: str) -> DatasetFormatError:
    """The error to raise for `path`, naming the file and the problem."""
    return DatasetFormatError(f"{path}: {problem}")


#: seconds without progress after which the structure read of an HDF5 file (probe_h5) is stopped
PROBE_STALL_S = 5.0
_PROBED: dict[tuple[int, int, int, int], None] = {}  # (device, inode, size, mtime) of files that read through


def probe_h5(path: str | Path) -> None:
    """Read the whole structure of the HDF5 file `path` in a forked child process: every group, dataset header,
    attribute value, chunk index and variable-length dataset. HDF5 loops forever on some corrupt metadata (a
    zeroed global heap, where variable-length strings live, spins inside HDF5 holding the GIL, where neither a
    signal handler nor another thread can stop it) and may crash on some; in the child, a read that makes no
    progress for PROBE_STALL_S seconds is stopped. Either becomes DatasetFormatError; errors HDF5 reports are
    left to the caller's own read. A file that read through is remembered (device, inode, size, mtime) and not
    probed again. Without os.fork (Windows) nothing is probed.

    Cost: one fork and the structure walk, 10-40 ms per file (measured up to 20 M events: the data, event
    columns and images, is not read); checksums would not do: HDF5 keeps none on global heaps."""
    path = Path(path)
    try:
        st = path.stat()
    except OSError:
        return  # the caller's open says what is wrong
    key = (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)
    if key in _PROBED or not hasattr(os, "fork"):
        return
    outcome = _in_child(lambda tick: _walk_h5(path, tick), PROBE_STALL_S)
    if outcome == "stalled":
        raise fail(path, f"corrupt HDF5 metadata: reading the file's structure made no progress for "
                         f"{PROBE_STALL_S:g} s (HDF5 loops on it)")
    if outcome != "done":
        raise fail(path, f"corrupt HDF5 metadata: the HDF5 library crashed reading the file's structure ({outcome})")
    if len(_PROBED) > 4096:
        _PROBED.clear()
    _PROBED[key] = None


def _walk_h5(path: Path, tick: Callable[[], None]) -> None:
    """Touch everything in an HDF5 file that a reader's metadata access could touch (see probe_h5); HDF5's own
    errors are ignored here (the caller's read reports them)."""

    def attributes(obj) -> None:
        try:
            names = list(obj.attrs)
        except Exception:
            return
        for k in names:
            try:
                obj.attrs[k]
            except Exception:
                pass
            tick()

    def visit(name, obj) -> None:
        try:
            attributes(obj)
            if isinstance(obj, h5py.Dataset):
                obj.shape, obj.dtype, obj.chunks, obj.compression  # noqa: B018 (header messages)
                if obj.chunks is not None:
                    obj.id.chunk_iter(lambda info: None)  # the chunk index (B-tree)
                if h5py.check_vlen_dtype(obj.dtype) is not None or obj.dtype.kind == "O":
                    obj[()]  # variable-length data lives in the global heap
        except Exception:
            pass
        tick()

    with h5py.File(path, "r") as f:
        attributes(f)
        tick()
        f.visititems(visit)


def _in_child(work: Callable[[Callable[[], None]], None], stall_s: float) -> str:
    """Run work(tick) in a forked child; return "done" when it ended (with or without an exception), "stalled"
    when it did not call tick() for stall_s seconds (it is killed), else how it died ("signal 11")."""
    r, w = os.pipe()
    pid = None
    try:
        with h5py._objects.phil, warnings.catch_warnings():  # no other thread is inside HDF5 while forking
            warnings.simplefilter("ignore", DeprecationWarning)  # (Python 3.12+: fork of a threaded process)
            pid = os.fork()
        if pid == 0:  # the child: never returns
            try:
                gc.disable()  # (the parent's garbage is the parent's to collect: finalizers run once)
                signal.set_wakeup_fd(-1)  # (the parent's, if any: its signals are not the child's)
                work(lambda: os.write(w, b"."))
            finally:
                os._exit(0)
        os.close(w)
        w = -1
        last = time.monotonic()
        while True:
            ready, _, _ = select.select([r], [], [], 0.1)
            if ready:
                if not os.read(r, 65536):
                    break  # EOF: the child has exited
                last = time.monotonic()
            elif time.monotonic() - last > stall_s:
                return "stalled"  # (killed below)
        _, status = os.waitpid(pid, 0)
        pid = None
        if os.WIFSIGNALED(status):
            return f"signal {os.WTERMSIG(status)}"
        return "done" if os.WEXITSTATUS(status) == 0 else f"exit {os.WEXITSTATUS(status)}"
    finally:  # also on SIGTERM or Ctrl-C while waiting: the child goes too
        if pid:
            try:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
            except OSError:
                pass
        os.close(r)
        if w >= 0:
            os.close(w)


@contextmanager
def open_h5(path: str | Path) -> Iterator[h5py.File]:
    """Open an HDF5 file for reading; missing/truncated/corrupt files and missing objects become DatasetFormatError.
    The file's structure is read first in a child process with a deadline (probe_h5): corrupt metadata on which
    HDF5 would loop forever or crash is refused."""
    path = Path(path)
    if not path.is_file():
        raise fail(path, "no such file")
    probe_h5(path)
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise fail(path, f"not a readable HDF5 file (truncated or corrupt?): {e}") from e
    try:
        with f:
            yield f
    except KeyError as e:
        raise fail(path, f"missing dataset or attribute: {e}") from e
    except OSError as e:
        if is_disk_full(e):  # an output written while this file is open (export): not this file's fault
            raise
        raise fail(path, f"unreadable data (truncated or corrupt?): {e}") from e


class H5Output:
    """An HDF5 file being written to `tmp` through an atomic.GuardedSink, so that a failed write (a full disk)
    never reaches HDF5: `file` is the h5py.File; check() raises the error of a failed write (call it after each
    block of data); close() closes the file and raises that error; abort() closes without raising it.

    From creation to close() or abort() (one of which every path must call), Ctrl-C and SIGTERM are held
    (held_interrupts): check() delivers them, and close() and abort() deliver one received meanwhile once the
    file is closed."""

    def __init__(self, tmp: str | Path):
        self._holding = held_interrupts.hold()
        try:
            self.sink = GuardedSink(tmp)
        except BaseException:
            self._release()
            raise
        try:
            self.file = h5py.File(self.sink, "w")
        except BaseException:
            self._close_sink_quietly()
            self._release()
            raise

    def check(self) -> None:
        """Deliver a Ctrl-C or SIGTERM received since the last check; raise the error of a failed write, if any."""
        held_interrupts.deliver_pending()
        self.sink.check()

    def close(self) -> None:
        """Close the HDF5 file, then the sink; raise the error of a failed write, if any."""
        try:
            self.file.close()
        except BaseException:
            self._close_sink_quietly()
            self._release()
            raise
        try:
            self.sink.close()
        finally:
            self._release()

    def abort(self) -> None:
        """Close without raising a failed write's error (the caller has an error of its own to report)."""
        try:
            self.file.close()
        except Exception:
            pass
        self._close_sink_quietly()
        self._release()

    def _release(self) -> None:
        if self._holding:
            self._holding = False
            held_interrupts.release()

    def _close_sink_quietly(self) -> None:
        try:
            self.sink.close()
        except OSError:
            pass


# What libraries raise on malformed content (h5py, zlib, json, scipy.io, numpy, int()/float() of bad values).
LIBRARY_ERRORS = (OSError, ValueError, KeyError, IndexError, TypeError, AttributeError, RuntimeError, OverflowError,
                  UnicodeError, zlib.error, MemoryError)


@contextmanager
def reading(path: str | Path) -> Iterator[None]:
    """Turn every error raised while decoding `path` into DatasetFormatError naming the file.

    Wrap only the reading itself, never code that runs on what was read (a caller's with-body)."""
    try:
        yield
    except DatasetFormatError:
        raise
    except OSError as e:
        if is_disk_full(e):  # an output's, not this file's
            raise
        raise fail(path, f"malformed content ({type(e).__name__}: {e})") from e
    except EvsimInputError as e:
        raise fail(path, str(e)) from e
    except MemoryError as e:
        raise fail(path, "content too large to load (corrupt sizes?)") from e
    except LIBRARY_ERRORS as e:
        raise fail(path, f"malformed content ({type(e).__name__}: {e})") from e


@contextmanager
def quiet_native_output() -> Iterator[None]:
    """Send what is written to file descriptors 1 and 2, and to sys.stdout and sys.stderr, while the block runs to
    /dev/null: native libraries write there directly or through Python's streams (a Rust panic's message and, with
    RUST_BACKTRACE, a backtrace; libpng's and OpenCV's complaints; the OpenEXR binding's "Warning: ..." printed to
    sys.stdout), where evsim's own one-line error already says what failed. C's stdio buffers are flushed before the
    descriptors are restored, so nothing held back reaches them later. Wrap only the library's calls: Python's own
    writes in the block go too."""
    import ctypes

    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    saved = [os.dup(fd) for fd in (1, 2)]
    streams = sys.stdout, sys.stderr
    try:
        with open(os.devnull, "w") as null:
            for fd in (1, 2):
                os.dup2(null.fileno(), fd)
            sys.stdout = sys.stderr = null
            yield
    finally:
        sys.stdout, sys.stderr = streams
        if os.name == "posix":  # (the C library of the process itself: CDLL(None) is POSIX only)
            ctypes.CDLL(None).fflush(None)
        for fd, copy in zip((1, 2), saved):
            os.dup2(copy, fd)
            os.close(copy)


def validated(path: str | Path, rec: Recording) -> Recording:
    """validate_recording(rec), its errors as DatasetFormatError naming `path`; returns rec."""
    with reading(path):
        return validate_recording(rec)


def check_event_chunk(path: str | Path, chunk: np.ndarray, height: int, width: int, t_last: int | None,
                      labels: np.ndarray | None = None) -> int | None:
    """Check one chunk of a streamed reader as load() checks a whole recording (validate_recording: polarity,
    time order, coordinates inside the height x width sensor, labels), and that it does not start before the
    previous chunk's last time `t_last`; DatasetFormatError naming `path`. Returns the new last time."""
    if not chunk.size:
        return t_last
    if t_last is not None and chunk["t"][0] < t_last:
        raise fail(path, f"events are not sorted by time across chunks: {int(chunk['t'][0])} us after {t_last} us")
    validated(path, Recording(events=chunk, height=height, width=width, event_labels=labels))
    return int(chunk["t"][-1])


def checked_event_chunks(path: str | Path, chunks: Iterator[np.ndarray], height: int,
                         width: int) -> Iterator[np.ndarray]:
    """The chunks of a streamed reader, each passed through check_event_chunk: a stream holds what load() of the
    same file would accept, or raises its error."""
    t_last = None
    for chunk in chunks:
        t_last = check_event_chunk(path, chunk, height, width, t_last)
        yield chunk


def require(f: h5py.File, path: str | Path, names: list[str]) -> None:
    """Raise DatasetFormatError listing the datasets of `names` that `f` lacks."""
    missing = [n for n in names if n not in f]
    if missing:
        raise fail(path, f"missing dataset(s) {', '.join(missing)}")


def json_attr(obj: h5py.Group | h5py.Dataset, name: str, default: Any = None) -> Any:
    """Decode a JSON string attribute, or `default` when it is absent."""
    if name not in obj.attrs:
        return default
    raw = obj.attrs[name]
    try:
        return json.loads(raw.decode() if isinstance(raw, bytes) else str(raw))
    except ValueError as e:  # JSONDecodeError, UnicodeDecodeError
        raise fail(getattr(getattr(obj, "file", None), "filename", "?"), f"attribute {name!r} is not JSON: {e}") from e


def to_json(value: object) -> str:
    """JSON text of a metadata value (numpy scalars and arrays become plain numbers and lists)."""

    def default(o):
        if isinstance(o, np.generic):
            return o.item()
        if isinstance(o, np.ndarray):
            return o.tolist()
        if isinstance(o, Path):
            return str(o)
        raise TypeError(f"metadata value of type {type(o).__name__} is not JSON-serialisable")

    return json.dumps(value, default=default, sort_keys=True)


def append_rows(ds: h5py.Dataset, data: np.ndarray) -> None:
    """Append rows to a resizable HDF5 dataset along its first axis."""
    n = ds.shape[0]
    ds.resize(n + len(data), axis=0)
    ds[n:] = data


def event_chunks(events: np.ndarray, size: int = EVENT_CHUNK) -> Iterator[np.ndarray]:
    """Consecutive views of at most `size` events."""
    for i in range(0, events.size, size):
        yield events[i : i + size]


def _checked_column(path, name: str, col, lo: int, hi: int) -> np.ndarray:
    """A decoded integer column checked to be numeric, whole and in lo..hi before any cast (a cast would wrap
    x = -1 to 65535, NaN to 0 and uint64 times >= 2**63 to negative ones)."""
    col = np.asarray(col)
    if col.size == 0:
        return col
    if col.dtype.kind not in "iuf" and col.dtype != np.bool_:
        raise fail(path, f"event column {name} must be numeric, got {col.dtype}")
    if col.dtype.kind == "f":
        if not np.isfinite(col).all():
            raise fail(path, f"event column {name} holds NaN or infinite values")
        if not (col == np.round(col)).all():
            raise fail(path, f"event column {name} holds non-integer values")
    if col.min() < lo or col.max() > hi:
        raise fail(path, f"event column {name} outside {lo}..{hi}: {col.min()}..{col.max()}")
    return col


def add_offset(path: str | Path, t: ArrayLike, offset: int) -> np.ndarray:
    """int64 times t + offset (microseconds), DatasetFormatError instead of a silent int64 wrap-around."""
    t = _checked_column(path, "t", t, -MAX_TIME_US, MAX_TIME_US)
    offset = int(offset)
    if abs(offset) > MAX_TIME_US:
        raise fail(path, f"time offset {offset} us outside +-2**62 us")
    return t.astype(np.int64) + np.int64(offset)


def events_from_columns(path: str | Path, t: ArrayLike, x: ArrayLike, y: ArrayLike, p: ArrayLike) -> np.ndarray:
    """Build a sorted-checked EVENT_DTYPE array from decoded columns; bad content becomes DatasetFormatError."""
    t = np.asarray(t)
    if any(np.shape(c) != t.shape for c in (x, y, p)) or t.ndim != 1:
        raise fail(path, f"event columns differ in shape: {[np.shape(c) for c in (t, x, y, p)]}")
    ev = np.empty(len(t), dtype=EVENT_DTYPE)
    for name, col, lo, hi in (("t", t, -MAX_TIME_US, MAX_TIME_US), ("x", x, 0, MAX_SENSOR_PX - 1),
                              ("y", y, 0, MAX_SENSOR_PX - 1), ("p", p, -1, 1)):
        ev[name] = _checked_column(path, name, col, lo, hi)
    try:
        return validate_events(ev, name=f"events of {path}")
    except EvsimInputError as e:
        raise fail(path, str(e)) from e


def polarity_pm1(path: str | Path, p: ArrayLike) -> np.ndarray:
    """Polarity as int8 -1/+1 from the field's encodings: bool, 0/1 or -1/+1 (0 and -1 are OFF, 1 is ON), whatever
    the number type (1.0 is 1). Any other value (2, 0.5, NaN) is refused with DatasetFormatError naming `path` and
    the values found: a reader never guesses what 4 or 0.5 means."""
    p = np.asarray(p)
    if p.dtype.kind not in "biuf":
        raise fail(path, f"event polarity must be numeric or boolean, got {p.dtype}")
    if p.dtype.kind == "b" or p.size == 0:
        return np.where(p, 1, -1).astype(np.int8)
    if not ((p == 0) | (p == 1) | (p == -1)).all():
        found = np.unique(p)
        listed = ", ".join(f"{v:g}" for v in found[:6]) + (f" and {found.size - 6} more" if found.size > 6 else "")
        raise fail(path, f"event polarity must be 0/1 or -1/+1 (0 and -1 are OFF), found values {listed}")
    return np.where(p > 0, 1, -1).astype(np.int8)


def frame_times_check(t_start: int, t_mid: int, t_end: int) -> None:
    """Raise TimeOrderError unless t_start <= t_mid <= t_end (microseconds)."""
    if not (t_start <= t_mid <= t_end):
        raise TimeOrderError(f"frame times must satisfy t_start <= t_mid <= t_end, got {t_start}, {t_mid}, {t_end} us")
