"""The frame camera of a recording, as a sensor file's [camera] table: what convert's LDR camera needs to write frames
like the recording's (frame rate, exposure, bit depth, read noise)."""

from __future__ import annotations

import numpy as np

import sim
from generators.formats.recording import Recording

__all__ = ["recorded_camera"]


def recorded_camera(rec: Recording, read_noise_dn: float) -> dict:
    """The CameraParams fields of the recording's frames.

    The frame rate is the median interval of the frames' mid-exposure times, the exposure their median exposure
    time (a camera under auto exposure varies it: the median is what it mostly used); the read noise in DN becomes
    electrons at the camera model's full well (CameraParams.full_well_e: DN = e (2^bits - 1) / full well). The
    frames' black level stays in the sensor file's [input] table: the camera model's frames start at 0 DN.

    Parameters
    ----------
    rec : Recording
        A recording with at least 2 frames.
    read_noise_dn : float
        The frames' read noise (DN rms).

    Returns
    -------
    dict
        {"fps" (frames per second), "exposure_us" (int us), "bit_depth", "read_noise_e" (electrons rms)}.
    """
    mid = np.asarray(rec.frame_t_mid_us, np.int64)
    exposure = np.asarray(rec.frame_t_end_us, np.int64) - np.asarray(rec.frame_t_start_us, np.int64)
    fps = 1e6 / float(np.median(np.diff(mid)))
    bits = int(rec.frame_bit_depth)
    full_well = sim.CameraParams().full_well_e
    table = {"fps": round(fps, 3), "bit_depth": bits,
             "read_noise_e": round(float(read_noise_dn) * full_well / ((1 << bits) - 1), 3)}
    if np.any(exposure > 0):
        table["exposure_us"] = int(np.median(exposure[exposure > 0]))
    return table
