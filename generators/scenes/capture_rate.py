"""The capture frame rate a phone records in an MP4/QuickTime file's metadata (slow-motion clips).

Phones store slow-motion video at a playback rate (e.g. 30 fps) and record the rate the sensor captured at in the
movie's metadata: Android's MediaMuxer writes the key `com.android.capture.fps` (a float32) in the QuickTime
metadata of the movie box (moov/meta with a `keys` and an `ilst` box: Apple, "QuickTime File Format
Specification", Metadata, 2016). capture_fps() reads the value of any key whose name ends in `capture.fps` or
`capture-fps` from moov/meta, moov/udta/meta and each track's meta, parsing the ISO base media file format boxes
itself (ISO/IEC 14496-12; no FFmpeg needed). Files that are not ISO base media (AVI, Matroska, ...) have none.

The parser is strict: a box whose size runs past its parent, or a key or value that cannot be decoded, raises
DatasetFormatError naming the file and the box.
"""

from __future__ import annotations

import struct
from pathlib import Path

from ..formats.common import fail

_TOP_LEVEL = {b"ftyp", b"moov", b"mdat", b"free", b"skip", b"wide", b"pnot", b"uuid", b"meta"}
_MAX_MOOV_BYTES = 256 << 20
_KEY_SUFFIXES = ("capture.fps", "capture-fps")


def _boxes(buf: bytes, start: int, end: int, path: Path, where: str):
    """(type, payload start, payload end) of each box in buf[start:end]."""
    i = start
    while i < end:
        if end - i < 8:
            raise fail(path, f"{where}: {end - i} stray bytes at offset {i}, too few for a box header")
        size, kind = struct.unpack(">I4s", buf[i:i + 8])
        head = 8
        if size == 1:
            if end - i < 16:
                raise fail(path, f"{where}: truncated 64-bit box size at offset {i}")
            size, head = struct.unpack(">Q", buf[i + 8:i + 16])[0], 16
        elif size == 0:
            size = end - i
        if size < head or i + size > end:
            raise fail(path, f"{where}/{kind.decode('latin-1')}: box of {size} bytes at offset {i} does not fit "
                             f"in its parent ({end - i} bytes left)")
        yield kind, i + head, i + size
        i += size


def _children(buf: bytes, start: int, end: int, path: Path, where: str) -> dict[bytes, list[tuple[int, int]]]:
    out: dict[bytes, list[tuple[int, int]]] = {}
    for kind, a, b in _boxes(buf, start, end, path, where):
        out.setdefault(kind, []).append((a, b))
    return out


def _decode(kind: int, data: bytes, path: Path, where: str) -> float | None:
    """A numeric metadata value: well-known types 1 (UTF-8), 21/22 (big-endian int), 23/24 (big-endian float)."""
    try:
        if kind == 23 and len(data) == 4:
            return struct.unpack(">f", data)[0]
        if kind == 24 and len(data) == 8:
            return struct.unpack(">d", data)[0]
        if kind in (21, 22) and len(data) in (1, 2, 4, 8):
            return float(int.from_bytes(data, "big", signed=kind == 21))
        if kind == 1:
            return float(data.decode("utf-8").strip())
    except (UnicodeDecodeError, ValueError):
        pass
    raise fail(path, f"{where}: cannot decode a capture rate from a value of type {kind} ({len(data)} bytes)")


