"""The AEDAT4 flatbuffer tables evsim writes itself: EventPacket (EVTS) and Frame (FRME) packets, the
FileDataTable (FTAB) index, and the IOHeader's dataTablePosition.

AEDAT4 (iniVation, "AEDAT 4.0" file format; schemas frame.fbs, FileDataTable.fbs, IOHeader.fbs of dv-processing):
"#!AER-DAT4.0\\r\\n", int32 size and an IOHeader flatbuffer (compression, dataTablePosition, infoNode XML), then
packets of int32 stream id, int32 size and the (compressed) size-prefixed flatbuffer with its 4-byte identifier,
then the FileDataTable at dataTablePosition, compressed alike. Flatbuffers: little-endian; a table starts with an
int32 offset back to its vtable (uint16 vtable size, uint16 table size, one uint16 field offset per field, 0 for a
field left at its default); references to vectors and tables are uint32 offsets forward from where they are stored.

EventPacket (events.fbs): one field, elements, a vector of Event structs {timestamp int64 us, x int16, y int16,
polarity bool (true = ON)}, 16 bytes each (8-byte alignment), the vector's elements starting at a multiple of 8.

Frame fields (frame.fbs, in order): timestamp, timestampStartOfFrame, timestampEndOfFrame, timestampStartOfExposure,
timestampEndOfExposure (int64 us), format (int8, 0 = 8-bit grey), sizeX, sizeY, positionX, positionY (int16),
pixels ([uint8], row-major), exposure (int64 us), source (int8, 1 = SENSOR).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

MAGIC = b"#!AER-DAT4.0\r\n"
#: an EventPacket element (events.fbs struct Event)
EVENT_STRUCT = np.dtype({"names": ["t", "x", "y", "on"], "formats": ["<i8", "<i2", "<i2", "u1"],
                         "offsets": [0, 8, 10, 12], "itemsize": 16})


@dataclass
class PacketEntry:
    """One FileDataTable row: byte_offset (in the file, of the packet's body, after its stream id and size words),
    stream_id, size (of the compressed body), num_elements, t_start, t_end (us)."""

    byte_offset: int
    stream_id: int
    size: int
    num_elements: int
    t_start: int
    t_end: int


def _table(buf: bytes, pos: int) -> tuple[int, list[int]]:
    """(position, field offsets) of the table at `pos`."""
    vt = pos - struct.unpack_from("<i", buf, pos)[0]
    vsize = struct.unpack_from("<H", buf, vt)[0]
    return pos, list(struct.unpack_from(f"<{(vsize - 4) // 2}H", buf, vt + 4))


def _field(buf: bytes, table: tuple[int, list[int]], i: int, fmt: str, default: int = 0) -> int:
    pos, offs = table
    return struct.unpack_from(fmt, buf, pos + offs[i])[0] if i < len(offs) and offs[i] else default


def _ref(buf: bytes, table: tuple[int, list[int]], i: int) -> int | None:
    pos, offs = table
    if i >= len(offs) or not offs[i]:
        return None
    at = pos + offs[i]
    return at + struct.unpack_from("<I", buf, at)[0]


def io_header_table(buf: bytes) -> tuple[int, int, int, str]:
    """(compression, dataTablePosition, byte position of dataTablePosition in buf, infoNode XML) of an IOHeader
    flatbuffer (not size-prefixed)."""
    table = _table(buf, struct.unpack_from("<I", buf, 0)[0])
    pos, offs = table
    if len(offs) < 2 or not offs[1]:
        raise ValueError("IOHeader without dataTablePosition")
    text = _ref(buf, table, 2)
    info = "" if text is None else buf[text + 4 : text + 4 + struct.unpack_from("<I", buf, text)[0]].decode()
    return _field(buf, table, 0, "<i"), _field(buf, table, 1, "<q", -1), pos + offs[1], info


def stream_ids(info: str, type_identifier: str) -> list[int]:
    """The ids of the streams of a type ("EVTS", "FRME", ...) declared in an IOHeader's infoNode XML."""
    import xml.etree.ElementTree as ET

    out = []
    for node in ET.fromstring(info).iter("node"):
        if node.get("name", "").isdigit() and any(a.get("key") == "typeIdentifier" and a.text == type_identifier
                                                  for a in node.findall("attr")):
            out.append(int(node.get("name")))
    return out


class _Builder:
    """Lays out one size-prefixed flatbuffer front to back: size, root offset, identifier, then tables and vectors,
    each reference pointing forward (flatbuffers' offsets are unsigned). Scalars are aligned to their size from
    the start of the buffer (the size prefix); every field of a table is present, so one vtable per table."""

    def __init__(self, identifier: bytes):
        self.buf = bytearray(8) + identifier

    def align(self, n: int) -> None:
        self.buf += bytes(-len(self.buf) % n)

    def table(self, fields: list[tuple[str, object]]) -> tuple[int, list[int]]:
        """Write a vtable and its table of (struct format, value) fields; a value None writes zeros (an offset
        patched later with patch_ref, or a struct). Returns (table position, field positions)."""
        vt_size = 4 + 2 * len(fields)
        self.buf += bytes(-(len(self.buf) + vt_size + 4) % 8)  # the table's first field at a multiple of 8
        vt = len(self.buf)
        self.buf += bytes(vt_size)
        table = len(self.buf)
        self.buf += struct.pack("<i", table - vt)
        positions = []
        for fmt, value in fields:
            size = struct.calcsize(fmt)
            self.align(min(size, 8))
            positions.append(len(self.buf))
            self.buf += bytes(size) if value is None else struct.pack(fmt, value)
        struct.pack_into("<HH", self.buf, vt, vt_size, len(self.buf) - table)
        for i, at in enumerate(positions):
            struct.pack_into("<H", self.buf, vt + 4 + 2 * i, at - table)
        return table, positions

    def vector(self, data: bytes, count: int, element_align: int = 4) -> int:
        """Write a vector (uint32 length, then the elements, starting at a multiple of element_align); returns its
        position."""
        self.align(4)
        self.buf += bytes(-(len(self.buf) + 4) % element_align)
        at = len(self.buf)
        self.buf += struct.pack("<I", count) + data
        return at

    def patch_ref(self, at: int, target: int) -> None:
        struct.pack_into("<I", self.buf, at, target - at)

    def finish(self, root: int) -> bytes:
        struct.pack_into("<I", self.buf, 4, root - 4)  # the root offset counts from the byte after the prefix
        self.align(8)
        struct.pack_into("<I", self.buf, 0, len(self.buf) - 4)
        return bytes(self.buf)


def event_packet(events: np.ndarray) -> bytes:
    """A size-prefixed EVTS flatbuffer of events (a structured array with fields t, x, y and p, p > 0 = ON)."""
    elements = np.zeros(events.size, EVENT_STRUCT)
    elements["t"], elements["x"], elements["y"] = events["t"], events["x"], events["y"]
    elements["on"] = events["p"] > 0
    b = _Builder(b"EVTS")
    table, pos = b.table([("<I", None)])
    b.patch_ref(pos[0], b.vector(elements.tobytes(), events.size, element_align=8))
    return b.finish(table)


def frame_packet(t: int, t_start_frame: int, t_end_frame: int, t_start_exp: int, t_end_exp: int,
                 pixels: bytes, width: int, height: int) -> bytes:
    """A size-prefixed FRME flatbuffer of one 8-bit grey SENSOR frame with every time field set."""
    b = _Builder(b"FRME")
    table, pos = b.table([("<q", t), ("<q", t_start_frame), ("<q", t_end_frame), ("<q", t_start_exp),
                          ("<q", t_end_exp), ("<b", 0), ("<h", width), ("<h", height), ("<h", 0), ("<h", 0),
                          ("<I", None), ("<q", t_end_exp - t_start_exp), ("<b", 1)])
    b.patch_ref(pos[10], b.vector(pixels, len(pixels)))
    return b.finish(table)


def data_table_packet(rows: list[PacketEntry]) -> bytes:
    """A size-prefixed FTAB flatbuffer of the rows."""
    b = _Builder(b"FTAB")
    root, pos = b.table([("<I", None)])
    vec = b.vector(bytes(4 * len(rows)), len(rows))
    b.patch_ref(pos[0], vec)
    for k, r in enumerate(rows):
        table, fpos = b.table([("<q", r.byte_offset), ("<ii", None), ("<q", r.num_elements), ("<q", r.t_start),
                            ("<q", r.t_end)])
        struct.pack_into("<ii", b.buf, fpos[1], r.stream_id, r.size)
        b.patch_ref(vec + 4 + 4 * k, table)
    return b.finish(root)
