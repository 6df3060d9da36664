"""AEDAT4 (iniVation DV): reader through the optional `aedat` package (`pip install aedat`); writer of a header by
dv-processing (`pip install dv-processing`), iniVation's own library, run in a child process (it aborts its
process when a write fails), and of event and frame packets of evsim's own (aedat4_tables): dv-processing takes
events from Python one at a time, and its Python dv.Frame leaves the start and end of frame readout at 0.

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
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from sim import EvsimInputError

from .aedat4_tables import (
    MAGIC,
    PacketEntry,
    data_table_packet,
    event_packet,
    frame_packet,
    io_header_table,
    stream_ids,
)
from .atomic import commit, discard, disk_full_error, is_disk_full, temp_sibling
from .common import events_from_columns, fail, polarity_pm1, quiet_native_output
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
        with quiet_native_output():  # the decoder's panic text (and RUST_BACKTRACE's backtrace) stays off the terminal
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
        events = events_from_columns(path, ev["t"].astype(np.int64), ev["x"], ev["y"], polarity_pm1(path, pol))
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
# dv-processing (iniVation's library) writes the file's header: the IOHeader with its stream declarations. It runs
# in a child process, as it aborts its process (SIGABRT) when a write fails (a full disk) or on a file name not
# ending in .aedat4; it writes <temporary folder>/header.aedat4 from the JSON {"path", "width", "height", "frames"}
# given as its argument. The packets are evsim's own (aedat4_tables): dv-processing takes events from Python one
# at a time (dv.EventStore.push_back, about 1.4 us per event): 5.15 M events took 10.5 s, now 1.3 s
# (bench/bench_export.py --duration-s 4 --formats aedat4).
_HEADER_CHILD = r"""
import json, sys
import dv_processing as dv
head = json.loads(sys.argv[1])
config = dv.io.MonoCameraWriter.Config("evsim")
config.addEventStream((head["width"], head["height"]))
if head["frames"]:
    config.addFrameStream((head["width"], head["height"]))
