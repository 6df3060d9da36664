"""Event arrays in the layouts of other Python libraries (no dependency on them: plain numpy dtypes).

tonic (tonic.io.events_struct) takes events as a structured array x, y (int16), t (int64), p (bool, True = ON).
Its transforms index channels by p: ToFrame(sensor_size=(W, H, 2)) with evsim's p = -1 would put every OFF
event into the ON channel (index -1 is the last one). to_tonic gives p = 0 (OFF) / 1 (ON) as tonic's own datasets.

References (docs/models/references.md): Lenz et al. 2021 [Lenz2021], tonic.
"""

from __future__ import annotations

import numpy as np

from sim import EVENT_DTYPE, validate_events

TONIC_DTYPE = np.dtype([("x", np.int16), ("y", np.int16), ("t", np.int64), ("p", bool)])


def to_tonic(events: np.ndarray) -> np.ndarray:
    """evsim's events as tonic's structured array. Sensor size for tonic is (width, height, 2).

    Parameters
    ----------
    events : numpy.ndarray
        sim.EVENT_DTYPE events (t int64 us, p = -1/+1).

    Returns
    -------
    numpy.ndarray
        TONIC_DTYPE events (t int64 us, x, y int16, p False = OFF, True = ON).
    """
    validate_events(events, name="events")
    out = np.empty(events.size, TONIC_DTYPE)
    out["x"], out["y"], out["t"], out["p"] = events["x"], events["y"], events["t"], events["p"] > 0
    return out


def from_tonic(events: np.ndarray) -> np.ndarray:
    """tonic's structured events as evsim's, checked (time-sorted, coordinates valid).

    Parameters
    ----------
    events : numpy.ndarray
        Structured events with fields t (us), x, y and p (bool or 0/1, True / 1 = ON).

    Returns
    -------
    numpy.ndarray
        sim.EVENT_DTYPE events (t int64 us, p = -1/+1).
    """
    out = np.empty(events.size, EVENT_DTYPE)
    out["t"], out["x"], out["y"] = events["t"], events["x"], events["y"]
    out["p"] = np.where(np.asarray(events["p"]).astype(np.int64) > 0, 1, -1)
    return validate_events(out, name="tonic events")
