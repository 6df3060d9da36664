"""AEDAT 2.0 (jAER) event files, DAVIS address layout: a streamed writer and a strict reader.

What they hold: DVS events (t, x, y, polarity) and the sensor size; no APS frames, reference, labels, thresholds,
CRF or metadata. Sources: jAER (github.com/SensorsINI/jaer), net.sf.jaer.eventio.AEFileOutputStream (header,
first-event rule), AEFileInputStream (int32 time wraps) and eu.seebetter.ini.chips.DavisChip / davis.DavisBaseCamera
(address fields, the DavisEventExtractor); iniVation's "AEDAT 2.0" file-format page.

Layout:
    header  ASCII lines "#...\\r\\n": the first "#!AER-DAT2.0", the last "# End Of ASCII Header"; in between
            jAER's lines, "# AEChip: <jAER chip class>" when the sensor size is a DAVIS chip's (346x260
            eu.seebetter.ini.chips.davis.Davis346B, 240x180 DAVIS240C, 640x480 Davis640) and evsim's keys
            ("# evsim_geometry WxH", "# evsim_t_offset_us N", ...).
    events  8 bytes each, big-endian: int32 address, int32 timestamp (1 us ticks).
    address (DavisChip, DVS event): bit 31 = 0 (1: APS sample or IMU word), bits 30..22 y field, bits 21..12 x
            field, bit 11 polarity (1 = ON), bit 10 external-input (special) event. jAER's DavisEventExtractor
            reads x = width - 1 - x field and y = y field with y pointing up; evsim's rows point down, so
            x field = width - 1 - x and y field = height - 1 - y (as tonic.io.read_davis_346 and v2e's AEDat2Output
            read and write DAVIS346 files). Sensors up to 1024 x 512 pixels fit the fields.
Time: stored relative to an offset, "# evsim_t_offset_us N": 0 when the first event time is in 0..2**31 - 1 us,
    else the first event time floored to a millisecond. The int32 timestamp wraps every 2**32 us (71.6 min), as a
    DAVIS camera's and jAER's do (jAER follows the wraps); the reader counts a wrap at each drop of the unsigned
    32-bit value (time_wrap.time_step_ok: a wrap moves time forward by at most 16.8 s), so the writer
    refuses a silence of 71.3 min or more between two events.
First data byte: readers take a first byte '#' (0x23) for one more header line; jAER's writer drops such first
    events. evsim's writer puts first an event of the first timestamp whose address does not start with 0x23;
    when every event of that timestamp does (y field 140..143), it writes an external-input (special) event at
    that time first, which jAER and evsim's reader skip.
Reading: special events, APS samples and IMU words are skipped (their count is in the Recording's metadata; the
    time order is checked on the DVS events alone, the words that are read); a
    header without "#!AER-DAT2.0", a chip other than a DAVIS, an unknown sensor size, a truncated event, a time
    that goes back or a coordinate outside the sensor are DatasetFormatError naming the file.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from sim import EvsimInputError

from .common import EVENT_CHUNK, events_from_columns, fail
from .event_file_writer import EventFileWriter
from .native import recording_event_chunks
from .recording import MAX_TIME_US, Recording, validate_recording
from .time_wrap import WRAP_WINDOW, time_step_ok

MAGIC = b"#!AER-DAT2.0"
END_OF_HEADER = "End Of ASCII Header"
LAYOUT_VERSION = 1
MAX_WIDTH, MAX_HEIGHT = 1024, 512  # the 10-bit x and 9-bit y fields
#: jAER chip classes by sensor size (width, height), written as "# AEChip:"; a chip name gives the size of a file
#: without evsim's geometry key (_CHIP_SIZES)
_JAER_DAVIS = "eu.seebetter.ini.chips.davis."
DAVIS_CHIPS = {(346, 260): _JAER_DAVIS + "Davis346B", (240, 180): _JAER_DAVIS + "DAVIS240C",
               (640, 480): _JAER_DAVIS + "Davis640"}
_CHIP_SIZES = (("Davis346", (346, 260)), ("DAVIS240", (240, 180)), ("Davis640", (640, 480)), ("Davis128", (128, 128)))
_EVENT = np.dtype([("a", ">u4"), ("t", ">u4")])
X_SHIFT, Y_SHIFT, POL_BIT, SPECIAL_BIT, APS_BIT = 12, 22, 11, 10, 31
_PERIOD = 1 << 32
_MAX_STEP = _PERIOD - _PERIOD // WRAP_WINDOW  # the longest step between two events (71.3 min): see the docstring
_COMMENT = 0x23  # '#'


def davis_addresses(x: np.ndarray, y: np.ndarray, p: np.ndarray, height: int, width: int) -> np.ndarray:
    """jAER DAVIS addresses (uint32) of DVS events at image column x, row y (row 0 at the top), polarity p."""
    return (((width - 1 - x.astype(np.uint32)) << X_SHIFT) | ((height - 1 - y.astype(np.uint32)) << Y_SHIFT) |
            ((p > 0).astype(np.uint32) << POL_BIT)).astype(np.uint32)


class Aedat2Writer(EventFileWriter):
    """Stream events into an AEDAT 2.0 file, atomically (`with` block or close()); see the module docstring.

    The time offset is fixed by the first event; a silence of 71.3 min or more between two events is an
    EvsimInputError (the int32 time could not say how many times it wrapped)."""

    def __init__(self, path: str | Path, height: int, width: int):
        if not (0 < width <= MAX_WIDTH and 0 < height <= MAX_HEIGHT):
            raise EvsimInputError(f"aedat2 (jAER DAVIS layout) holds sensors up to {MAX_WIDTH}x{MAX_HEIGHT} pixels, "
                                  f"got {width}x{height}")
        super().__init__(path, height, width)

    def _start(self, offset: int) -> None:
        self._offset = offset
        chip = DAVIS_CHIPS.get((self.width, self.height))
        lines = ["!AER-DAT2.0", " This is a raw AE data file - do not edit",
                 " Data format is int32 address, int32 timestamp (8 bytes total), repeated for each event",
                 " Timestamps tick is 1 us",
                 " Creation date: 1970-01-01 (fixed: the same recording gives the same file)",
                 *([f" AEChip: {chip}"] if chip else []),
                 " Address layout: jAER DavisChip (bit 31 0 = DVS, y field bits 30..22, x field bits 21..12, "
                 "polarity bit 11, 1 = ON); x field = width-1-column, y field = height-1-row",
                 f" evsim_layout_version {LAYOUT_VERSION}", f" evsim_geometry {self.width}x{self.height}",
                 f" evsim_t_offset_us {offset}", " evsim_time_base us",
                 " evsim_holds events, sensor size (no frames, reference, labels, thresholds, CRF, metadata)",
                 f" {END_OF_HEADER}"]
        self._f.write("".join(f"#{line}\r\n" for line in lines).encode("ascii"))

    def add_events(self, events: np.ndarray) -> None:
        """Append a time-sorted chunk of sim.EVENT_DTYPE events, later than every earlier chunk."""
        t = self._checked_times(events)
        if t is None:
            return
        steps = np.diff(t, prepend=t[0] if self._t_last is None else self._t_last)
        if steps.max() >= _MAX_STEP:
            raise EvsimInputError(f"aedat2 cannot hold a silence of {_MAX_STEP} us ({_MAX_STEP / 6e7:.1f} min) or "
                                  "more between two events: its int32 time wraps every 2**32 us")
        out = np.empty(t.size, _EVENT)
        out["a"] = davis_addresses(events["x"], events["y"], events["p"], self.height, self.width)
        first = self._offset is None
        if first:
            self._start(0 if 0 <= t[0] < 1 << 31 else int(t[0]) // 1000 * 1000)
        out["t"] = ((t - self._offset) & (_PERIOD - 1)).astype(np.uint32)
        if first:
            out = _first_not_comment(out)
        self._t_last = int(t[-1])
        self._f.write(out.tobytes())

def _first_not_comment(out: np.ndarray) -> np.ndarray:
    """The first chunk with a first address whose top byte is not '#' (see the module docstring)."""
    if out["a"][0] >> 24 != _COMMENT:
        return out
    tied = int(np.argmax(out["t"] != out["t"][0])) or out.size
    ok = np.flatnonzero(out["a"][:tied] >> 24 != _COMMENT)
    if ok.size:  # events of one timestamp have no order: swap one that does not start with '#' to the front
        i = int(ok[0])
        out[[0, i]] = out[[i, 0]]
        return out
    with_special = np.empty(out.size + 1, _EVENT)  # (np.concatenate would turn the fields native-endian)
    with_special[1:] = out
    with_special[0] = (1 << SPECIAL_BIT, out["t"][0])
    return with_special


def write_aedat2(rec: Recording, path: str | Path, *, event_source: Iterator | None = None) -> None:
    """Write a Recording's events as AEDAT 2.0 (jAER, DAVIS layout), streamed chunk by chunk and atomically."""
    validate_recording(rec)
    with Aedat2Writer(path, rec.height, rec.width) as w:
        for chunk, _ in event_source if event_source is not None else recording_event_chunks(rec):
            w.add_events(chunk)


