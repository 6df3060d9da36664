"""AEDAT4 (iniVation DV): reader through the optional `aedat` package (`pip install aedat`), writer through
dv-processing (`pip install dv-processing`), iniVation's own library.

Reads the first event stream (and the first frame stream, if any) into a Recording. Times are the camera's
int64 microseconds (usually Unix time). Frame exposure windows come from exposure_begin_t / exposure_end_t;
colour frames are converted to grey with OpenCV. IMU and trigger packets are ignored.
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np

from sim import EvsimInputError

from .atomic import commit
from .common import events_from_columns, fail, polarity_pm1
from .native import recording_event_chunks
from .recording import Recording, validate_recording


def _grey(frame: dict) -> np.ndarray:
    px = np.asarray(frame["pixels"])
    if px.ndim == 3:
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
def write_aedat4(rec: Recording, path: str | Path, *, event_source: Iterator | None = None) -> None:
    """Write events (and frames with their exposure windows, when the recording has them) as AEDAT4 through
    dv-processing (`pip install dv-processing`), streamed chunk by chunk and atomically.

    What AEDAT4 holds: the sensor size (stream resolution), events as int64 microsecond times with boolean
    polarity (True = ON), 8-bit grey frames whose timestamp is the exposure start and whose exposure is
    t_end - t_start (deeper frames lose their low bits). The mid-exposure time reads back as (start + end) // 2.
    """
    validate_recording(rec)
    try:
        import dv_processing as dv
    except ImportError as e:
        raise EvsimInputError("writing AEDAT4 needs the optional 'dv-processing' package "
                              "(pip install dv-processing)") from e
    nf = 0 if rec.frames is None else rec.frames.shape[0]
    config = dv.io.MonoCameraWriter.Config("evsim")
    config.addEventStream((rec.width, rec.height))
    if nf:
        config.addFrameStream((rec.width, rec.height))
    shift = max(rec.frame_bit_depth - 8, 0)
    t_start = np.asarray(rec.frame_t_start_us if nf else [], np.int64)
    t_end = np.asarray(rec.frame_t_end_us if nf else [], np.int64)
    next_frame = 0

    def write_frames_until(writer, t_us) -> int:
        i = next_frame
        while i < nf and (t_us is None or t_start[i] <= t_us):
            img = np.ascontiguousarray(rec.frames[i] >> shift if shift else rec.frames[i], dtype=np.uint8)
            writer.writeFrame(dv.Frame(int(t_start[i]), int(t_end[i] - t_start[i]), 0, 0, img,
                                       dv.FrameSource.SENSOR))
            i += 1
        return i

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # dv-processing aborts the process on a file name not ending in .aedat4: write one in a private temporary
    # folder beside path, then move it onto path (atomic, as every writer)
    with tempfile.TemporaryDirectory(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent) as d:
        tmp = Path(d) / "out.aedat4"
        writer = dv.io.MonoCameraWriter(str(tmp), config)
        try:
            for chunk, _ in event_source if event_source is not None else recording_event_chunks(rec):
                if chunk.size == 0:
                    continue
                next_frame = write_frames_until(writer, int(chunk["t"][-1]))  # frames interleaved in time
                store = dv.EventStore()
                push = store.push_back
                for t, x, y, on in zip(chunk["t"].tolist(), chunk["x"].tolist(), chunk["y"].tolist(),
                                       (chunk["p"] > 0).tolist()):
                    push(t, x, y, on)
                writer.writeEvents(store)
            next_frame = write_frames_until(writer, None)
        finally:
            del writer  # closes the file (flushes dv-processing's writer thread)
        commit(tmp, path)
