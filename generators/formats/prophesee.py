"""Prophesee (Metavision) event files: EVT 3.0 and EVT 2.0 `.raw`, and `.dat`; streamed writers and readers.

What they hold: CD events (t, x, y, polarity) and the sensor size, nothing else (no frames, reference, labels,
thresholds, CRF or metadata). Polarity is 1 = ON, 0 = OFF on disk (-1/+1 in evsim). Time base: integer
microseconds, stored relative to an offset that the header records as `% evsim_t_offset_us N` (0 when the
recording's times fit the format from 0: a stream starting at t >= 2**24 us for EVT 3.0, 2**34 for EVT 2.0,
2**32 for .dat has offset = its first event time floored to a millisecond). Readers of other software see the
stored (relative) times; evsim's reader adds the offset back.

Layouts (little-endian):
    .raw: ASCII header lines "% key value" ending with "% end", then words. Header: "% evt 3.0" (or 2.0),
          "% format EVT3;height=H;width=W", "% geometry WxH", evsim's keys. The data starts with a TIME_HIGH 0
          word so that no decoder mistakes a first data byte 0x25 ('%') for more header.
    EVT 3.0: 16-bit words, see prophesee_kernels.py. The 24-bit time wraps every 16.8 s; TIME_HIGH words make
          every wrap visible, so streams of any length are exact.
    EVT 2.0: 32-bit words, type in bits 31..28: 0x0 CD_OFF / 0x1 CD_ON with bits 27..22 time bits 5..0,
          21..11 x, 10..0 y; 0x8 TIME_HIGH with bits 27..0 = time bits 33..6 (2**34 us, about 4.8 h, per file).
          Other types (0xA trigger, 0xE, 0xF) are skipped.
    .dat: "% " header lines (Version 2, Date, Height, Width, evsim's keys), then two bytes event type 0 (2D/CD)
          and size 8, then 8-byte events: uint32 t, uint32 x (bits 13..0) | y (27..14) | p (31..28). 32-bit
          times (2**32 us, about 71 min, per file). As prophesee-automotive-dataset-toolbox src/io/dat_events_tools.py.
"""

from __future__ import annotations

import datetime
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from sim import EvsimInputError

from .atomic import DiskFullError, atomic_path, disk_full_error, is_disk_full
from .common import EVENT_CHUNK, events_from_columns, fail
from .native import recording_event_chunks
from .prophesee_kernels import TIME_HIGH_MAX_STEP, decode_evt3, encode_evt3
from .recording import Recording, validate_recording

PROPHESEE_FORMATS = ("evt3", "evt2", "dat")
SUFFIX = {"evt3": ".raw", "evt2": ".raw", "dat": ".dat"}
_TIME_LIMIT = {"evt3": 1 << 24, "evt2": 1 << 34, "dat": 1 << 32}  # stored times must start (evt3) or stay below
_MAX_COORD = {"evt3": 2048, "evt2": 2048, "dat": 1 << 14}
_WORD = {"evt3": np.dtype("<u2"), "evt2": np.dtype("<u4")}
_DAT_EVENT = np.dtype([("t", "<u4"), ("xyp", "<u4")])
LAYOUT_VERSION = 1
_POPCOUNT = np.array([bin(i).count("1") for i in range(4096)], np.int64)  # set bits of 12-bit vector masks


