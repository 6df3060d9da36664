"""DVS video (`evsim plot events DATASET --video OUT.mp4|.gif --frame-ms 10`): event frames over consecutive
intervals, streamed over the file a chunk at a time (memory does not grow with the recording).

Frame k shows the events with t0 + k dt <= t < t0 + (k + 1) dt, t0 the first event's time and dt = frame_ms; a
recording whose events span t0..t_last gives (t_last - t0) // dt + 1 frames (silences give blank frames). Colours as
every evsim event figure (plots.events.event_frame_rgb): white where no event, towards red with the ON count and
towards blue with the OFF count, full at `full_scale` events of a polarity in the frame (a fixed scale, so one
colour means one pair of counts in every frame). Each sensor pixel becomes a `scale` x `scale` block.

MP4 is H.264 (High profile, yuv420p, CRF 18: what browsers, slide software and phones play), encoded by the x264
that PyAV's wheels ship (the FFmpeg libraries, no ffmpeg program needed); lossy, so colours are near, not exact; an
odd side gets one blank row or column at the bottom or right, as 4:2:0 frames have even sides;
GIF with Pillow, one frame at a time with a fixed palette (lossless; GIF frame delays are whole centiseconds).
The file is written to a temporary folder beside OUT and moved into place when complete.
"""

from __future__ import annotations

import io
import itertools
import time
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np

from sim import EvsimInputError

VIDEO_SUFFIXES = (".mp4", ".gif")
MAX_FULL_SCALE = 15  # (full_scale + 1)**2 colours must fit a 256-colour GIF palette


def palette(full_scale: int) -> np.ndarray:
    """((full_scale + 1)**2, 3) uint8 RGB colours; index on * (full_scale + 1) + off for clipped counts on, off."""
    from .events import event_frame_rgb

    n = full_scale + 1
    on, off = np.divmod(np.arange(n * n), n)
    rgb = event_frame_rgb(np.stack([on, off]).reshape(2, 1, n * n), top=full_scale)[0]
    return np.round(rgb * 255).astype(np.uint8)


def colour_index(counts: np.ndarray, full_scale: int) -> np.ndarray:
    """(H, W) uint8 palette indices of a (2, H, W) event frame (ON, OFF counts)."""
    c = np.minimum(counts, full_scale).astype(np.uint8)
    return c[0] * np.uint8(full_scale + 1) + c[1]


def event_frames(chunks: Iterable[np.ndarray], height: int, width: int, frame_us: int) -> Iterator[np.ndarray]:
    """(2, H, W) int64 ON and OFF counts of consecutive frames of frame_us microseconds from the first event (see
    the module docstring), from time-ordered event chunks; nothing for a stream without events."""
    counts = np.zeros((2, height * width), np.int64)
    t0, k = None, 0
    for ev in chunks:
        if ev.size == 0:
            continue
        if t0 is None:
            t0 = int(ev["t"][0])
        kk = (ev["t"].astype(np.int64) - t0) // frame_us
        idx = ev["y"].astype(np.int64) * width + ev["x"]
        on = ev["p"] > 0
        # the chunk's runs of events of one frame, [a, b), b from an array (a list of Python ints, one per run,
        # took 5 times the chunk's own memory when every event starts a frame)
        a = 0
        for b in itertools.chain(np.flatnonzero(np.diff(kk)) + 1, [kk.size]):
            while k < kk[a]:
                yield counts.reshape(2, height, width)
                counts = np.zeros((2, height * width), np.int64)
                k += 1
            counts[0] += np.bincount(idx[a:b][on[a:b]], minlength=height * width)
            counts[1] += np.bincount(idx[a:b][~on[a:b]], minlength=height * width)
            a = b
    if t0 is not None:
        yield counts.reshape(2, height, width)


class _Mp4:
    """H.264 in MP4 through PyAV (libx264), one frame at a time."""

    def __init__(self, path: Path, fps: float, size: tuple[int, int], colours: np.ndarray):
        from fractions import Fraction

        import av

        self._lut = np.zeros((256, 3), np.uint8)
        self._lut[: len(colours)] = colours  # RGB
        self._size = (size[0] + size[0] % 2, size[1] + size[1] % 2)  # 4:2:0 needs even sides
        self._file = av.open(str(path), mode="w", format="mp4")
        rate = Fraction(fps).limit_denominator(1001)
        self._stream = self._file.add_stream("libx264", rate=rate)
        self._stream.width, self._stream.height = self._size
        self._stream.pix_fmt = "yuv420p"
        self._stream.options = {"crf": "18", "preset": "medium", "profile": "high"}
        self._av = av

    def add(self, index: np.ndarray) -> None:
        h, w = index.shape
        if (w, h) != self._size:  # pad with the blank colour (index 0) to even sides
            index = np.pad(index, ((0, self._size[1] - h), (0, self._size[0] - w)))
        frame = self._av.VideoFrame.from_ndarray(self._lut[index], format="rgb24")
        self._file.mux(self._stream.encode(frame))

    def close(self) -> None:
        self._file.mux(self._stream.encode())  # flush the encoder's delayed frames
        self._file.close()


