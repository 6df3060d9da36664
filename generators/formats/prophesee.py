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
          every wrap visible, so streams of any length are exact. Words of the undefined types (0x1, 0x9, 0xB..0xD)
          are refused.
    EVT 2.0: 32-bit words, type in bits 31..28: 0x0 CD_OFF / 0x1 CD_ON with bits 27..22 time bits 5..0,
          21..11 x, 10..0 y; 0x8 TIME_HIGH with bits 27..0 = time bits 33..6 (2**34 us, about 4.8 h, per file).
          Types 0xA (trigger), 0xE and 0xF are skipped; the undefined types (0x2..0x7, 0x9, 0xB..0xD) are refused.
    .dat: as Prophesee's DAT spec (docs.prophesee.ai, "DAT File Format"): "% " header lines "% Data file
          containing CD events", Date, Version 2, Width, Height (then evsim's keys), then two bytes, event type 0x0C
          (EventCD) and size 8, then 8-byte events: uint32 t, uint32 x (bits 13..0) | y (27..14) | p (31..28: 0 or 1,
          anything else refused).
          32-bit times (2**32 us, about 71 min, per file). The Date is fixed (1970-01-01 00:00:00), so one recording
          always gives the same bytes. The reader also takes event type 0 (Event2d: the same 8-byte layout) and
          any first header line.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from sim import EvsimInputError

from .common import EVENT_CHUNK, ReaderNoteWarning, events_from_columns, fail, polarity_pm1
from .event_file_writer import EventFileWriter
from .native import recording_event_chunks
from .recording import MAX_TIME_US, Recording, validate_recording
from .time_wrap import WRAP_WINDOW, time_step_ok

PROPHESEE_FORMATS = ("evt3", "evt2", "dat")
SUFFIX = {"evt3": ".raw", "evt2": ".raw", "dat": ".dat"}
_TIME_LIMIT = {"evt3": 1 << 24, "evt2": 1 << 34, "dat": 1 << 32}  # stored times must start (evt3) or stay below
_MAX_COORD = {"evt3": 2048, "evt2": 2048, "dat": 1 << 14}
_WORD = {"evt3": np.dtype("<u2"), "evt2": np.dtype("<u4")}
_DAT_EVENT = np.dtype([("t", "<u4"), ("xyp", "<u4")])
_EVT2_TH_STEP = (1 << 28) // WRAP_WINDOW  # the longest TIME_HIGH step the EVT 2.0 writer makes (67 s)
_DAT_MAX_STEP = (1 << 32) - (1 << 32) // WRAP_WINDOW  # .dat: no step between two events this long (71.3 min)
_DAT_CD = 0x0C  # the .dat event type byte evsim writes: EventCD
_DAT_CD_TYPES = (0, _DAT_CD)  # read: 0 Event2d, 12 EventCD (same 8-byte layout); 14 (triggers) is refused
LAYOUT_VERSION = 1
_DAT_DATE = "1970-01-01 00:00:00"
_POPCOUNT = np.array([bin(i).count("1") for i in range(4096)], np.int64)  # set bits of 12-bit vector masks