writer = dv.io.MonoCameraWriter(head["path"], config)
del writer  # closes the file (a failed write aborts this process)
"""
PACKET_EVENTS = 32768  # events per EVTS packet at most
MAX_SIDE = 32767  # pixels: the Event struct's int16 x and y


def write_aedat4(rec: Recording, path: str | Path, *, event_source: Iterator | None = None) -> None:
    """Write events (and frames with their exposure windows, when the recording has them) as AEDAT4, streamed chunk
    by chunk and atomically: the header (stream declarations) by dv-processing (`pip install dv-processing`), the
    event and frame packets LZ4-compressed by evsim (needs `pip install lz4`, as dv-processing declares LZ4).

    What AEDAT4 holds: the sensor size (stream resolution), events as int64 microsecond times with boolean
    polarity (True = ON), in packets of at most PACKET_EVENTS; 8-bit grey frames (deeper frames lose their low
    bits). A frame's timestamp is its exposure start (dv-processing's convention); its start and end of exposure
    are the exposure window; its start and end of frame (readout) are the same window (the camera model has no
    readout time); its exposure is t_end - t_start. The mid-exposure time reads back as (start + end) // 2. A frame
    packet precedes the first event packet that starts after the frame's exposure start. A full disk raises
    atomic.DiskFullError naming `path`; a failure of dv-processing an OSError with its message.
    """
    validate_recording(rec)
    if max(rec.width, rec.height) > MAX_SIDE:
        raise EvsimInputError(f"aedat4 holds sensors up to {MAX_SIDE}x{MAX_SIDE} pixels (int16 x and y), not "
                              f"{rec.width}x{rec.height}: choose another format")
    for module, what in (("dv_processing", "dv-processing"), ("lz4", "lz4")):
        if importlib.util.find_spec(module) is None:
            raise EvsimInputError(f"writing AEDAT4 needs the optional '{what}' package (pip install {what})")
    nf = 0 if rec.frames is None else rec.frames.shape[0]
    path = Path(path)
    tmp_dir = temp_sibling(path, directory=True)  # dv-processing needs a name ending in .aedat4
    try:
        _write_header(tmp_dir / "header.aedat4", rec.width, rec.height, nf > 0)
        chunks = event_source if event_source is not None else recording_event_chunks(rec)
        _write_packets(tmp_dir / "header.aedat4", tmp_dir / "out.aedat4", rec, (c for c, _ in chunks))
        commit(tmp_dir / "out.aedat4", path)
    except BaseException as e:
        if is_disk_full(e):
            raise disk_full_error(e, path) from e
        raise
    finally:
        discard(tmp_dir)


def _write_header(path: Path, width: int, height: int, frames: bool) -> None:
    """dv-processing writes an AEDAT4 file at `path` with an event stream (and a frame stream) and no packet."""
    head = json.dumps({"path": str(path), "width": int(width), "height": int(height), "frames": bool(frames)})
    proc = subprocess.run([sys.executable, "-P", "-c", _HEADER_CHILD, head], stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE)
    if proc.returncode != 0 or not path.is_file():
        text = proc.stderr.decode(errors="replace")
        lines = [ln.strip() for ln in text.splitlines() if "rror" in ln] or [text.strip() or "no message"]
        raise OSError(f"dv-processing could not write {path} (exit {proc.returncode}): {lines[-1][-500:]}")


def _write_packets(src: Path, dst: Path, rec: Recording, event_chunks: Iterator[np.ndarray]) -> None:
    """Copy the header of the AEDAT4 file `src` (LZ4-compressed, its streams declared, no packet) to `dst`, then
    the event packets of the time-sorted event_chunks with one FRME packet per frame of `rec` put before the first
    event packet that starts after its exposure start, then a new FileDataTable."""
    import lz4.frame

    with open(src, "rb") as f:
        if f.read(len(MAGIC)) != MAGIC:
            raise OSError(f"{src}: dv-processing did not write an AEDAT4 file")
        (n,) = struct.unpack("<i", f.read(4))
        header = f.read(n)
    compression, _, field_at, info = io_header_table(header)
    if compression != 1:
        raise OSError(f"{src}: expected LZ4 compression (1), found {compression}")
    (event_id,) = stream_ids(info, "EVTS")
    frame_ids = stream_ids(info, "FRME")  # declared when the recording has frames
    frame_id = frame_ids[0] if frame_ids else None
    shift = max(rec.frame_bit_depth - 8, 0)
    rows, k = [], 0
    t_start = t_end = np.zeros(0, np.int64)
    if frame_id is not None:
        t_start, t_end = (np.asarray(a, np.int64) for a in (rec.frame_t_start_us, rec.frame_t_end_us))

    with open(dst, "wb") as out:
        out.write(MAGIC + struct.pack("<i", n) + header)

        def packet(stream_id: int, body: bytes, count: int, t0: int, t1: int) -> None:
            body = lz4.frame.compress(body)
            rows.append(PacketEntry(out.tell() + 8, stream_id, len(body), count, t0, t1))
            out.write(struct.pack("<ii", stream_id, len(body)) + body)

        def frames_until(t_us: int | None) -> None:
            nonlocal k
            while k < t_start.size and (t_us is None or t_start[k] <= t_us):
                img = rec.frames[k]
                pixels = np.ascontiguousarray(img >> shift if shift else img, dtype=np.uint8).tobytes()
                t0, t1 = int(t_start[k]), int(t_end[k])
                packet(frame_id, frame_packet(t0, t0, t1, t0, t1, pixels, rec.width, rec.height), 1, t0, t0)
                k += 1

        for chunk in event_chunks:
            for i in range(0, chunk.size, PACKET_EVENTS):
                part = chunk[i:i + PACKET_EVENTS]
                t0, t1 = int(part["t"][0]), int(part["t"][-1])
                frames_until(t0)
                packet(event_id, event_packet(part), part.size, t0, t1)
        frames_until(None)
        table = out.tell()
        out.write(lz4.frame.compress(data_table_packet(rows)))
        out.seek(len(MAGIC) + 4 + field_at)
        out.write(struct.pack("<q", table))
