"""AEDAT4 (iniVation DV): reader through the optional `aedat` package (`pip install aedat`), writer through
dv-processing (`pip install dv-processing`), iniVation's own library, run in a child process (it aborts its
process when a write fails), for the events; the frames are evsim's own FRME packets (aedat4_tables), since
dv-processing's Python dv.Frame leaves the start and end of frame readout at 0.

Reads the first event stream (and the first frame stream, if any) into a Recording. Times are the camera's
int64 microseconds (usually Unix time). Frame exposure windows come from exposure_begin_t / exposure_end_t;
colour frames are converted to grey with OpenCV. IMU and trigger packets are ignored.
"""

from __future__ import annotations

import importlib.util
import json
import struct
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from sim import EvsimInputError

from .aedat4_tables import (
    MAGIC,
    PacketEntry,
    data_table_packet,
    frame_packet,
    io_header_table,
    read_data_table,
    stream_ids,
)
from .atomic import commit, discard, disk_full_error, is_disk_full, temp_sibling
from .common import events_from_columns, fail, polarity_pm1
from .native import recording_event_chunks
from .recording import Recording, validate_recording


def _grey(frame: dict) -> np.ndarray:
    px = np.asarray(frame["pixels"])
    if px.ndim == 3:
        import cv2

        fmt = str(frame.get("format", "BGR")).upper()
        code = {3: cv2.COLOR_RGB2GRAY if fmt.startswith("RGB") else cv2.COLOR_BGR2GRAY,
                4: cv2.COLOR_RGBA2GRAY if fmt.startswith("RGB") else cv2.COLOR_BGRA2GRAY}[px.shape[2]]
        px = cv2.cvtColor(px, code)
    return px


def _is_native_panic(e: BaseException) -> bool:
    """A panic of a Rust library (the aedat decoder) raised through pyo3: pyo3_runtime.PanicException, which
    derives from BaseException, not Exception."""
    return type(e).__name__ == "PanicException" and type(e).__module__ == "pyo3_runtime"


def read_aedat4(path: str | Path) -> Recording:
    """Read an AEDAT4 file; DatasetFormatError when aedat is missing or the file is unreadable/truncated (a panic
    of the aedat decoder on corrupt bytes included)."""
    path = Path(path)
    if not path.is_file():
        raise fail(path, "no such file")
    try:
        import aedat
    except ImportError as e:
        raise fail(path, "reading AEDAT4 needs the optional 'aedat' package (pip install aedat)") from e
    chunks, frames, times = [], [], []
    try:
        decoder = aedat.Decoder(path)
        streams = decoder.id_to_stream()
        ev_ids = sorted(i for i, s in streams.items() if s["type"] == "events")
        fr_ids = sorted(i for i, s in streams.items() if s["type"] == "frame")
        if not ev_ids and not fr_ids:
            raise fail(path, "no event or frame stream")
        main = streams[(ev_ids or fr_ids)[0]]
        for packet in decoder:
            if "events" in packet and packet["stream_id"] == ev_ids[0]:
                chunks.append(packet["events"].copy())
            elif "frame" in packet and packet["stream_id"] == fr_ids[0]:
                f = packet["frame"]
                frames.append(_grey(f))
                times.append((int(f["exposure_begin_t"]), int(f["exposure_end_t"])))
    except RuntimeError as e:  # the decoder's error for truncated or corrupt files
        raise fail(path, f"unreadable AEDAT4 file (truncated or corrupt?): {e}") from e
    except BaseException as e:
        if not _is_native_panic(e):  # KeyboardInterrupt, SystemExit and the like pass through
            raise
        raise fail(path, f"unreadable AEDAT4 file (corrupt?): the aedat decoder failed: {e}") from None
    ev = np.concatenate(chunks) if chunks else None
    if ev is not None:
        pol = ev["on"] if "on" in ev.dtype.fields else ev["p"]
        events = events_from_columns(path, ev["t"].astype(np.int64), ev["x"], ev["y"], polarity_pm1(pol))
    else:
        events = events_from_columns(path, [], [], [], [])
    t = np.array(times, dtype=np.int64).reshape(-1, 2)
    return Recording(
        events=events, height=int(main["height"]), width=int(main["width"]),
        frames=np.stack(frames) if frames else None,
        frame_t_start_us=t[:, 0] if frames else None, frame_t_mid_us=(t[:, 0] + t[:, 1]) // 2 if frames else None,
        frame_t_end_us=t[:, 1] if frames else None, frame_bit_depth=8,
        metadata={"source": {"format": "aedat4", "path": str(path)}},
    )


