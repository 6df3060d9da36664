"""The native HDF5 layout (one file per sequence), DSEC-like, written in streaming fashion.

Layout (all times int64 microseconds):
    /t_offset (i8)    as in DSEC, stored event times are relative: absolute t = events/t + t_offset. It is the
                      first event's time floored to a whole millisecond (0 for a sequence starting at 0).
    /events/t (i8, relative), /events/x, /events/y (u2), /events/p (u1, 1 = ON, 0 = OFF, as DSEC stores it)
                      time-sorted events; the Python API (sim.EVENT_DTYPE) keeps p = -1/+1
    /events/label (u1, optional)                                      0 signal, 1 shot, 2 leak, 3 hot
    /events attrs     summary (JSON, written at close): {"count", "on", "t_first_us", "t_last_us" (absolute),
                      "labels": [count per label] or null}, so that `evsim info` need not read the events
                      (event_summary checks it against the datasets' length and first and last times)
    /ms_to_idx (u8)   ms_to_idx[k] = index of the first event with events/t >= k * 1000 (i.e. absolute
                      t >= t_offset + k * 1000 us), for k = 0 .. events/t[-1] // 1000 + 1; the last entry is
                      the event count, so events of millisecond k are [ms_to_idx[k], ms_to_idx[k + 1]).
    /frames/images (F, H, W) u1 (bit depth 8) or u2 (9..16), attr bit_depth
    /frames/t_start_us, /frames/t_mid_us, /frames/t_end_us (F,) i8   exposure window of each frame
    /reference/images (R, H, W) f4 linear HDR radiance, /reference/t_us (R,) i8
    /threshold_maps (2, H, W) f4 (optional): ON and OFF contrast thresholds, log units
    root attrs: format="evsim-native", format_version, height, width, metadata (JSON), crf (JSON or absent)
Layout versions: 2 stores events/p as u1 0/1 (DSEC's convention); 1 (files written before) stored i1 -1/+1.
Readers decode p by the file's version; DSEC-like files without the format attribute are read as 0/1.
Datasets are chunked, resizable, byte-shuffled and gzip-compressed (HDF5's standard shuffle and deflate filters,
which every HDF5 reader has); each add_* call appends, so memory stays flat. The writer compresses the events and
images itself, chunk by chunk, with ISA-L's deflate (the isal package, about 8x faster than the zlib inside HDF5
for a few % larger files) and stores the chunks as they are (h5py write_direct_chunk).

References (docs/models/references.md): Gehrig et al. 2021 [Gehrig2021], DSEC.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import h5py
import numpy as np
from isal import isal_zlib

from sim import EvsimInputError, InvalidParameterError, TimeOrderError, UnsortedEventsError, validate_events

from .atomic import DiskFullError, commit, discard, disk_full_error, is_disk_full, temp_sibling
from .common import (
    EVENT_CHUNK,
    H5Output,
    add_offset,
    append_rows,
    check_event_chunk,
    event_chunks,
    events_from_columns,
    fail,
    frame_times_check,
    json_attr,
    open_h5,
    reading,
    require,
    to_json,
    validated,
)
from .recording import N_EVENT_LABELS, Recording, validate_recording

FORMAT_NAME = "evsim-native"
FORMAT_VERSION = 2  # 2: events/p stored 0/1 (DSEC); 1: stored -1/+1
_EVENT_FIELDS = {"t": np.int64, "x": np.uint16, "y": np.uint16, "p": np.uint8}
_EV_H5_CHUNK = 1 << 16
_DEFLATE_LEVEL = 2  # ISA-L's levels are 0..3; on generated sequences 2 is as small as zlib's 1 and ~10x faster


class _ChunkAppender:
    """Appends rows to a resizable chunked dataset by writing whole chunks directly (h5py write_direct_chunk):
    for a dataset with the shuffle and gzip filters, compressed here (numpy byte shuffle, ISA-L deflate: the bytes
    HDF5's own filters would store); for one without filters, as they are. Rows short of a whole chunk wait in
    `tail` until more arrive or finish() pads and writes the last chunk; the dataset's extent grows as whole
    chunks are written, and finish() sets it to the row count."""

    def __init__(self, ds: h5py.Dataset):
        self.ds, self.rows = ds, ds.chunks[0]
        self.deflate = ds.compression == "gzip"  # with shuffle (NativeWriter's layout); else no filters
        self.tail = np.zeros((0,) + ds.shape[1:], dtype=ds.dtype)
        self.n_done = 0  # rows in chunks already written

    def append(self, data: np.ndarray) -> None:
        data = np.asarray(data, dtype=self.tail.dtype)
        if self.tail.size:
            data = np.concatenate([self.tail, data])
        whole = len(data) // self.rows * self.rows
        if whole:
            self.ds.resize(self.n_done + whole, axis=0)
        for i in range(0, whole, self.rows):
            self._write(self.n_done + i, data[i : i + self.rows])
        self.n_done += whole
        self.tail = data[whole:].copy()

    def finish(self) -> None:
        if len(self.tail):
            chunk = np.zeros((self.rows,) + self.tail.shape[1:], dtype=self.tail.dtype)
            chunk[: len(self.tail)] = self.tail
            self.ds.resize(self.n_done + len(self.tail), axis=0)
            self._write(self.n_done, chunk)
            self.n_done += len(self.tail)
            self.tail = self.tail[:0]

    def _write(self, row: int, chunk: np.ndarray) -> None:
        offset, chunk, size = (row,) + (0,) * (chunk.ndim - 1), np.ascontiguousarray(chunk), chunk.dtype.itemsize
        if self.deflate:
            shuffled = chunk.view(np.uint8).reshape(-1, size).T if size > 1 else chunk
            data = isal_zlib.compress(np.ascontiguousarray(shuffled), _DEFLATE_LEVEL)
        else:
            data = chunk.tobytes()
        self.ds.id.write_direct_chunk(offset, data)


#: HDF5 compression of the native layout's datasets: gzip (shuffle + deflate, the default), lzf (faster to write,
#: larger) or None (uncompressed; "none" in a TOML configuration)
COMPRESSIONS = ("gzip", "lzf", None)


def check_compression(compression: str | None) -> str | None:
    """compression if it is one of COMPRESSIONS, else InvalidParameterError naming them.

    Parameters
    ----------
    compression : str or None
        "gzip", "lzf" or None.

    Returns
    -------
    str or None
        compression.
    """
    if compression not in COMPRESSIONS:
        raise InvalidParameterError(f"compression must be 'gzip', 'lzf' or None, got {compression!r}")
    return compression


class NativeWriter:
    """Stream one sequence into a native HDF5 file, atomically.

    Usage: `with NativeWriter(path, H, W, metadata=...) as w: w.add_events(chunk); w.add_frame(...)`.
    Everything goes to a temporary file beside `path`, renamed onto `path` by close() (or a clean `with` exit);
    on an exception inside the `with` block the temporary file is deleted and `path` is left as it was.
    A full disk (or file size limit) raises atomic.DiskFullError naming `path`, from the add_* call or close()
    that met it.

    Parameters
    ----------
    path : str or Path
        The file to write.
    height, width : int
        Sensor size (pixels), > 0.
    metadata : dict
        JSON-serialisable metadata (more can be merged with update_metadata until close).
    frame_bit_depth : int, optional
        Bits per LDR sample, 8..16 (default 8).
    compression : {"gzip", "lzf", None}, optional
        Dataset compression (default "gzip").
    """

    def __init__(self, path: str | Path, height: int, width: int, *, metadata: dict, frame_bit_depth: int = 8,
                 compression: str | None = "gzip"):
        if int(height) <= 0 or int(width) <= 0:
            raise InvalidParameterError(f"sensor size must be positive, got {height}x{width}")
        if not 8 <= int(frame_bit_depth) <= 16:
            raise InvalidParameterError(f"frame_bit_depth must be in 8..16, got {frame_bit_depth}")
        check_compression(compression)
        self.path = Path(path)
        self.height, self.width, self.bit_depth = int(height), int(width), int(frame_bit_depth)
        self._metadata = {}
        self.update_metadata(metadata)
        self._crf = None
        self._n_events = 0
        self._n_on = 0
        self._label_counts = np.zeros(N_EVENT_LABELS, np.int64)
        self._t_first = self._t_last = None
        self._has_labels = None
        self._ms_next = 0  # next ms_to_idx entry to fill
        self._t_offset = None  # fixed by the first non-empty chunk
        self._tmp = temp_sibling(self.path)
        self._f = self._out = None
        try:
            self._out = H5Output(self._tmp)
            self._f = self._out.file
            self._create_layout(compression)
        except BaseException as e:
            self.abort()
            self._raise_disk_full(e)
            raise

    def _create_layout(self, compression) -> None:
        f, h, w = self._f, self.height, self.width
        # byte shuffling before compression: int64 times and float32 references then compress smaller and faster
        kw = {"compression": compression, "shuffle": True} if compression else {}
        if compression == "gzip":
            kw["compression_opts"] = _DEFLATE_LEVEL
        self._appenders = {}
        ev = f.create_group("events")
        for name, dt in _EVENT_FIELDS.items():
            ev.create_dataset(name, (0,), dtype=dt, maxshape=(None,), chunks=(_EV_H5_CHUNK,), **kw)
        f.create_dataset("ms_to_idx", (0,), dtype=np.uint64, maxshape=(None,), chunks=(4096,), **kw)
        f.create_dataset("t_offset", data=np.int64(0))
        fr = f.create_group("frames")
        fr.attrs["bit_depth"] = self.bit_depth
        fdt = np.uint8 if self.bit_depth == 8 else np.uint16
        fr.create_dataset("images", (0, h, w), dtype=fdt, maxshape=(None, h, w), chunks=(1, h, w), **kw)
        ref = f.create_group("reference")
        ref.create_dataset("images", (0, h, w), dtype=np.float32, maxshape=(None, h, w), chunks=(1, h, w), **kw)
        for g, names in ((fr, ("t_start_us", "t_mid_us", "t_end_us")), (ref, ("t_us",))):
            for name in names:
                g.create_dataset(name, (0,), dtype=np.int64, maxshape=(None,), chunks=(1024,))
        self._kw = kw
        # datasets by path, and the last frame and reference times: looked up once, not per append
        self._ds = {name: f[name] for name in ["ms_to_idx"] + [f"events/{n}" for n in _EVENT_FIELDS] +
                    [f"frames/{n}" for n in ("images", "t_start_us", "t_mid_us", "t_end_us")] +
                    ["reference/images", "reference/t_us"]}
        self._last_frame_t = self._last_reference_t = None
        for name in self._ds:
            self._appender(name)

    # -- appending ------------------------------------------------------------------------------------------
    def add_events(self, events: np.ndarray, labels: np.ndarray | None = None) -> None:
        """Append a chunk of events. Either every chunk has labels or none has.

        Parameters
        ----------
        events : numpy.ndarray
            Time-sorted sim.EVENT_DTYPE events (t int64 us, none before the previous chunk's last), inside the
            sensor.
        labels : numpy.ndarray, optional
            uint8 per-event labels (0 signal, 1 shot, 2 leak, 3 hot), of events' shape.
        """
        validate_events(events, name="event chunk")
        if events.size == 0:
            return
        if self._t_last is not None and events["t"][0] < self._t_last:
            raise UnsortedEventsError(
                f"event chunk starts at t={events['t'][0]} us, before the previous chunk's last event "
                f"t={self._t_last} us: chunks must arrive in time order")
        if events["x"].max() >= self.width or events["y"].max() >= self.height:
            raise EvsimInputError(f"event coordinates exceed the sensor size {self.width}x{self.height}")
        if self._has_labels is not None and (labels is not None) != self._has_labels:
            raise EvsimInputError("event labels must be given for every event chunk or for none")
        if labels is not None:
            labels = np.asarray(labels)
            if labels.shape != events.shape or labels.dtype != np.uint8:
                raise EvsimInputError(f"labels must be uint8 of shape {events.shape}, got {labels.dtype} "
                                      f"{labels.shape}")
            if labels.size and int(labels.max()) >= N_EVENT_LABELS:
                raise EvsimInputError(f"labels must be in 0..{N_EVENT_LABELS - 1}, got {int(labels.max())}")
        if self._has_labels is None:
            self._has_labels = labels is not None
            if self._has_labels:
                self._ds["events/label"] = self._f["events"].create_dataset(
                    "label", (0,), dtype=np.uint8, maxshape=(None,), chunks=(_EV_H5_CHUNK,), **self._kw)
                self._appender("events/label")
        n0, n = self._n_events, events.size
        if self._t_offset is None:
            self._t_offset = int(events["t"][0]) // 1000 * 1000
        t = events["t"] - self._t_offset
        stored = {"t": t, "x": events["x"], "y": events["y"], "p": (events["p"] > 0).astype(np.uint8)}
        for name in _EVENT_FIELDS:
            self._append(f"events/{name}", stored[name])
        if labels is not None:
            self._append("events/label", labels)
        # ms_to_idx entries whose millisecond starts at or before this chunk's last event are now known.
        k_last = int(t[-1]) // 1000
        if k_last >= self._ms_next:
            ks = np.arange(self._ms_next, k_last + 1, dtype=np.int64) * 1000
            self._append("ms_to_idx", (n0 + np.searchsorted(t, ks, side="left")).astype(np.uint64))
            self._ms_next = k_last + 1
        self._n_events += n
        self._n_on += int(np.count_nonzero(events["p"] > 0))
        if labels is not None:
            self._label_counts += np.bincount(labels, minlength=N_EVENT_LABELS)[:N_EVENT_LABELS]
        self._t_first = int(events["t"][0]) if self._t_first is None else self._t_first
        self._t_last = int(events["t"][-1])

    def add_frame(self, image: np.ndarray, t_start_us: int, t_mid_us: int, t_end_us: int) -> None:
        """Append one LDR frame with its exposure window (frames in order of t_mid_us).

        Parameters
        ----------
        image : numpy.ndarray
            Unsigned integer (H, W) raw frame (DN), values < 2**frame_bit_depth.
        t_start_us, t_mid_us, t_end_us : int
            Exposure start, middle and end (us).
        """
        image = np.asarray(image)
        if image.shape != (self.height, self.width) or image.dtype.kind != "u":
            raise EvsimInputError(f"frame must be unsigned integer ({self.height}, {self.width}), got "
                                  f"{image.dtype} {image.shape}")
        if image.size and int(image.max()) >= 1 << self.bit_depth:
            raise EvsimInputError(f"frame value {int(image.max())} exceeds {self.bit_depth}-bit range")
        ts = [int(t_start_us), int(t_mid_us), int(t_end_us)]
        frame_times_check(*ts)
        if self._last_frame_t is not None and ts[1] < self._last_frame_t:
            raise TimeOrderError(f"frame at t_mid={ts[1]} us comes after one at {self._last_frame_t} us")
        self._append("frames/images", image[None])
        for name, t in zip(("t_start_us", "t_mid_us", "t_end_us"), ts):
            self._append(f"frames/{name}", np.array([t], dtype=np.int64))
        self._last_frame_t = ts[1]

    def add_reference(self, image: np.ndarray, t_us: int) -> None:
        """Append one HDR reference frame (reference frames in time order).

        Parameters
        ----------
        image : numpy.ndarray
            Float (H, W) linear radiance (radiance units), finite, >= 0.
        t_us : int
            Its time (us).
        """
        image = np.asarray(image, dtype=np.float32)
        if image.shape != (self.height, self.width):
            raise EvsimInputError(f"reference must be ({self.height}, {self.width}), got {image.shape}")
        if not np.all(np.isfinite(image)) or image.min(initial=0) < 0:
            raise EvsimInputError("reference radiance must be finite and >= 0")
        if self._last_reference_t is not None and int(t_us) < self._last_reference_t:
            raise TimeOrderError(f"reference at t={int(t_us)} us comes after one at {self._last_reference_t} us")
        self._append("reference/images", image[None])
        self._append("reference/t_us", np.array([int(t_us)], dtype=np.int64))
        self._last_reference_t = int(t_us)

    def _appender(self, name: str) -> None:
        """Route appends to dataset `name` through a _ChunkAppender (with gzip or no compression; lzf goes
        through h5py's filter pipeline)."""
        if self._kw.get("compression") in ("gzip", None):
            self._appenders[name] = _ChunkAppender(self._ds[name])

    def _append(self, name: str, data: np.ndarray) -> None:
        appender = self._appenders.get(name)
        if appender is None:
            append_rows(self._ds[name], data)
        else:
            appender.append(data)
        try:
            self._out.check()  # a failed write (full disk), Ctrl-C or SIGTERM: stop here
        except BaseException as e:
            self.abort()
            self._raise_disk_full(e)
            raise

    def _raise_disk_full(self, e: BaseException) -> None:
        if is_disk_full(e) and not isinstance(e, DiskFullError):
            raise disk_full_error(e, self.path) from e

    def set_threshold_maps(self, maps: np.ndarray) -> None:
        """Store the contrast threshold maps (replacing any stored before).

        Parameters
        ----------
        maps : numpy.ndarray
            (2, H, W) ON and OFF contrast thresholds (log units).
        """
        maps = np.asarray(maps, dtype=np.float32)
        if maps.shape != (2, self.height, self.width):
            raise EvsimInputError(f"threshold maps must be (2, {self.height}, {self.width}), got {maps.shape}")
        if "threshold_maps" in self._f:
            del self._f["threshold_maps"]
        self._f.create_dataset("threshold_maps", data=maps, **self._kw)

    def set_crf(self, crf: dict | None) -> None:
        """Record the camera response curve.

        Parameters
        ----------
        crf : dict or None
            {"name": ..., "params": {...}} (``crf_models.get(name, **params)`` rebuilds it; JSON-serialisable), or None.
        """
        if crf is not None and not (isinstance(crf, dict) and "name" in crf):
            raise EvsimInputError(f"crf must be a dict with 'name' and 'params', got {crf!r}")
        to_json(crf)
        self._crf = crf

    def update_metadata(self, metadata: dict) -> None:
        """Merge keys into the metadata (written when the file is closed).

        Parameters
        ----------
        metadata : dict
            JSON-serialisable keys and values.
        """
        try:
            to_json(metadata)
        except (TypeError, ValueError) as e:
            raise EvsimInputError(f"metadata is not JSON-serialisable: {e}") from e
        self._metadata.update(metadata)

    # -- finishing ------------------------------------------------------------------------------------------
    def close(self) -> None:
        """Finish the file and move it onto `path`. Idempotent."""
        if self._f is None:
            return
        try:
            f = self._f
            self._append("ms_to_idx", np.array([self._n_events], dtype=np.uint64))
            for appender in self._appenders.values():
                appender.finish()
            f["t_offset"][()] = self._t_offset or 0
            f["events"].attrs["summary"] = to_json(
                {"count": self._n_events, "on": self._n_on, "t_first_us": self._t_first, "t_last_us": self._t_last,
                 "labels": self._label_counts.tolist() if self._has_labels else None})
            f.attrs.update({"format": FORMAT_NAME, "format_version": FORMAT_VERSION,
                            "height": self.height, "width": self.width, "metadata": to_json(self._metadata)})
            if self._crf is not None:
                f.attrs["crf"] = to_json(self._crf)
            self._f = None
            out, self._out = self._out, None
            out.close()
            commit(self._tmp, self.path)
        except BaseException as e:
            self.abort()
            self._raise_disk_full(e)
            raise

    def abort(self) -> None:
        """Drop the temporary file; `path` is left untouched."""
        if self._out is not None:
            self._out.abort()  # (a failed write's error is not raised: the error that led here is reported)
            self._f = self._out = None
        discard(self._tmp)

    def __enter__(self) -> NativeWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()
            self._raise_disk_full(exc)


def write_native(rec: Recording, path: str | Path, *,
                 event_source: Iterator[tuple[np.ndarray, np.ndarray | None]] | None = None,
                 compression: str | None = "gzip") -> None:
    """Write a Recording as a native file, atomically.

    Parameters
    ----------
    rec : Recording
        The recording.
    path : str or Path
        The file to write.
    event_source : iterator of (numpy.ndarray, numpy.ndarray or None), optional
        (events, labels) chunks to write instead of rec.events / rec.event_labels (a stream).
    compression : {"gzip", "lzf", None}, optional
        As NativeWriter's.
    """
    validate_recording(rec)
    with NativeWriter(path, rec.height, rec.width, metadata=rec.metadata, frame_bit_depth=rec.frame_bit_depth,
                      compression=compression) as w:
        for ev, lab in event_source if event_source is not None else recording_event_chunks(rec):
            w.add_events(ev, lab)
        if rec.frames is not None:
            for img, t0, tm, t1 in zip(rec.frames, rec.frame_t_start_us, rec.frame_t_mid_us, rec.frame_t_end_us):
                w.add_frame(img, t0, tm, t1)
        if rec.reference is not None:
            for img, t in zip(rec.reference, rec.reference_t_us):
                w.add_reference(img, t)
        if rec.threshold_maps is not None:
            w.set_threshold_maps(rec.threshold_maps)
        w.set_crf(rec.crf)


def recording_event_chunks(rec: Recording, size: int = EVENT_CHUNK) -> Iterator[tuple[np.ndarray, np.ndarray | None]]:
    """A Recording's events in chunks.

    Parameters
    ----------
    rec : Recording
        The recording.
    size : int, optional
        Events per chunk (default EVENT_CHUNK).

    Yields
    ------
    tuple of numpy.ndarray
        (events, labels): sim.EVENT_DTYPE events and their uint8 labels, or None when the recording has none.
    """
    for i, ev in enumerate(event_chunks(rec.events, size)):
        yield ev, None if rec.event_labels is None else rec.event_labels[i * size : i * size + ev.size]


# -- reading ----------------------------------------------------------------------------------------------------
def is_native(f: h5py.File) -> bool:
    """Whether an open HDF5 file is in the native layout (by format attribute, or DSEC-like events/t).

    Parameters
    ----------
    f : h5py.File
        The open file.

    Returns
    -------
    bool
        True for the native layout.
    """
    fmt = f.attrs.get("format")
    return (fmt.decode() if isinstance(fmt, bytes) else fmt) == FORMAT_NAME or "events/t" in f


def iter_native_events(path: str | Path, size: int = EVENT_CHUNK) -> Iterator[tuple[np.ndarray, np.ndarray | None]]:
    """Stream the events of a native file without loading the whole stream. Each chunk is checked as load()
    checks a whole recording (coordinates inside the sensor, sorted across chunks, labels in range).

    Parameters
    ----------
    path : str or Path
        The native file.
    size : int, optional
        Events per chunk (default EVENT_CHUNK).

    Yields
    ------
    tuple of numpy.ndarray
        (events, labels): sim.EVENT_DTYPE events (absolute t, int64 us) and their uint8 labels, or None.
    """
    with open_h5(path) as f:
        with reading(path):
            _require_complete(f, path)
            require(f, path, ["events/t", "events/x", "events/y", "events/p"])
            ev = f["events"]
            n, t_offset, version = ev["t"].shape[0], _t_offset(f), _layout_version(f)
            h, w = _resolution(f, path)
        t_last = None
        for i in range(0, n, size):
            with reading(path):
                cols = [ev[k][i : i + size] for k in ("t", "x", "y", "p")]
                cols[0] = add_offset(path, cols[0], t_offset)
                cols[3] = _decode_polarity(path, cols[3], version)
                labels = ev["label"][i : i + size] if "label" in ev else None
                chunk = events_from_columns(path, *cols)
            t_last = check_event_chunk(path, chunk, h, w, t_last, labels)
            yield chunk, labels


def event_summary(path: str | Path) -> dict | None:
    """The event summary a native file records (see the layout: count, on, t_first_us, t_last_us, labels), when
    it agrees with the file: the count equals the event datasets' length and the first and last times equal the
    stored first and last events' (two reads).

    Parameters
    ----------
    path : str or Path
        The native file.

    Returns
    -------
    dict or None
        {"count", "on", "t_first_us", "t_last_us" (absolute us), "labels" (count per label, or None)}; None when
        the file records none (older files) or it disagrees: then stream the events (iter_native_events).
    """
    with open_h5(path) as f:
        with reading(path):
            _require_complete(f, path)
            require(f, path, ["events/t"])
            ev = f["events"]
            summary = json_attr(ev, "summary")
            if not isinstance(summary, dict):
                return None
            t = ev["t"]
            n, offset = t.shape[0], _t_offset(f)
            if any(k not in summary for k in ("count", "on", "t_first_us", "t_last_us", "labels")) \
                    or summary["count"] != n or not 0 <= summary["on"] <= n \
                    or ((summary["labels"] is None) != ("label" not in ev)):
                return None
            if n and (summary["t_first_us"] != int(t[0]) + offset or summary["t_last_us"] != int(t[n - 1]) + offset):
                return None
            if summary["labels"] is not None and sum(summary["labels"]) != n:
                return None
    return summary


def iter_native_columns(path: str | Path, names: tuple[str, ...] = ("t", "p"),
                        size: int = EVENT_CHUNK) -> Iterator[dict[str, np.ndarray]]:
    """Stream some event columns of a native file in chunks. Lighter than iter_native_events (which builds and
    checks whole events) for a pass that needs a few columns, e.g. an event rate from t and p; times are checked
    to be sorted, x and y to be inside the sensor.

    Parameters
    ----------
    path : str or Path
        The native file.
    names : tuple of str, optional
        The columns: of "t", "x", "y", "p", "label" (default ("t", "p")).
    size : int, optional
        Events per chunk (default EVENT_CHUNK).

    Yields
    ------
    dict of str to numpy.ndarray
        {name: array}: t absolute int64 us, x and y uint16, p int8 -1/+1, label uint8.
    """
    with open_h5(path) as f:
        with reading(path):
            _require_complete(f, path)
            require(f, path, [f"events/{n}" for n in names])
            ev, offset, version = f["events"], _t_offset(f), _layout_version(f)
            n, (h, w) = ev["t"].shape[0], _resolution(f, path)
        t_last = None
        for i in range(0, n, size):
            with reading(path):
                chunk = {name: ev[name][i : i + size] for name in names}
                for name, side in (("x", w), ("y", h)):
                    if name in chunk and chunk[name].size and int(chunk[name].max()) >= side:
                        raise fail(path, f"event coordinates outside the {w}x{h} sensor (max {name} "
                                         f"{int(chunk[name].max())}, in events {i}..{i + chunk[name].size})")
                if "t" in chunk:
                    t = chunk["t"] = add_offset(path, chunk["t"], offset)
                    if t.size and ((t_last is not None and t[0] < t_last) or np.any(np.diff(t) < 0)):
                        raise fail(path, f"events are not sorted by time (in events {i}..{i + t.size})")
                    t_last = int(t[-1]) if t.size else t_last
                if "p" in chunk:
                    chunk["p"] = _decode_polarity(path, chunk["p"], version)
            yield chunk


def read_native_window(path: str | Path, t_start_us: int, t_end_us: int) -> np.ndarray:
    """The events of a time window of a native file, read through its ms_to_idx index (only the milliseconds that
    overlap the window are read; a file without the index is searched by binary search on events/t).

    Parameters
    ----------
    path : str or Path
        The native file.
    t_start_us, t_end_us : int
        The window [t_start_us, t_end_us) (absolute us).

    Returns
    -------
    numpy.ndarray
        sim.EVENT_DTYPE events with t_start_us <= t < t_end_us.
    """
    with open_h5(path) as f:
        with reading(path):
            _require_complete(f, path)
            require(f, path, ["events/t", "events/x", "events/y", "events/p"])
            ev, offset, version = f["events"], _t_offset(f), _layout_version(f)
            t, n = ev["t"], ev["t"].shape[0]
            lo_t, hi_t = int(t_start_us) - offset, int(t_end_us) - offset
            if "ms_to_idx" in f and f["ms_to_idx"].shape[0]:
                idx = f["ms_to_idx"]
                m = idx.shape[0]
                lo = int(idx[min(max(lo_t // 1000, 0), m - 1)]) if lo_t > 0 else 0
                hi = int(idx[min(max(-(-hi_t // 1000), 0), m - 1)]) if hi_t > 0 else 0
                lo, hi = min(lo, n), min(max(hi, lo), n)
            else:
                lo, hi = _search(t, lo_t), _search(t, hi_t)
            cols = [ev[k][lo:hi] for k in ("t", "x", "y", "p")]
            cols[0] = add_offset(path, cols[0], offset)
            cols[3] = _decode_polarity(path, cols[3], version)
            h, w = _resolution(f, path)
            events = events_from_columns(path, *cols)
            validated(path, Recording(events=events, height=h, width=w))
    from sim import slice_time

    return slice_time(events, int(t_start_us), int(t_end_us))


def _search(t: h5py.Dataset, value: int) -> int:
    """The first index i of the sorted dataset t with t[i] >= value (binary search, one element per step)."""
    lo, hi = 0, t.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if int(t[mid]) < value:
            lo = mid + 1
        else:
            hi = mid
    return lo


def read_native(path: str | Path, *, events: bool = True) -> Recording:
    """Read a native file into a Recording.

    Parameters
    ----------
    path : str or Path
        The native file.
    events : bool, optional
        Read the event stream and labels (default True; False skips them).

    Returns
    -------
    Recording
        The recording.
    """
    with open_h5(path) as f, reading(path):
        return validated(path, _native_recording(f, path, events=events, lazy_images=False))


@contextmanager
def open_native_images(path: str | Path) -> Iterator[Recording]:
    """A Recording of a native file without its events, whose frames and reference are the file's HDF5 datasets
    (read one image at a time when indexed or iterated, so memory does not grow with the sequence length); valid
    inside the with block. Exporters stream the events alongside with iter_native_events.

    Parameters
    ----------
    path : str or Path
        The native file.

    Yields
    ------
    Recording
        The recording without events, its images lazy.
    """
    with open_h5(path) as f:
        with reading(path):
            rec = validated(path, _native_recording(f, path, events=False, lazy_images=True))
        yield rec


def _native_recording(f: h5py.File, path, *, events: bool, lazy_images: bool) -> Recording:
    if not is_native(f):
        raise fail(path, "not a native evsim HDF5 file")
    _require_complete(f, path)
    require(f, path, ["events/t", "events/x", "events/y", "events/p", "frames/images", "frames/t_start_us",
                      "frames/t_mid_us", "frames/t_end_us"])
    h, w = _resolution(f, path)
    ev = f["events"]
    if events:
        evs = events_from_columns(path, add_offset(path, ev["t"][()], _t_offset(f)), ev["x"][()], ev["y"][()],
                                  _decode_polarity(path, ev["p"][()], _layout_version(f)))
        labels = ev["label"][()] if "label" in ev else None
    else:
        evs = events_from_columns(path, [], [], [], [])
        labels = None

    def images(ds):
        return (ds if lazy_images else ds[()]) if ds.shape[0] else None

    fr = f["frames"]
    nf = fr["images"].shape[0]
    ref = f["reference"] if "reference" in f and f["reference/images"].shape[0] else None
    if nf and not all(fr[k].shape[0] == nf for k in ("t_start_us", "t_mid_us", "t_end_us")):
        raise fail(path, "frame time datasets do not have one entry per frame")
    return Recording(
        events=evs, height=h, width=w,
        frames=images(fr["images"]),
        frame_t_start_us=fr["t_start_us"][()] if nf else None,
        frame_t_mid_us=fr["t_mid_us"][()] if nf else None,
        frame_t_end_us=fr["t_end_us"][()] if nf else None,
        frame_bit_depth=int(fr.attrs.get("bit_depth", 8 * fr["images"].dtype.itemsize)),
        reference=None if ref is None else images(ref["images"]),
        reference_t_us=None if ref is None else ref["t_us"][()],
        crf=json_attr(f, "crf"),
        threshold_maps=f["threshold_maps"][()] if "threshold_maps" in f else None,
        event_labels=labels,
        metadata=json_attr(f, "metadata", {}),
    )


def _layout_version(f: h5py.File) -> int:
    """The layout version of a complete native file (see _require_complete): its format_version attribute."""
    return int(f.attrs.get("format_version", 1))


def _decode_polarity(path, p: np.ndarray, version: int) -> np.ndarray:
    """Stored polarity -> int8 -1/+1: version >= 2 (and DSEC) stores 0/1, version 1 stored -1/+1."""
    p = np.asarray(p)
    if version >= 2:
        if p.size and p.max() > 1:
            raise fail(path, f"events/p must hold 0/1 (layout version {version}), found {int(p.max())}")
        return (p.astype(np.int8) * 2 - 1).astype(np.int8)
    return p.astype(np.int8)


def _require_complete(f: h5py.File, path) -> None:
    """NativeWriter sets the root attribute format="evsim-native" only when it closes the file: a file without it
    is an interrupted write (e.g. a leftover temporary file), never read as a valid recording."""
    fmt = f.attrs.get("format")
    if (fmt.decode() if isinstance(fmt, bytes) else fmt) != FORMAT_NAME:
        raise fail(path, f"no format={FORMAT_NAME!r} attribute: an incomplete (interrupted) or foreign file")


def _t_offset(f: h5py.File) -> int:
    return int(f["t_offset"][()]) if "t_offset" in f else 0


def _resolution(f: h5py.File, path) -> tuple[int, int]:
    if "height" in f.attrs and "width" in f.attrs:
        return int(f.attrs["height"]), int(f.attrs["width"])
    if f["frames/images"].shape[0]:
        return tuple(int(s) for s in f["frames/images"].shape[1:])
    raise fail(path, "sensor size unknown: no height/width attributes and no frames")