# -- reading ----------------------------------------------------------------------------------------------------
def is_aedat2(path: str | Path) -> bool:
    """Whether the file starts with AEDAT 2.0's first header line."""
    with open(path, "rb") as f:
        return f.read(len(MAGIC)) == MAGIC


def read_header(path: str | Path) -> tuple[list[str], int]:
    """The header lines (without '#' and line ends) and the byte offset of the first event. The header ends at
    the line "# End Of ASCII Header" or before the first byte that is not '#'."""
    path = Path(path)
    lines, pos = [], 0
    with open(path, "rb") as f:
        if f.read(len(MAGIC)) != MAGIC:
            raise fail(path, "not an AEDAT 2.0 file: the first line is not '#!AER-DAT2.0'")
        f.seek(0)
        while True:
            pos = f.tell()
            if f.read(1) != b"#":
                break
            line = f.readline(4096)
            if not line.endswith(b"\n"):
                raise fail(path, "truncated or malformed header: a '#' line without an end")
            text = line.rstrip(b"\r\n").decode("latin-1")
            lines.append(text)
            if text.strip() == END_OF_HEADER:
                pos = f.tell()
                break
    return lines, pos


def sensor_size(path: str | Path) -> tuple[int, int]:
    """(height, width) of an AEDAT 2.0 file, from its header (see _geometry)."""
    lines, _ = read_header(path)
    return _geometry(Path(path), _keys(lines))