# -- writing ----------------------------------------------------------------------------------------------------
# dv-processing writes in a thread of its own and aborts the process (SIGABRT) when a write fails (a full disk) or
# on a file name not ending in .aedat4: it runs in a child process, fed through a pipe, which writes
# <temporary folder>/out.aedat4; a failure there is an exception here. Messages on the pipe: b"E" + n (u8) + t (i8
# x n) + x (u2 x n) + y (u2 x n) + on (u1 x n) for events, b"Q" to close the file; the first line is JSON
# {"path", "width", "height", "frames"} ("frames": declare a frame stream, which add_frames then fills).
_WRITER_CHILD = r"""
import json, os, struct, sys
import numpy as np
import dv_processing as dv
src = sys.stdin.buffer
def read(n):
    buf = bytearray(n); view = memoryview(buf); got = 0
    while got < n:
        k = src.readinto(view[got:])
        if not k:
            os._exit(3)  # the parent went away: leave without finishing the file
        got += k
    return buf
head = json.loads(src.readline())
config = dv.io.MonoCameraWriter.Config("evsim")
config.addEventStream((head["width"], head["height"]))
if head["frames"]:
    config.addFrameStream((head["width"], head["height"]))
writer = dv.io.MonoCameraWriter(head["path"], config)
while True:
    tag = bytes(read(1))
    if tag == b"E":
        (n,) = struct.unpack("<Q", read(8))
        t = np.frombuffer(read(8 * n), "<i8"); x = np.frombuffer(read(2 * n), "<u2")
        y = np.frombuffer(read(2 * n), "<u2"); on = np.frombuffer(read(n), "u1")
        store = dv.EventStore()
        push = store.push_back
        for ti, xi, yi, oi in zip(t.tolist(), x.tolist(), y.tolist(), on.astype(bool).tolist()):
            push(ti, xi, yi, oi)
        writer.writeEvents(store)
    else:
        break
del writer  # closes the file (flushes the writer thread; a failed write aborts this process)
"""


def write_aedat4(rec: Recording, path: str | Path, *, event_source: Iterator | None = None) -> None:
    """Write events (and frames with their exposure windows, when the recording has them) as AEDAT4, streamed chunk
    by chunk and atomically: the events through dv-processing (`pip install dv-processing`), the frames as FRME
    packets of evsim's own (needs `pip install lz4`, as dv-processing compresses with LZ4).

    What AEDAT4 holds: the sensor size (stream resolution), events as int64 microsecond times with boolean
    polarity (True = ON), 8-bit grey frames (deeper frames lose their low bits). A frame's timestamp is its
    exposure start (dv-processing's convention); its start and end of exposure are the exposure window; its start
    and end of frame (readout) are the same window (the camera model has no readout time); its exposure is
    t_end - t_start. The mid-exposure time reads back as (start + end) // 2. dv-processing runs in a child process
    (it aborts its process on a failed write): a full disk raises atomic.DiskFullError naming `path`, another
    failure of it an OSError with its message.
    """
    validate_recording(rec)
    if importlib.util.find_spec("dv_processing") is None:
        raise EvsimInputError("writing AEDAT4 needs the optional 'dv-processing' package "
                              "(pip install dv-processing)")
    nf = 0 if rec.frames is None else rec.frames.shape[0]
    if nf and importlib.util.find_spec("lz4") is None:
        raise EvsimInputError("writing AEDAT4 frames needs the optional 'lz4' package (pip install lz4)")
    path = Path(path)
    tmp_dir = temp_sibling(path, directory=True)  # dv-processing needs a name ending in .aedat4: <tmp_dir>/out.aedat4
    try:
        with _DvWriter(tmp_dir / "out.aedat4", rec.width, rec.height, nf > 0) as writer:
            for chunk, _ in event_source if event_source is not None else recording_event_chunks(rec):
                if chunk.size:
                    writer.events(chunk)
        if nf:
            add_frames(tmp_dir / "out.aedat4", tmp_dir / "framed.aedat4", rec)
        commit(tmp_dir / ("framed.aedat4" if nf else "out.aedat4"), path)
    except BaseException as e:
        if is_disk_full(e):
            raise disk_full_error(e, path) from e
        raise
    finally:
        discard(tmp_dir)


