"""Exposure-matched reconstruction: a method's output integrated over a frame's exposure window, so that it can be
compared with what that frame recorded (a motion-blurred frame integrates the scene over its exposure).

A camera pixel collects charge in proportion to the time integral of its irradiance over [t_start, t_end]; its
x value (after CRF^-1 and the exposure gain) is the window's mean linear intensity. exposure_average() estimates
that mean from reconstructions at n sample times, the midpoints of n equal sub-intervals (the midpoint rule the
LDR camera model uses for motion blur, sim.camera), averaged in linear intensity; the caller then applies the
frame's response (clips to the range the frame can measure).

How many samples (sample_count): the reconstructions change at events (each a step of about one contrast threshold
c in log intensity) and slowly between them. With n midpoint samples each step is placed within 1/(2n) of the
window, so a pixel with k steps in the window has its mean off by at most k c / (2n) relative; n = 4 k bounds that
by c / 8 (2.5 % at c = 0.2) whatever k is. k is the busiest pixels' event count in the window (the 99th
percentile over the pixels with events), and n is kept in [MIN_SAMPLES, MAX_SAMPLES]: at least 8 where there are
few events (smooth leak and decay), at most 64 (cost: the reconstruction is evaluated n times per window).
A zero-length window (no exposure recorded) gives one sample, the point-in-time value.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Callable

    import numpy.typing as npt

__all__ = ["MIN_SAMPLES", "MAX_SAMPLES", "SAMPLES_PER_EVENT", "sample_count", "sample_times", "exposure_average"]

MIN_SAMPLES = 8  # samples per window at least (few events: the output changes smoothly)
MAX_SAMPLES = 64  # samples per window at most (each is a reconstruction)
SAMPLES_PER_EVENT = 4  # per event of the busiest pixels: each step placed within 1/8 of its share of the window
_CHUNK_BYTES = 1 << 28  # reconstructions per method call: about 256 MB of float32 images (at least MAX_SAMPLES)


def sample_count(events: np.ndarray, t_start_us: int, t_end_us: int, shape: tuple[int, int]) -> int:
    """The number of midpoint samples for the window [t_start_us, t_end_us) (see the module): 1 for an empty
    window, else clip(SAMPLES_PER_EVENT k, MIN_SAMPLES, MAX_SAMPLES) for k the 99th-percentile event count of the
    pixels with events in the window, and at most one sample per microsecond.

    Parameters
    ----------
    events : numpy.ndarray
        Time-sorted sim.EVENT_DTYPE events.
    t_start_us, t_end_us : int
        The window (int64 us).
    shape : tuple of int
        (H, W), pixels.

    Returns
    -------
    int
        The number of samples, >= 1.
    """
    length = int(t_end_us) - int(t_start_us)
    if length <= 0:
        return 1
    lo, hi = np.searchsorted(events["t"], [t_start_us, t_end_us], side="left")
    inside = events[lo:hi]
    k = 0.0
    if inside.size:
        counts = np.bincount(inside["y"].astype(np.int64) * shape[1] + inside["x"], minlength=shape[0] * shape[1])
        k = float(np.percentile(counts[counts > 0], 99))
    n = min(max(math.ceil(SAMPLES_PER_EVENT * k), MIN_SAMPLES), MAX_SAMPLES)
    return max(1, min(n, length))


def sample_times(t_start_us: int, t_end_us: int, n: int) -> npt.NDArray[np.int64]:
    """n midpoint times of [t_start_us, t_end_us): t_start + (j + 1/2) (t_end - t_start) / n, rounded to the
    microsecond (int64, non-decreasing).

    Parameters
    ----------
    t_start_us, t_end_us : int
        The window (int64 us).
    n : int
        Number of samples.

    Returns
    -------
    numpy.ndarray
        (n,) int64 times (us).
    """
    j = np.arange(n, dtype=np.float64)
    return np.rint(t_start_us + (j + 0.5) * (int(t_end_us) - int(t_start_us)) / n).astype(np.int64)


def exposure_average(reconstruct: Callable[[np.ndarray], np.ndarray], events: np.ndarray,
                     windows: npt.ArrayLike, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """The mean linear reconstruction over each exposure window, and the number of samples of each.

    reconstruct is called on groups of consecutive windows whose samples fit in about 256 MB of float32 images (each
    call runs the method from its start).

    Parameters
    ----------
    reconstruct : callable
        reconstruct(times) is the method at int64 times (us), returning (T, H, W) linear intensity (x units).
    events : numpy.ndarray
        Time-sorted sim.EVENT_DTYPE events (for sample_count).
    windows : array_like
        (K, 2) int64 [t_start, t_end] us, in time order, not overlapping.
    shape : tuple of int
        (H, W), pixels.

    Returns
    -------
    images : numpy.ndarray
        float32 (K, H, W) mean linear intensity (x units) of each window.
    counts : numpy.ndarray
        int64 (K,) samples of each window.
    """
    windows = np.asarray(windows, np.int64).reshape(-1, 2)
    counts = np.array([sample_count(events, a, b, shape) for a, b in windows], np.int64)
    budget = max(MAX_SAMPLES, _CHUNK_BYTES // (4 * shape[0] * shape[1]))
    out = np.empty((windows.shape[0], *shape), np.float32)
    k = 0
    while k < windows.shape[0]:
        stop = k + 1
        while stop < windows.shape[0] and counts[k:stop + 1].sum() <= budget:
            stop += 1
        times = np.concatenate([sample_times(a, b, n) for (a, b), n in zip(windows[k:stop], counts[k:stop])])
        images = reconstruct(times)
        bounds = np.concatenate([[0], np.cumsum(counts[k:stop])])
        for i in range(stop - k):
            out[k + i] = images[bounds[i]:bounds[i + 1]].mean(axis=0, dtype=np.float64)
        k = stop
    return out, counts