def _keys(lines: list[str]) -> dict[str, str]:
    keys = {}
    for line in lines:
        m = re.match(r"\s*(evsim_\w+)\s+(.*)$", line) or re.match(r"\s*(AEChip)\s*:\s*(\S+)", line)
        if m:
            keys[m.group(1)] = m.group(2).strip()
    return keys


def _geometry(path: Path, keys: dict) -> tuple[int, int]:
    """(height, width): evsim's "evsim_geometry WxH", else the size of the DAVIS chip named by "AEChip". A chip
    named beside the geometry key must be a DAVIS of that size (evsim writes it only then): another chip's
    addresses (a DVS128's) would be read in the wrong layout."""
    chip = keys.get("AEChip")
    chip_size = None
    if chip is not None:
        chip_size = next(((h, w) for name, (w, h) in _CHIP_SIZES if name.lower() in chip.lower()), None)
        if chip_size is None:
            raise fail(path, f"AEChip {chip}: only the DAVIS address layout (Davis346, DAVIS240, Davis640, Davis128) "
                             "is read")
    if "evsim_geometry" in keys:
        m = re.fullmatch(r"(\d+)x(\d+)", keys["evsim_geometry"])
        if not m or not (0 < int(m.group(1)) <= MAX_WIDTH and 0 < int(m.group(2)) <= MAX_HEIGHT):
            raise fail(path, f"header key evsim_geometry: expected WxH up to {MAX_WIDTH}x{MAX_HEIGHT}, got "
                             f"{keys['evsim_geometry']!r}")
        size = int(m.group(2)), int(m.group(1))
        if chip_size is not None and chip_size != size:
            raise fail(path, f"header keys disagree: AEChip {chip} is {chip_size[1]}x{chip_size[0]}, evsim_geometry "
                             f"says {keys['evsim_geometry']}")
        return size
    if chip_size is None:
        raise fail(path, "sensor size unknown: the header names no AEChip (and no evsim_geometry); the DAVIS x field "
                         "is read from the sensor's right edge, so the size is needed")
    return chip_size