def add_frames(src: Path, dst: Path, rec: Recording) -> None:
    """Copy the AEDAT4 file `src` (LZ4-compressed, a frame stream declared and empty) to `dst` with one FRME packet
    per frame of `rec` put before the first event packet that starts after it, and a new FileDataTable. Packets
    are copied one at a time."""
    import lz4.frame

    shift = max(rec.frame_bit_depth - 8, 0)
    with open(src, "rb") as f, open(dst, "wb") as out:
        if f.read(len(MAGIC)) != MAGIC:
            raise OSError(f"{src}: dv-processing did not write an AEDAT4 file")
        (n,) = struct.unpack("<i", f.read(4))
        header = bytearray(f.read(n))
        compression, table_at, field_at, info = io_header_table(header)
        if compression != 1:
            raise OSError(f"{src}: expected LZ4 compression (1), found {compression}")
        (frame_id,) = stream_ids(info, "FRME")
        f.seek(table_at)
        rows = read_data_table(lz4.frame.decompress(f.read()))
        out.write(MAGIC + struct.pack("<i", n) + header)
        new_rows, k = [], 0
        t_start, t_end = (np.asarray(a, np.int64) for a in (rec.frame_t_start_us, rec.frame_t_end_us))

        def frames_until(t_us: int | None) -> None:
            nonlocal k
            while k < t_start.size and (t_us is None or t_start[k] <= t_us):
                img = rec.frames[k]
                pixels = np.ascontiguousarray(img >> shift if shift else img, dtype=np.uint8).tobytes()
                t0, t1 = int(t_start[k]), int(t_end[k])
                body = lz4.frame.compress(frame_packet(t0, t0, t1, t0, t1, pixels, rec.width, rec.height))
                new_rows.append(PacketEntry(out.tell() + 8, frame_id, len(body), 1, t0, t0))
                out.write(struct.pack("<ii", frame_id, len(body)) + body)
                k += 1

        for row in sorted(rows, key=lambda r: r.byte_offset):
            frames_until(row.t_start)
            f.seek(row.byte_offset)
            new_rows.append(PacketEntry(out.tell() + 8, row.stream_id, row.size, row.num_elements, row.t_start,
                                        row.t_end))
            out.write(struct.pack("<ii", row.stream_id, row.size) + f.read(row.size))
        frames_until(None)
        table = out.tell()
        out.write(lz4.frame.compress(data_table_packet(new_rows)))
        out.seek(len(MAGIC) + 4 + field_at)
        out.write(struct.pack("<q", table))


class _DvWriter:
    """dv-processing's MonoCameraWriter in a child process (see _WRITER_CHILD), fed through its stdin."""

    def __init__(self, path: Path, width: int, height: int, frames: bool):
        self.path = path
        self._err: list[bytes] = []
        self._proc = subprocess.Popen([sys.executable, "-P", "-c", _WRITER_CHILD], stdin=subprocess.PIPE,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        self._drain = threading.Thread(target=lambda: self._err.append(self._proc.stderr.read()), daemon=True)
        self._drain.start()
        self._send(json.dumps({"path": str(path), "width": int(width), "height": int(height),
                               "frames": bool(frames)}).encode() + b"\n")

    def events(self, chunk: np.ndarray) -> None:
        self._send(b"E" + struct.pack("<Q", chunk.size), chunk["t"].astype("<i8").tobytes(),
                   chunk["x"].astype("<u2").tobytes(), chunk["y"].astype("<u2").tobytes(),
                   (chunk["p"] > 0).astype(np.uint8).tobytes())

    def _send(self, *parts: bytes) -> None:
        try:
            for part in parts:
                self._proc.stdin.write(part)
        except BrokenPipeError:  # the child died: its exit status and message say why
            self._finish(done=False)

    def _finish(self, *, done: bool = True) -> None:
        """Close the pipe, wait for the child; raise OSError unless it wrote the whole file."""
        try:
            self._proc.stdin.close()
        except BrokenPipeError:
            pass
        code = self._proc.wait()
        self._drain.join()
        self._proc.stderr.close()
        if code != 0 or not done:
            text = b"".join(self._err).decode(errors="replace")
            lines = [ln.strip() for ln in text.splitlines() if "rror" in ln] or [text.strip() or "no message"]
            raise OSError(f"dv-processing could not write {self.path} (exit {code}): {lines[-1][-500:]}")

    def __enter__(self) -> _DvWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self._send(b"Q")
            self._finish()
            return
        if self._proc.poll() is None:  # an error here, or SIGTERM/Ctrl-C: the child goes without finishing
            self._proc.kill()
        self._proc.wait()
        self._drain.join(timeout=1.0)
        for pipe in (self._proc.stdin, self._proc.stderr):
            try:
                pipe.close()
            except OSError:  # (a broken pipe)
                pass