class PropheseeWriter:
    """Stream events into an EVT 3.0 / EVT 2.0 .raw or a .dat file, atomically (`with` block or close()).

    The time offset is fixed by the first event (see the module docstring); later chunks must stay in the
    format's time range (EvsimInputError otherwise, naming the limit)."""

    def __init__(self, path: str | Path, fmt: str, height: int, width: int):
        if fmt not in PROPHESEE_FORMATS:
            raise EvsimInputError(f"unknown Prophesee format {fmt!r}; one of {', '.join(PROPHESEE_FORMATS)}")
        if not (0 < height <= _MAX_COORD[fmt] and 0 < width <= _MAX_COORD[fmt]):
            raise EvsimInputError(f"{fmt} holds sensors up to {_MAX_COORD[fmt]} pixels a side, got {width}x{height}")
        self.path, self.fmt, self.height, self.width = Path(path), fmt, int(height), int(width)
        self._atomic = atomic_path(self.path)
        self._tmp = self._atomic.__enter__()
        self._f = open(self._tmp, "wb")
        self._offset = None
        self._t_last = None
        self._state = np.array([0, -1, -1], np.int64)  # evt3 encoder: time_high 0 written first

    def _start(self, t_offset: int) -> None:
        self._offset = t_offset
        self._f.write(self._header().encode("ascii"))
        if self.fmt == "evt3":
            self._f.write(np.array([0x8000], "<u2").tobytes())
        elif self.fmt == "evt2":
            self._f.write(np.array([0x8000_0000], "<u4").tobytes())
            self._th2 = 0
        else:
            self._f.write(bytes([0, 8]))  # event type 0 (2D / CD events), 8 bytes per event

    def _header(self) -> str:
        h, w = self.height, self.width
        evsim = [f"% evsim_layout_version {LAYOUT_VERSION}", f"% evsim_t_offset_us {self._offset}",
                 "% evsim_time_base us", "% evsim_polarity 1=ON 0=OFF",
                 "% evsim_holds events, sensor size (no frames, reference, labels, thresholds, CRF, metadata)"]
        if self.fmt == "dat":
            date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M:%S")
            return "\n".join(["% Data file containing Event2D events.", "% Version 2", f"% Date {date}",
                              f"% Height {h}", f"% Width {w}", *evsim]) + "\n"
        version = "3.0" if self.fmt == "evt3" else "2.0"
        fmt = "EVT3" if self.fmt == "evt3" else "EVT2"
        return "\n".join([f"% evt {version}", f"% format {fmt};height={h};width={w}", f"% geometry {w}x{h}",
                          "% integrator_name evsim", *evsim, "% end"]) + "\n"

    def add_events(self, events: np.ndarray) -> None:
        """Append a time-sorted chunk of sim.EVENT_DTYPE events, later than every earlier chunk."""
        if events.size == 0:
            return
        t = events["t"].astype(np.int64)
        if self._t_last is not None and t[0] < self._t_last:
            raise EvsimInputError(f"event chunk starts at t={t[0]} us, before the previous chunk's last event")
        if events["x"].max() >= self.width or events["y"].max() >= self.height:
            raise EvsimInputError(f"event coordinates exceed the sensor size {self.width}x{self.height}")
        limit = _TIME_LIMIT[self.fmt]
        if self._offset is None:
            self._start(0 if 0 <= t[0] < limit else int(t[0]) // 1000 * 1000)
        t = t - self._offset
        if self.fmt != "evt3" and t[-1] >= limit:
            raise EvsimInputError(f"{self.fmt} stores times below {limit} us ({limit / 3.6e9:.2f} h) after the "
                                  f"offset {self._offset} us; this stream lasts longer")
        self._t_last = int(events["t"][-1])
        getattr(self, f"_write_{self.fmt}")(t, events)

    def _write_evt3(self, t, ev) -> None:
        gap = int(t[-1] >> 12) - int(self._state[0])
        out = np.empty(4 * t.size + gap // TIME_HIGH_MAX_STEP + 1, np.uint16)
        n = encode_evt3(t, ev["x"], ev["y"], ev["p"], self._state, out)
        self._f.write(out[:n].tobytes())

    def _write_evt2(self, t, ev) -> None:
        th = t >> 6
        new = np.empty(t.size, bool)
        new[0] = th[0] != self._th2
        new[1:] = th[1:] != th[:-1]
        self._th2 = int(th[-1])
        cd_pos = np.arange(t.size) + np.cumsum(new)
        out = np.empty(t.size + int(new.sum()), "<u4")
        out[cd_pos[new] - 1] = (0x8 << 28) | th[new].astype(np.uint32)
        out[cd_pos] = ((ev["p"] > 0).astype(np.uint32) << 28) | ((t & 63).astype(np.uint32) << 22) | \
            (ev["x"].astype(np.uint32) << 11) | ev["y"].astype(np.uint32)
        self._f.write(out.tobytes())

    def _write_dat(self, t, ev) -> None:
        out = np.empty(t.size, _DAT_EVENT)
        out["t"] = t
        out["xyp"] = ev["x"].astype(np.uint32) | (ev["y"].astype(np.uint32) << 14) | \
            ((ev["p"] > 0).astype(np.uint32) << 28)
        self._f.write(out.tobytes())

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

    def __enter__(self) -> PropheseeWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort(exc)
            if is_disk_full(exc) and not isinstance(exc, DiskFullError):
                raise disk_full_error(exc, self.path) from exc


def write_prophesee(rec: Recording, path: str | Path, fmt: str, *, event_source: Iterator | None = None) -> None:
    """Write a Recording's events as `fmt` (evt3, evt2 or dat), streamed chunk by chunk and atomically."""
    validate_recording(rec)
    with PropheseeWriter(path, fmt, rec.height, rec.width) as w:
        for chunk, _ in event_source if event_source is not None else recording_event_chunks(rec):
            w.add_events(chunk)


# -- reading ----------------------------------------------------------------------------------------------------
def _read_header(path: Path, f) -> tuple[dict, int]:
    """Parse "% key value" header lines; returns (keys, byte offset of the data). A .raw header ends at
    "% end" (or at the first line not starting with '%'), a .dat header at the first line not starting "% "."""
    keys, pos = {}, 0
    while True:
        pos = f.tell()
        line = f.readline()
        if not line.startswith(b"%"):
            break
        text = line[1:].decode("latin-1").strip()
        if text == "end":
            pos = f.tell()
            break
        key, _, value = text.partition(" ")
        keys[key] = value.strip()
    f.seek(pos)
    return keys, pos


def prophesee_kind(path: str | Path) -> str | None:
    """"evt3", "evt2" or "dat" for a Prophesee file (by suffix and header), else None."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".dat":
        return "dat"
    if suffix != ".raw" or not path.is_file():
        return None
    with open(path, "rb") as f:
        keys, _ = _read_header(path, f)
    return _raw_kind(keys)


def _raw_kind(keys: dict) -> str | None:
    evt = keys.get("evt", "")
    fmt = keys.get("format", "").split(";")[0].upper()
    if evt.startswith("3") or fmt == "EVT3":
        return "evt3"
    if evt.startswith("2") or fmt == "EVT2":
        return "evt2"
    return None


def _geometry(path: Path, keys: dict) -> tuple[int | None, int | None]:
    if "Height" in keys and "Width" in keys:
        return int(keys["Height"]), int(keys["Width"])
    fields = dict(kv.split("=", 1) for kv in keys.get("format", "").split(";")[1:] if "=" in kv)
    if "height" in fields and "width" in fields:
        return int(fields["height"]), int(fields["width"])
    if "geometry" in keys:
        w, _, h = keys["geometry"].partition("x")
        return int(h), int(w)
    return None, None


def iter_prophesee_events(path: str | Path, size: int = EVENT_CHUNK) -> Iterator[np.ndarray]:
    """Stream the CD events of an EVT 3.0 / EVT 2.0 .raw or .dat file in chunks (times with the header's offset
    added back). Bad files raise DatasetFormatError naming the file."""
    path = Path(path)
    if not path.is_file():
        raise fail(path, "no such file")
    kind = prophesee_kind(path)
    if kind is None:
        raise fail(path, "not a Prophesee EVT 2.0 / EVT 3.0 .raw file (header has no 'evt' or 'format' key)")
    with open(path, "rb") as f:
        keys, _ = _read_header(path, f)
        offset = int(keys.get("evsim_t_offset_us", 0))
        if kind == "dat":
            head = f.read(2)
            if len(head) == 2 and head[1] != 8:
                raise fail(path, f".dat events of {head[1]} bytes: only 8-byte CD events are read")
            yield from _dat_chunks(path, f, offset, size)
        elif kind == "evt2":
            yield from _evt2_chunks(path, f, offset, size)
        else:
            yield from _evt3_chunks(path, f, offset, size)


def _words(path, f, dtype, count):
    raw = f.read(count * dtype.itemsize)
    if len(raw) % dtype.itemsize:
        raise fail(path, f"truncated: {len(raw) % dtype.itemsize} trailing bytes after the last whole word")
    return np.frombuffer(raw, dtype)


def _dat_chunks(path, f, offset, size):
    ovf, last = 0, 0
    while True:
        d = _words(path, f, _DAT_EVENT, size)
        if d.size == 0:
            return
        t = d["t"].astype(np.int64)
        wraps = np.concatenate([[t[0] < last], np.diff(t) < 0]).cumsum()  # 32-bit time wrap-arounds
        t += (ovf + wraps) << 32
        ovf, last = ovf + int(wraps[-1]), int(d["t"][-1])
        xyp = d["xyp"]
        yield events_from_columns(path, t + offset, xyp & 0x3FFF, (xyp >> 14) & 0x3FFF,
                                  np.where((xyp >> 28) & 1, 1, -1).astype(np.int8))


def _evt2_chunks(path, f, offset, size):
    th = 0
    while True:
        w = _words(path, f, _WORD["evt2"], size).astype(np.int64)
        if w.size == 0:
            return
        typ = w >> 28
        is_th = typ == 0x8
        last_th = np.maximum.accumulate(np.where(is_th, np.arange(w.size), -1))
        th_of = np.where(last_th >= 0, w[np.maximum(last_th, 0)] & 0x0FFF_FFFF, th)
        if is_th.any():
            th = int(w[is_th][-1] & 0x0FFF_FFFF)
        cd = typ <= 1
        wc = w[cd]
        t = (th_of[cd] << 6) | ((wc >> 22) & 63)
        yield events_from_columns(path, t + offset, (wc >> 11) & 0x7FF, wc & 0x7FF,
                                  np.where(typ[cd] == 1, 1, -1).astype(np.int8))


def _evt3_chunks(path, f, offset, size):
    state = np.zeros(6, np.int64)
    per_read = max(1, size // 2)
    while True:
        w = _words(path, f, _WORD["evt3"], per_read)
        if w.size == 0:
            return
        typ = w >> 12
        n_max = int(np.count_nonzero(typ == 0x2) + _POPCOUNT[w[typ == 0x4] & 0xFFF].sum() +
                    _POPCOUNT[w[typ == 0x5] & 0xFF].sum())
        t, x, y, p = np.empty(n_max, np.int64), np.empty(n_max, np.uint16), np.empty(n_max, np.uint16), \
            np.empty(n_max, np.int8)
        n = decode_evt3(w, state, t, x, y, p)
        yield events_from_columns(path, t[:n] + offset, x[:n], y[:n], p[:n])


def read_prophesee(path: str | Path) -> Recording:
    """Read an EVT 3.0 / EVT 2.0 .raw or .dat file into a Recording (events and sensor size). Without a size
    in the header, the sensor is max(x) + 1 by max(y) + 1."""
    path = Path(path)
    chunks = list(iter_prophesee_events(path))
    events = np.concatenate(chunks) if chunks else events_from_columns(path, [], [], [], [])
    if events.size > 1 and np.any(np.diff(events["t"]) < 0):
        raise fail(path, "event times decrease across chunks (corrupt file?)")
    with open(path, "rb") as f:
        keys, _ = _read_header(path, f)
    h, w = _geometry(path, keys)
    if h is None:
        if not events.size:
            raise fail(path, "sensor size unknown: no geometry in the header and no events")
        h, w = int(events["y"].max()) + 1, int(events["x"].max()) + 1
    if events.size and (events["x"].max() >= w or events["y"].max() >= h):
        raise fail(path, f"event coordinates exceed the header's sensor size {w}x{h}")
    rec = Recording(events=events, height=h, width=w,
                    metadata={"source": {"format": prophesee_kind(path), "path": str(path),
                                         "header": keys}})
    return rec  # load() validates it