def _offset(path: Path, keys: dict) -> int:
    if "evsim_layout_version" in keys and keys["evsim_layout_version"] not in {str(v) for v in
                                                                                range(1, LAYOUT_VERSION + 1)}:
        raise fail(path, f"header key evsim_layout_version: unknown version {keys['evsim_layout_version']!r}")
    if keys.get("evsim_time_base", "us") != "us":
        raise fail(path, f"header key evsim_time_base: {keys['evsim_time_base']!r}, where evsim writes and reads only "
                         "'us' (1 us ticks)")
    text = keys.get("evsim_t_offset_us", "0")
    try:
        offset = int(text)
    except ValueError:
        raise fail(path, f"header key evsim_t_offset_us: expected an integer, got {text!r}") from None
    if abs(offset) > MAX_TIME_US:
        raise fail(path, f"header key evsim_t_offset_us: {offset} outside +-2**62")
    return offset


def iter_aedat2_events(path: str | Path, size: int = EVENT_CHUNK, counts: dict | None = None) -> Iterator[np.ndarray]:
    """Stream the DVS events of an AEDAT 2.0 file in chunks (times unwrapped, the header's offset added back).
    counts, when given, receives the number of skipped words: "special", "aps_imu"."""
    path = Path(path)
    if not path.is_file():
        raise fail(path, "no such file")
    lines, start = read_header(path)
    keys = _keys(lines)
    h, w = _geometry(path, keys)
    offset = _offset(path, keys)
    counts = {} if counts is None else counts
    counts.update(special=0, aps_imu=0)
    wraps, prev = 0, None
    with open(path, "rb") as f:
        f.seek(start)
        while True:
            pos = f.tell()
            raw = f.read(size * _EVENT.itemsize)
            if not raw:
                return
            if len(raw) % _EVENT.itemsize:
                raise fail(path, f"truncated: {len(raw) % _EVENT.itemsize} trailing bytes after the last whole event")
            d = np.frombuffer(raw, _EVENT)
            a = d["a"].astype(np.int64)
            aps = (a >> APS_BIT) & 1 == 1
            special = ~aps & ((a >> SPECIAL_BIT) & 1 == 1)
            counts["aps_imu"] += int(aps.sum())
            counts["special"] += int(special.sum())
            at = np.flatnonzero(~aps & ~special)  # DVS events; their times alone are checked and unwrapped
            if at.size == 0:
                continue
            a, t = a[at], d["t"][at].astype(np.int64)
            before = np.empty_like(t)
            before[1:] = t[:-1]
            before[0] = t[0] if prev is None else prev
            ok = time_step_ok(before, t, _PERIOD)
            if not ok.all():
                i = int(np.argmin(ok))
                raise fail(path, f"time goes back at byte {pos + 8 * int(at[i])}: timestamp {int(t[i])} after "
                                 f"{int(before[i])} (unsigned 32-bit) is neither a step forward nor a wrap of the "
                                 "32-bit time: a corrupt file")
            k = np.cumsum(t < before)
            prev, t = int(t[-1]), t + ((wraps + k) << 32) + offset
            wraps += int(k[-1])
            xf, yf = (a >> X_SHIFT) & 0x3FF, (a >> Y_SHIFT) & 0x1FF
            bad = np.flatnonzero((xf >= w) | (yf >= h))
            if bad.size:
                raise fail(path, f"event at byte {pos + 8 * int(at[bad[0]])}: x field {int(xf[bad[0]])}, y field "
                                 f"{int(yf[bad[0]])} outside the {w}x{h} sensor")
            yield events_from_columns(path, t, w - 1 - xf, h - 1 - yf,
                                      np.where((a >> POL_BIT) & 1, 1, -1).astype(np.int8))


def read_aedat2(path: str | Path) -> Recording:
    """Read an AEDAT 2.0 file (jAER, DAVIS layout) into a Recording: events and sensor size."""
    path = Path(path)
    counts: dict = {}
    chunks = list(iter_aedat2_events(path, counts=counts))
    events = np.concatenate(chunks) if chunks else events_from_columns(path, [], [], [], [])
    lines, _ = read_header(path)
    h, w = sensor_size(path)
    return Recording(events=events, height=h, width=w,
                     metadata={"source": {"format": "aedat2", "path": str(path), "header": lines,
                                          "skipped_words": counts}})