def _meta_capture_fps(buf: bytes, start: int, end: int, path: Path, where: str) -> tuple[float, str] | None:
    """The capture rate in one meta box (QuickTime style, or ISO style with version and flags)."""
    if buf[start + 4:start + 8] != b"hdlr":  # ISO full box: skip version and flags
        start += 4
    kids = _children(buf, start, end, path, where)
    if b"keys" not in kids or b"ilst" not in kids:
        return None
    a, b = kids[b"keys"][0]
    if b - a < 8:
        raise fail(path, f"{where}/keys: truncated")
    (count,) = struct.unpack(">I", buf[a + 4:a + 8])
    names, i = [], a + 8
    for _ in range(count):
        if i + 8 > b:
            raise fail(path, f"{where}/keys: {count} keys announced, the box ends after {len(names)}")
        (size,) = struct.unpack(">I", buf[i:i + 4])
        if size < 8 or i + size > b:
            raise fail(path, f"{where}/keys: key {len(names) + 1} of {size} bytes does not fit")
        names.append(buf[i + 8:i + size].decode("utf-8", "replace"))
        i += size
    a, b = kids[b"ilst"][0]
    for kind, ia, ib in _boxes(buf, a, b, path, f"{where}/ilst"):
        index = int.from_bytes(kind, "big")
        if not 1 <= index <= len(names) or not names[index - 1].lower().endswith(_KEY_SUFFIXES):
            continue
        name = names[index - 1]
        for dkind, da, db in _boxes(buf, ia, ib, path, f"{where}/ilst/{name}"):
            if dkind == b"data":
                if db - da < 8:
                    raise fail(path, f"{where}/ilst/{name}/data: truncated")
                (type_word,) = struct.unpack(">I", buf[da:da + 4])
                return _decode(type_word & 0xFFFFFF, buf[da + 8:db], path, f"{where}/ilst/{name}"), name
    return None


def capture_fps(path: str | Path) -> tuple[float, str] | None:
    """The capture rate an MP4/QuickTime file records.

    Parameters
    ----------
    path : str or Path
        The video file.

    Returns
    -------
    tuple of (float, str) or None
        (capture rate in frames per second, the metadata key that holds it), or None for a file that records none
        (or is not an ISO base media file).
    """
    path = Path(path)
    with open(path, "rb") as f:
        head = f.read(8)
        if len(head) < 8 or head[4:8] not in _TOP_LEVEL:
            return None  # not an ISO base media file
        f.seek(0, 2)
        size = f.tell()
        pos = 0
        while pos + 8 <= size:
            f.seek(pos)
            box_size, kind = struct.unpack(">I4s", f.read(8))
            head_len = 8
            if box_size == 1:
                box_size, head_len = struct.unpack(">Q", f.read(8))[0], 16
            elif box_size == 0:
                box_size = size - pos
            if box_size < head_len or pos + box_size > size:
                raise fail(path, f"top-level box {kind.decode('latin-1')!r} of {box_size} bytes at offset {pos} "
                                 f"runs past the end of the file ({size} bytes)")
            if kind == b"moov":
                if box_size > _MAX_MOOV_BYTES:
                    raise fail(path, f"the movie box is {box_size} bytes, more than {_MAX_MOOV_BYTES} bytes")
                f.seek(pos + head_len)
                moov = f.read(box_size - head_len)
                return _moov_capture_fps(moov, path)
            pos += box_size
    return None


def _moov_capture_fps(moov: bytes, path: Path) -> tuple[float, str] | None:
    kids = _children(moov, 0, len(moov), path, "moov")
    places = [("moov/meta", a, b) for a, b in kids.get(b"meta", [])]
    for a, b in kids.get(b"udta", []):
        places += [("moov/udta/meta", x, y) for x, y in _children(moov, a, b, path, "moov/udta").get(b"meta", [])]
    for n, (a, b) in enumerate(kids.get(b"trak", [])):
        trak = _children(moov, a, b, path, f"moov/trak[{n}]")
        places += [(f"moov/trak[{n}]/meta", x, y) for x, y in trak.get(b"meta", [])]
        for ua, ub in trak.get(b"udta", []):
            places += [(f"moov/trak[{n}]/udta/meta", x, y)
                       for x, y in _children(moov, ua, ub, path, f"moov/trak[{n}]/udta").get(b"meta", [])]
    for where, a, b in places:
        found = _meta_capture_fps(moov, a, b, path, where)
        if found is not None:
            return found
    return None