class PropheseeWriter(EventFileWriter):
    """Stream events into an EVT 3.0 / EVT 2.0 .raw or a .dat file, atomically (`with` block or close()).

    The time offset is fixed by the first event (see the module docstring); later chunks must stay in the
    format's time range (EvsimInputError otherwise, naming the limit). A .dat file cannot hold a silence of 71.3
    min or more between two events (readers take it for time going back: time_wrap.time_step_ok); EVT 2.0
    and EVT 3.0 files hold silences of any length (TIME_HIGH words every few steps)."""

    def __init__(self, path: str | Path, fmt: str, height: int, width: int):
        if fmt not in PROPHESEE_FORMATS:
            raise EvsimInputError(f"unknown Prophesee format {fmt!r}; one of {', '.join(PROPHESEE_FORMATS)}")
        if not (0 < height <= _MAX_COORD[fmt] and 0 < width <= _MAX_COORD[fmt]):
            raise EvsimInputError(f"{fmt} holds sensors up to {_MAX_COORD[fmt]} pixels a side, got {width}x{height}")
        self.fmt = fmt
        super().__init__(path, height, width)
        self._state = np.array([0, -1, -1], np.int64)  # evt3 encoder: time_high 0 written first
        self._dat_last = None  # dat: the last relative time written

    def _start(self, t_offset: int) -> None:
        self._offset = t_offset
        self._f.write(self._header().encode("ascii"))
        if self.fmt == "evt3":
            self._f.write(np.array([0x8000], "<u2").tobytes())
        elif self.fmt == "evt2":
            self._f.write(np.array([0x8000_0000], "<u4").tobytes())
            self._th2 = 0
        else:
            self._f.write(bytes([_DAT_CD, 8]))  # event type EventCD, 8 bytes per event

    def _header(self) -> str:
        h, w = self.height, self.width
        evsim = [f"% evsim_layout_version {LAYOUT_VERSION}", f"% evsim_t_offset_us {self._offset}",
                 *(f"% {k} {v}" for k, v in EVSIM_KEYS.items()),
                 "% evsim_holds events, sensor size (no frames, reference, labels, thresholds, CRF, metadata)"]
        if self.fmt == "dat":
            # a fixed Date (not the time of writing): the same file for the same recording, checkable by SHA-256
            return "\n".join(["% Data file containing CD events", f"% Date {_DAT_DATE}", "% Version 2",
                              f"% Width {w}", f"% Height {h}", *evsim]) + "\n"
        version = "3.0" if self.fmt == "evt3" else "2.0"
        fmt = "EVT3" if self.fmt == "evt3" else "EVT2"
        return "\n".join([f"% evt {version}", f"% format {fmt};height={h};width={w}", f"% geometry {w}x{h}",
                          "% integrator_name evsim", *evsim, "% end"]) + "\n"

    def add_events(self, events: np.ndarray) -> None:
        """Append a time-sorted chunk of sim.EVENT_DTYPE events, later than every earlier chunk."""
        t = self._checked_times(events)
        if t is None:
            return
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
        from .prophesee_kernels import TIME_HIGH_MAX_STEP, encode_evt3  # (numba: on first use)

        gap = int(t[-1] >> 12) - int(self._state[0])
        out = np.empty(4 * t.size + gap // TIME_HIGH_MAX_STEP + 1, np.uint16)
        n = encode_evt3(t, ev["x"], ev["y"], ev["p"], self._state, out)
        self._f.write(out[:n].tobytes())

    def _write_evt2(self, t, ev) -> None:
        # a TIME_HIGH word at least every _EVT2_TH_STEP (67 s) of silence, as readers refuse a longer step that
        # could be a step back (time_wrap.time_step_ok)
        th = t >> 6
        prev = np.concatenate([[self._th2], th[:-1]])
        cuts = np.flatnonzero(th - prev > _EVT2_TH_STEP).tolist()
        for a, b in zip([0, *cuts], [*cuts, t.size]):
            if a == b:
                continue
            while int(th[a]) - self._th2 > _EVT2_TH_STEP:
                self._th2 += _EVT2_TH_STEP
                self._f.write(np.array([(0x8 << 28) | self._th2], "<u4").tobytes())
            self._write_evt2_run(t[a:b], ev[a:b])

    def _write_evt2_run(self, t, ev) -> None:
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
        steps = np.diff(t, prepend=t[0] if self._dat_last is None else self._dat_last)
        if steps.max() >= _DAT_MAX_STEP:
            raise EvsimInputError(f"dat cannot hold a silence of {_DAT_MAX_STEP} us ({_DAT_MAX_STEP / 6e7:.1f} min) "
                                  "or more between two events: readers take so long a step of the 32-bit time for "
                                  "time going back")
        self._dat_last = int(t[-1])
        out = np.empty(t.size, _DAT_EVENT)
        out["t"] = t
        out["xyp"] = ev["x"].astype(np.uint32) | (ev["y"].astype(np.uint32) << 14) | \
            ((ev["p"] > 0).astype(np.uint32) << 28)
        self._f.write(out.tobytes())

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


#: the header keys evsim writes whose value it reads back as written (checked by the readers)
EVSIM_KEYS = {"evsim_time_base": "us", "evsim_polarity": "1=ON 0=OFF"}


def _header_int(path: Path, keys: dict, key: str, lo: int, hi: int, value: str | None = None) -> int:
    """The integer header value of `key` (or `value`, taken from it), checked to be in lo..hi."""
    text = keys[key] if value is None else value
    try:
        v = int(text)
    except ValueError:
        raise fail(path, f"header key {key!r}: expected an integer, got {text!r}") from None
    if not lo <= v <= hi:
        raise fail(path, f"header key {key!r}: {v} outside {lo}..{hi}")
    return v


def _geometry(path: Path, keys: dict) -> tuple[int | None, int | None]:
    """(height, width) from the header ("Height"/"Width" of .dat, "format ...;height=H;width=W" or "geometry WxH"
    of .raw), each checked to be 1..the format's largest coordinate + 1; (None, None) when the header has none."""
    most = _MAX_COORD["dat"] if path.suffix.lower() == ".dat" else _MAX_COORD["evt3"]
    if "Height" in keys and "Width" in keys:
        return _header_int(path, keys, "Height", 1, most), _header_int(path, keys, "Width", 1, most)
    fields = dict(kv.split("=", 1) for kv in keys.get("format", "").split(";")[1:] if "=" in kv)
    if "height" in fields and "width" in fields:
        return (_header_int(path, keys, "format", 1, most, fields["height"]),
                _header_int(path, keys, "format", 1, most, fields["width"]))
    if "geometry" in keys:
        w, _, h = keys["geometry"].partition("x")
        return _header_int(path, keys, "geometry", 1, most, h), _header_int(path, keys, "geometry", 1, most, w)
    return None, None


def _header_offset(path: Path, keys: dict) -> int:
    """The evsim header keys the readers rely on: the time offset (0 when absent), a known layout version and the
    EVSIM_KEYS as evsim writes them."""
    if "evsim_layout_version" in keys:
        _header_int(path, keys, "evsim_layout_version", 1, LAYOUT_VERSION)
    for key, value in EVSIM_KEYS.items():  # what evsim writes is read back: another unit or encoding is refused
        if keys.get(key, value) != value:
            raise fail(path, f"header key {key}: {keys[key]!r}, where evsim writes and reads only {value!r}")
    if "evsim_t_offset_us" not in keys:
        return 0
    return _header_int(path, keys, "evsim_t_offset_us", -MAX_TIME_US, MAX_TIME_US)


def iter_prophesee_events(path: str | Path, size: int = EVENT_CHUNK) -> Iterator[np.ndarray]:
    """Stream the CD events of an EVT 3.0 / EVT 2.0 .raw or .dat file in chunks (times with the header's offset
    added back). Bad files raise DatasetFormatError naming the file: among them a time that goes back (naming its
    byte position) other than a wrap of the format's counter from the top of its range to its bottom
    (time_wrap.time_step_ok)."""
    path = Path(path)
    if not path.is_file():
        raise fail(path, "no such file")
    kind = prophesee_kind(path)
    if kind is None:
        raise fail(path, "not a Prophesee EVT 2.0 / EVT 3.0 .raw file (header has no 'evt' or 'format' key)")
    with open(path, "rb") as f:
        keys, _ = _read_header(path, f)
        offset = _header_offset(path, keys)
        _geometry(path, keys)
        if kind == "dat":
            head = f.read(2)
            if len(head) < 2:
                raise fail(path, "truncated: no event type and size bytes after the header")
            if head[0] not in _DAT_CD_TYPES:
                raise fail(path, f".dat event type {head[0]}: only CD events are read (type 12 EventCD, or 0 "
                                 "Event2d); 14 is external triggers")
            if head[1] != 8:
                raise fail(path, f".dat events of {head[1]} bytes: only 8-byte CD events are read")
            yield from _dat_chunks(path, f, offset, size)
        else:
            yield from _noting_silence(path, (_evt2_chunks if kind == "evt2" else _evt3_chunks)(path, f, offset, size))


#: a silence between two events longer than this (us) in an EVT 2.0 / 3.0 stream is read with a note
SILENCE_NOTE_US = 10_000_000


def _noting_silence(path: Path, chunks: Iterator[np.ndarray]) -> Iterator[np.ndarray]:
    """The chunks, with a ReaderNoteWarning (once per file) at the first silence between two events longer than
    SILENCE_NOTE_US: in EVT 2.0 / 3.0 one TIME_HIGH word sets the time of every later event, so a corrupt one
    moves the rest of the stream ahead, exactly as a real pause in the recording would; the file is read as it
    says, and the user told where to look."""
    last = None
    for chunk in chunks:
        t = chunk["t"] if last is None else np.concatenate(([last], chunk["t"]))
        if t.size >= 2:
            gaps = np.diff(t)
            i = int(np.argmax(gaps))
            if gaps[i] > SILENCE_NOTE_US:
                warnings.warn(f"{path}: no events for {gaps[i] / 1e6:.4g} s before the one at {int(t[i + 1])} us: "
                              "read as a pause in the recording (a corrupt TIME_HIGH word would give the same; "
                              "`evsim info` shows the span)", ReaderNoteWarning, stacklevel=2)
                yield chunk
                yield from chunks
                return
        last = int(t[-1]) if t.size else last
        yield chunk


def _words(path, f, dtype, count):
    raw = f.read(count * dtype.itemsize)
    if len(raw) % dtype.itemsize:
        raise fail(path, f"truncated: {len(raw) % dtype.itemsize} trailing bytes after the last whole word")
    return np.frombuffer(raw, dtype)


def _byte(pos: int, stride: int, word_index, i: int) -> int:
    """The file position of item i of a chunk read at `pos`: word word_index[i] (or i) of `stride` bytes."""
    return pos + stride * int(i if word_index is None else word_index[i])


def _unwrap(path, values, prev, period, what, pos, stride, word_index=None) -> tuple[np.ndarray, int]:
    """Wrap counts of a chunk of counter values (int64) whose predecessor is `prev` (None before the first):
    returns (for each value the number of wraps since prev, that number after the last value). Every step must
    pass time_step_ok, else DatasetFormatError naming the byte position of the value (see _byte)."""
    before = np.empty_like(values)
    before[1:] = values[:-1]
    before[0] = values[0] if prev is None else prev
    ok = time_step_ok(before, values, period)
    if not ok.all():
        i = int(np.argmin(ok))
        new, old = int(values[i]), int(before[i])
        how = "goes back" if new < old else "jumps from the bottom of the range to its top (back across zero)"
        raise fail(path, f"time goes back at byte {_byte(pos, stride, word_index, i)}: {what} {new} after {old} "
                         f"{how}; a wrap of the {period.bit_length() - 1}-bit range goes from its top 1/{WRAP_WINDOW} "
                         f"to its bottom 1/{WRAP_WINDOW}: a corrupt file")
    wraps = np.cumsum(values < before)
    return wraps, int(wraps[-1])


def _time_order(path, t, last, pos, stride, word_index) -> None:
    """DatasetFormatError at the first event earlier than its predecessor (last: the previous chunk's last time)."""
    if t.size == 0:
        return
    prev = np.empty_like(t)
    prev[1:] = t[:-1]
    prev[0] = t[0] if last is None else last
    back = np.flatnonzero(t < prev)
    if back.size:
        i = int(back[0])
        raise fail(path, f"time goes back at byte {_byte(pos, stride, word_index, i)}: an event at {int(t[i])} us "
                         f"after one at {int(prev[i])} us: a corrupt file")


def _dat_chunks(path, f, offset, size):
    ovf, prev = 0, None
    while True:
        pos = f.tell()
        d = _words(path, f, _DAT_EVENT, size)
        if d.size == 0:
            return
        t = d["t"].astype(np.int64)
        wraps, n_wraps = _unwrap(path, t, prev, 1 << 32, ".dat event time", pos, _DAT_EVENT.itemsize)
        prev = int(t[-1])
        t += (ovf + wraps) << 32
        ovf += n_wraps
        xyp = d["xyp"]
        yield events_from_columns(path, t + offset, xyp & 0x3FFF, (xyp >> 14) & 0x3FFF, polarity_pm1(path, xyp >> 28))


#: the EVT 2.0 word types: CD_OFF, CD_ON, TIME_HIGH, EXT_TRIGGER, OTHERS, CONTINUED (any other is a corrupt word)
_EVT2_TYPES = np.array([0x0, 0x1, 0x8, 0xA, 0xE, 0xF])


def _evt2_chunks(path, f, offset, size):
    th, ovf, prev, last = 0, 0, None, None  # time high (unwrapped), its wraps, its last raw value, last event time
    while True:
        pos = f.tell()
        w = _words(path, f, _WORD["evt2"], size).astype(np.int64)
        if w.size == 0:
            return
        typ = w >> 28
        odd = np.flatnonzero(~np.isin(typ, _EVT2_TYPES))
        if odd.size:
            i = int(odd[0])
            raise fail(path, f"EVT 2.0 word of undefined type {int(typ[i]):#x} at byte {pos + 4 * i} (CD events are "
                             "type 0 OFF or 1 ON): a corrupt file")
        is_th = typ == 0x8
        th_at = np.flatnonzero(is_th)
        th_full = np.zeros(w.size, np.int64)
        if th_at.size:
            raw = w[is_th] & 0x0FFF_FFFF
            wraps, n_wraps = _unwrap(path, raw, prev, 1 << 28, "EVT 2.0 TIME_HIGH", pos, 4, th_at)
            th_full[is_th] = raw + ((ovf + wraps) << 28)
            prev, ovf = int(raw[-1]), ovf + n_wraps
        last_th = np.maximum.accumulate(np.where(is_th, np.arange(w.size), -1))
        th_of = np.where(last_th >= 0, th_full[np.maximum(last_th, 0)], th)
        if th_at.size:
            th = int(th_full[th_at[-1]])
        cd = typ <= 1
        wc = w[cd]
        t = (th_of[cd] << 6) | ((wc >> 22) & 63)
        _time_order(path, t, last, pos, 4, np.flatnonzero(cd))
        last = int(t[-1]) if t.size else last
        yield events_from_columns(path, t + offset, (wc >> 11) & 0x7FF, wc & 0x7FF,
                                  np.where(typ[cd] == 1, 1, -1).astype(np.int8))


#: the EVT 3.0 word types (prophesee_kernels): ADDR_Y, ADDR_X, VECT_BASE_X, VECT_12, VECT_8, TIME_LOW, CONTINUED_4,
#: TIME_HIGH, EXT_TRIGGER, OTHERS, CONTINUED_12 (0x1, 0x9, 0xB..0xD are undefined: a corrupt word)
_EVT3_TYPES = np.array([0x0, 0x2, 0x3, 0x4, 0x5, 0x6, 0x7, 0x8, 0xA, 0xE, 0xF])


def _evt3_chunks(path, f, offset, size):
    from .prophesee_kernels import STATE_SIZE, decode_evt3  # (numba: on first use)

    state = np.zeros(STATE_SIZE, np.int64)
    state[6] = -1  # no event yet
    per_read = max(1, size // 2)
    while True:
        pos = f.tell()
        w = _words(path, f, _WORD["evt3"], per_read)
        if w.size == 0:
            return
        typ = w >> 12
        odd = np.flatnonzero(~np.isin(typ, _EVT3_TYPES))
        if odd.size:
            i = int(odd[0])
            raise fail(path, f"EVT 3.0 word of undefined type {int(typ[i]):#x} at byte {pos + 2 * i}: a corrupt file")
        n_max = int(np.count_nonzero(typ == 0x2) + _POPCOUNT[w[typ == 0x4] & 0xFFF].sum() +
                    _POPCOUNT[w[typ == 0x5] & 0xFF].sum())
        t, x, y, p = np.empty(n_max, np.int64), np.empty(n_max, np.uint16), np.empty(n_max, np.uint16), \
            np.empty(n_max, np.int8)
        n = decode_evt3(w, state, t, x, y, p)
        if n < 0:
            i = -1 - n
            if w[i] >> 12 == 0x8:
                new, old = int(w[i]) & 0xFFF, int(state[0]) & 0xFFF
                how = "goes back" if new < old else "jumps from the bottom of the range to its top (back across zero)"
                raise fail(path, f"time goes back at byte {pos + 2 * i}: EVT 3.0 TIME_HIGH {new} after {old} {how}; "
                                 f"a wrap of the 12-bit range goes from its top 1/{WRAP_WINDOW} to its bottom "
                                 f"1/{WRAP_WINDOW}: a corrupt file")
            raise fail(path, f"time goes back at byte {pos + 2 * i}: an event at "
                             f"{(int(state[0]) << 12) | int(state[1])} us after one at {int(state[6])} us: a corrupt "
                             "file")
        yield events_from_columns(path, t[:n] + offset, x[:n], y[:n], p[:n])


def read_prophesee(path: str | Path) -> Recording:
    """Read an EVT 3.0 / EVT 2.0 .raw or .dat file into a Recording (events and sensor size). Without a size
    in the header, the sensor is max(x) + 1 by max(y) + 1."""
    path = Path(path)
    chunks = list(iter_prophesee_events(path))
    events = np.concatenate(chunks) if chunks else events_from_columns(path, [], [], [], [])  # in time order
    with open(path, "rb") as f:
        keys, _ = _read_header(path, f)
    h, w = _geometry(path, keys)
    if h is None:
        if not events.size:
            raise fail(path, "sensor size unknown: no geometry in the header and no events")
        h, w = int(events["y"].max()) + 1, int(events["x"].max()) + 1
    rec = Recording(events=events, height=h, width=w,
                    metadata={"source": {"format": prophesee_kind(path), "path": str(path),
                                         "header": keys}})
    return rec  # load() validates it
