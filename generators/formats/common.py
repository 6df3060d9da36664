"""Shared pieces of the format modules: the error type, safe HDF5 access and small conversions."""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import h5py
import numpy as np

from sim import EVENT_DTYPE, EvsimInputError, TimeOrderError, validate_events

EVENT_CHUNK = 1 << 20  # events per chunk when streaming between files (about 13 MB as EVENT_DTYPE)


class DatasetFormatError(EvsimInputError):
    """A dataset file or folder cannot be read: missing, truncated, malformed or of an unknown layout."""


def fail(path, problem: str) -> DatasetFormatError:
    """The error to raise for `path`, naming the file and the problem."""
    return DatasetFormatError(f"{path}: {problem}")


@contextmanager
def open_h5(path) -> Iterator[h5py.File]:
    """Open an HDF5 file for reading; missing/truncated/corrupt files and missing objects become DatasetFormatError."""
    path = Path(path)
    if not path.is_file():
        raise fail(path, "no such file")
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
        raise fail(path, f"unreadable data (truncated or corrupt?): {e}") from e


def require(f: h5py.File, path, names: list[str]) -> None:
    """Raise DatasetFormatError listing the datasets of `names` that `f` lacks."""
    missing = [n for n in names if n not in f]
    if missing:
        raise fail(path, f"missing dataset(s) {', '.join(missing)}")


def json_attr(obj, name: str, default=None):
    """Decode a JSON string attribute, or `default` when it is absent."""
    if name not in obj.attrs:
        return default
    raw = obj.attrs[name]
    return json.loads(raw.decode() if isinstance(raw, bytes) else str(raw))


def to_json(value) -> str:
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


def events_from_columns(path, t, x, y, p) -> np.ndarray:
    """Build a sorted-checked EVENT_DTYPE array from decoded columns; bad content becomes DatasetFormatError."""
    ev = np.empty(len(t), dtype=EVENT_DTYPE)
    for name, col in (("t", t), ("x", x), ("y", y), ("p", p)):
        ev[name] = col
    try:
        return validate_events(ev, name=f"events of {path}")
    except EvsimInputError as e:
        raise fail(path, str(e)) from e


def polarity_pm1(p) -> np.ndarray:
    """Polarity as int8 -1/+1 from any of the field's encodings (bool, 0/1, -1/+1)."""
    return np.where(np.asarray(p).astype(np.int64) > 0, 1, -1).astype(np.int8)


def _shape_dtype(images) -> tuple[tuple[int, ...], np.dtype]:
    """Shape and dtype of an image stack without reading it (an array, or an HDF5 dataset read lazily)."""
    if hasattr(images, "shape") and hasattr(images, "dtype"):
        return tuple(images.shape), np.dtype(images.dtype)
    a = np.asarray(images)
    return a.shape, a.dtype


def check_recording(rec) -> None:
    """Raise EvsimInputError unless a Recording's arrays agree with each other (shapes, lengths, dtypes)."""
    validate_events(rec.events, name="recording events")
    h, w = rec.height, rec.width
    if rec.event_labels is not None and np.shape(rec.event_labels) != rec.events.shape:
        raise EvsimInputError(f"{np.shape(rec.event_labels)} event labels for {rec.events.size} events")
    if rec.frames is not None:
        shape, dtype = _shape_dtype(rec.frames)
        if len(shape) != 3 or shape[1:] != (h, w) or dtype.kind != "u":
            raise EvsimInputError(f"frames must be unsigned (F, {h}, {w}), got {dtype} {shape}")
        for name in ("frame_t_start_us", "frame_t_mid_us", "frame_t_end_us"):
            if np.shape(getattr(rec, name)) != (shape[0],):
                raise EvsimInputError(f"{name} must have one entry per frame ({shape[0]})")
    if rec.reference is not None:
        shape, _ = _shape_dtype(rec.reference)
        if len(shape) != 3 or shape[1:] != (h, w) or np.shape(rec.reference_t_us) != (shape[0],):
            raise EvsimInputError(f"reference must be (R, {h}, {w}) with R times, got {shape} and "
                                  f"{np.shape(rec.reference_t_us)} times")
    if rec.threshold_maps is not None and np.shape(rec.threshold_maps) != (2, h, w):
        raise EvsimInputError(f"threshold maps must be (2, {h}, {w}), got {np.shape(rec.threshold_maps)}")


def frame_times_check(t_start, t_mid, t_end) -> None:
    """Raise TimeOrderError unless t_start <= t_mid <= t_end (microseconds)."""
    if not (t_start <= t_mid <= t_end):
        raise TimeOrderError(f"frame times must satisfy t_start <= t_mid <= t_end, got {t_start}, {t_mid}, {t_end} us")
