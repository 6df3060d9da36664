"""Test helpers: synthetic compressed clips (OpenCV's MPEG-4 Part 2 encoder, the one this OpenCV writes to MP4)
and a capture-rate tag written the way Android's MediaMuxer writes it (moov/meta with keys and ilst boxes)."""

from __future__ import annotations

import struct
from pathlib import Path

import cv2
import numpy as np
from skimage import data

H, W = 120, 160


def slow_motion_frames(n: int, *, px_per_frame: float = 0.25) -> np.ndarray:
    """(n, H, W) uint8: a static textured background (the astronaut, 10..227 DN) and a bright disk (radius 8 px)
    moving right along y = 20 by px_per_frame per frame, as a 960 fps capture of a slow scene."""
    bg = cv2.resize(cv2.cvtColor(data.astronaut(), cv2.COLOR_RGB2GRAY), (W, H), interpolation=cv2.INTER_AREA)
    bg = 0.85 * bg.astype(np.float32) + 10
    yy, xx = np.mgrid[:H, :W]
    out = np.empty((n, H, W), np.uint8)
    for k in range(n):
        disk = np.hypot(xx - (20 + px_per_frame * k), yy - 20) < 8
        out[k] = np.clip(np.round(np.where(disk, 230.0, bg)), 0, 255)
    return out


def encode_mp4(path: Path, frames: np.ndarray, *, fps: float = 30.0, gop: int = 160) -> Path:
    """Encode grey frames (n, h, w) uint8 as MPEG-4 Part 2 in MP4 at fps with a key frame every gop frames."""
    h, w = frames.shape[1:]
    writer = cv2.VideoWriter(str(path), cv2.CAP_FFMPEG, cv2.VideoWriter_fourcc(*"mp4v"), fps, (w, h),
                             [cv2.VIDEOWRITER_PROP_GOP_SIZE, gop, cv2.VIDEOWRITER_PROP_IS_COLOR, 0])
    assert writer.isOpened(), "this OpenCV cannot write mp4v"
    for f in frames:
        writer.write(f)
    writer.release()
    return path


def _box(kind: bytes, payload: bytes) -> bytes:
    return struct.pack(">I4s", 8 + len(payload), kind) + payload


def tag_capture_fps(path: Path, fps: float, key: str = "com.android.capture.fps", where: str = "moov") -> None:
    """Add a QuickTime metadata box holding `key` = fps (float32, well-known type 23) to the movie box of an MP4
    whose movie box comes last (as OpenCV writes it: appending there moves no sample data). where: "moov" or
    "udta" (inside a new moov/udta)."""
    buf = bytearray(Path(path).read_bytes())
    i = 0
    while i < len(buf):
        size, kind = struct.unpack(">I4s", buf[i:i + 8])
        if kind == b"moov":
            break
        i += size
    assert kind == b"moov" and i + size == len(buf), "the movie box must be the last box"
    hdlr = _box(b"hdlr", bytes(8) + b"mdta" + bytes(12) + b"\0")
    name = key.encode()
    keys = _box(b"keys", bytes(4) + struct.pack(">I", 1) + struct.pack(">I4s", 8 + len(name), b"mdta") + name)
    value = _box(b"data", struct.pack(">II", 23, 0) + struct.pack(">f", fps))
    ilst = _box(b"ilst", _box(struct.pack(">I", 1), value))
    meta = _box(b"meta", hdlr + keys + ilst)
    if where == "udta":
        meta = _box(b"udta", meta)
    buf[i:i + 4] = struct.pack(">I", size + len(meta))
    Path(path).write_bytes(bytes(buf) + meta)