class _Gif:
    """Frames encoded one at a time by Pillow (each a one-frame GIF with the same global palette) and joined:
    the first file's header, then every file's frame blocks, then the trailer (GIF89a specification)."""

    def __init__(self, path: Path, fps: float, size: tuple[int, int], colours: np.ndarray):
        self._f = open(path, "wb")
        self._delay_ms = max(10, int(round(100 / fps)) * 10)  # whole centiseconds
        self._colours = colours.tobytes()
        self._header = None

    def add(self, index: np.ndarray) -> None:
        from PIL import Image

        im = Image.fromarray(index, "P")
        im.putpalette(self._colours)
        buf = io.BytesIO()
        im.save(buf, "GIF", duration=self._delay_ms, loop=0, optimize=False, disposal=1)
        head, blocks = _split_gif(buf.getvalue())
        if self._header is None:
            self._header = head
            self._f.write(head)
        elif head != self._header:
            raise RuntimeError("Pillow wrote a different GIF header (palette) for one frame")
        self._f.write(blocks)

    def close(self) -> None:
        self._f.write(b";")
        self._f.close()


def _split_gif(data: bytes) -> tuple[bytes, bytes]:
    """(header: signature, logical screen descriptor, global colour table, application extensions; frame: graphic
    control extension and image blocks) of a one-frame GIF file."""
    flags = data[10]
    pos = 13 + (3 << ((flags & 7) + 1) if flags & 0x80 else 0)
    head, frame = [data[:pos]], []
    while data[pos] != 0x3B:  # the trailer
        if data[pos] == 0x21:  # an extension: label, then sub-blocks up to a 0 byte
            end = _sub_blocks(data, pos + 2)
            (head if data[pos + 1] == 0xFF else frame).append(data[pos:end])
        elif data[pos] == 0x2C:  # image descriptor, optional local colour table, LZW code size, sub-blocks
            desc = data[pos + 9]
            end = _sub_blocks(data, pos + 10 + (3 << ((desc & 7) + 1) if desc & 0x80 else 0) + 1)
            frame.append(data[pos:end])
        else:
            raise RuntimeError(f"unexpected GIF block 0x{data[pos]:02x}")
        pos = end
    return b"".join(head), b"".join(frame)


def _sub_blocks(data: bytes, pos: int) -> int:
    while data[pos]:
        pos += data[pos] + 1
    return pos + 1


def write_video(path: str | Path, out: str | Path, *, frame_ms: float = 10.0, fps: float = 30.0, full_scale: int = 3,
                scale: int = 1, progress: bool = True) -> dict:
    """Render the events of the file `path` (any layout evsim reads) as a DVS video `out` (.mp4 or .gif); see the
    module docstring. frame_ms: the interval each frame accumulates (ms); fps: playback frames per second.
    Returns {"frames": number written, "events": events drawn, "frame_us", "height", "width", "path"}."""
    from tqdm.auto import tqdm

    from generators.formats.atomic import commit, discard, temp_sibling
    from generators.formats.streaming import open_event_stream

    out = Path(out)
    suffix = out.suffix.lower()
    check_video_options(out, frame_ms, fps, full_scale, scale)
    stream = open_event_stream(path)
    frame_us = int(round(frame_ms * 1e3))
    span = stream.known_t_range  # (a file without a known span is not read twice for the progress bar)
    total = None if span is None else (span[1] - span[0]) // frame_us + 1
    colours = palette(full_scale)
    size = (stream.width * scale, stream.height * scale)
    tmp_dir = temp_sibling(out, directory=True)
    n_frames = n_events = 0
    start = time.monotonic()
    try:
        writer = (_Mp4 if suffix == ".mp4" else _Gif)(tmp_dir / f"video{suffix}", fps, size, colours)
        try:
            with tqdm(total=total, unit="frame", desc="video", disable=not progress, leave=False) as bar:
                for counts in event_frames(stream.chunks(), stream.height, stream.width, frame_us):
                    index = colour_index(counts, full_scale)
                    if scale > 1:
                        index = np.repeat(np.repeat(index, scale, axis=0), scale, axis=1)
                    writer.add(index)
                    n_frames += 1
                    n_events += int(counts.sum())
                    bar.update(1)
                    bar.set_postfix_str(f"{n_events / max(time.monotonic() - start, 1e-9):.3g} events/s", refresh=False)
        finally:
            writer.close()
        if n_frames == 0:
            raise EvsimInputError(f"{path}: no events to draw")
        commit(tmp_dir / f"video{suffix}", out)
    finally:
        discard(tmp_dir)
    return {"frames": n_frames, "events": n_events, "frame_us": frame_us, "height": stream.height,
            "width": stream.width, "path": out}


def check_video_options(out: str | Path, frame_ms: float, fps: float, full_scale: int, scale: int) -> None:
    """EvsimInputError naming the first bad option."""
    suffix = Path(out).suffix.lower()
    if suffix not in VIDEO_SUFFIXES:
        raise EvsimInputError(f"--video file must end in {' or '.join(VIDEO_SUFFIXES)}, got {str(out)!r}")
    if not frame_ms * 1e3 >= 1:
        raise EvsimInputError(f"--frame-ms must be at least 0.001 ms, got {frame_ms}")
    if not 0 < fps <= 1000:
        raise EvsimInputError(f"--video-fps must be in (0, 1000], got {fps}")
    if not 1 <= full_scale <= MAX_FULL_SCALE:
        raise EvsimInputError(f"--full-scale must be 1..{MAX_FULL_SCALE} events, got {full_scale}")
    if not 1 <= scale <= 16:
        raise EvsimInputError(f"--scale must be 1..16, got {scale}")
