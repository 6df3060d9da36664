"""AEDAT4 (iniVation DV) reader through the optional `aedat` package (`pip install aedat`).

Reads the first event stream (and the first frame stream, if any) into a Recording. Times are the camera's
int64 microseconds (usually Unix time). Frame exposure windows come from exposure_begin_t / exposure_end_t;
colour frames are converted to grey with OpenCV. IMU and trigger packets are ignored.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ..recording import Recording
from .common import events_from_columns, fail, polarity_pm1


def _grey(frame: dict) -> np.ndarray:
    px = np.asarray(frame["pixels"])
    if px.ndim == 3:
        fmt = str(frame.get("format", "BGR")).upper()
        code = {3: cv2.COLOR_RGB2GRAY if fmt.startswith("RGB") else cv2.COLOR_BGR2GRAY,
                4: cv2.COLOR_RGBA2GRAY if fmt.startswith("RGB") else cv2.COLOR_BGRA2GRAY}[px.shape[2]]
        px = cv2.cvtColor(px, code)
    return px


def read_aedat4(path) -> Recording:
    """Read an AEDAT4 file; DatasetFormatError when aedat is missing or the file is unreadable/truncated."""
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
