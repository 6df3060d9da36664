"""The frames of a recorded hybrid sequence (AEDAT4, native or E2VID HDF5, IJRR folder) as a video scene's input.

A hybrid camera's own frames (a DAVIS's APS frames) are the most faithful input there is for simulating the events it
recorded: same scene, same instant, same optics. The frames are read with generators.formats.load; their times are
the mid-exposure times, kept in the recording's own time base (time_origin_us is the first frame's mid-exposure,
so that simulated events can be written at the times the real ones carry), and each frame's exposure time
(t_end - t_start) goes with it so that the scene can normalise frames of different exposures.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..formats.common import fail

if TYPE_CHECKING:
    from ..formats.recording import Recording


def sha256_of(paths: list[Path]) -> str:
    """sha256 of one file's bytes, or of the names and bytes of several files in order.

    Parameters
    ----------
    paths : list of Path
        The files.

    Returns
    -------
    str
        The hex digest.
    """
    h = hashlib.sha256()
    for p in paths:
        if len(paths) > 1:
            h.update(p.name.encode() + b"\0")
        with open(p, "rb") as f:
            while chunk := f.read(1 << 20):
                h.update(chunk)
    return h.hexdigest()


def is_recording(path: Path) -> bool:
    """True for an event recording evsim reads as scene input (its frames): a file or folder that a format of
    generators.formats.registry holding events recognises (native or E2VID HDF5, AEDAT4, AKF .mat, an IJRR folder,
    ...; one without frames is then refused by RecordingFrames). Files of other suffixes are not read; a folder no
    format recognises (images) is not a recording; a file whose suffix a format claims but whose content is wrong
    raises DatasetFormatError (naming what is wrong).

    Parameters
    ----------
    path : Path
        A scene input (file or folder).

    Returns
    -------
    bool
        Whether it is an event recording.
    """
    from ..formats import DatasetFormatError, detect
    from ..formats.registry import format_record, suffix_claimed

    if path.is_dir():
        try:
            name = detect(path)
        except DatasetFormatError:
            return False
    elif suffix_claimed(path):
        name = detect(path)
    else:
        return False
    return "events" in format_record(name).holds


class RecordingFrames:
    """Sequential access to the frames of a recording, as the video scene's other inputs (scenes.video._Frames).

    Parameters
    ----------
    path : Path
        The recording (file or folder).
    recording : Recording, optional
        The recording already loaded from path (else it is loaded).

    Attributes
    ----------
    times_us : numpy.ndarray
        (F,) int64 mid-exposure times from the first frame (us).
    time_origin_us : int
        The first frame's mid-exposure time in the recording's time base (us).
    exposures_us : numpy.ndarray
        (F,) int64 exposure times (us; 0 where the layout records none).
    crf : dict
        The recorded camera response {"name", "params"} (a simulated recording's), else linear (a DAVIS's APS
        frames are linear in DN).
    """

    kind = "recording"
    counted_to_end = True

    def __init__(self, path: Path, recording: Recording | None = None):
        from ..formats import load

        self.path = path
        rec = load(path) if recording is None else recording  # a recording the caller loaded already
        if rec.frames is None or rec.frames.shape[0] < 2:
            n = 0 if rec.frames is None else rec.frames.shape[0]
            raise fail(path, f"the recording holds {n} frame(s): a scene needs at least 2")
        self._frames = np.asarray(rec.frames)
        mid = np.asarray(rec.frame_t_mid_us, np.int64)
        if np.any(np.diff(mid) <= 0):
            raise fail(path, "the frames' mid-exposure times must increase strictly")
        self.time_origin_us = int(mid[0])
        self.times_us = mid - mid[0]
        self.exposures_us = np.asarray(rec.frame_t_end_us, np.int64) - np.asarray(rec.frame_t_start_us, np.int64)
        self.bit_depth = int(rec.frame_bit_depth)
        self.crf = dict(rec.crf) if rec.crf else {"name": "linear", "params": {}}
        self.size = tuple(self._frames.shape[1:3])
        self.sha256 = sha256_of(sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path])
        self.rate = {"timestamps": "the recording's frame mid-exposure times", "unit": "us"}

    def frames(self, first: int = 0) -> Iterator[np.ndarray]:
        """The frames in order.

        Parameters
        ----------
        first : int, optional
            Index of the first frame (default 0).

        Yields
        ------
        numpy.ndarray
            (H, W) raw frame (DN, unsigned integers of the recording's bit depth).
        """
        for k in range(first, self._frames.shape[0]):
            yield self._frames[k]
