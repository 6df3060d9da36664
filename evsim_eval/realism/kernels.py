"""Numba kernel of the realism statistics: one pass over a time-sorted event stream that gives every event's
interval since the previous event at its pixel and the event counts of the pixel's passages (bursts)."""

from __future__ import annotations

import numpy as np
from numba import njit

NO_INTERVAL = -1  # interval of a pixel's first event in a window


@njit(cache=True, nogil=True)
def _moving(t0, t1, pixel, interval_t, motion):
    """Whether the frames saw pixel change in a frame interval overlapping [t0, t1] (us). interval_t: (F,) frame
    times bounding the F - 1 intervals of motion (F - 1, n_pixels)."""
    n = motion.shape[0]
    if n == 0:
        return False
    k0 = np.searchsorted(interval_t, t0, side="right") - 1
    k1 = np.searchsorted(interval_t, t1, side="right") - 1
    k0 = min(max(k0, 0), n - 1)
    k1 = min(max(k1, 0), n - 1)
    for k in range(k0, k1 + 1):
        if motion[k, pixel]:
            return True
    return False


@njit(cache=True, nogil=True)
def pixel_runs(t, pixel, n_pixels, gap_us, interval_t, motion, out_interval, out_passage):
    """One window's events, sorted by time: t (N,) int64 us, pixel (N,) int64 = y * width + x.

    out_interval[i] gets t[i] minus the time of the previous event at the same pixel (us), NO_INTERVAL for the
    pixel's first event. A passage is a maximal run of a pixel's events whose successive intervals are <= gap_us,
    counted only where the frames saw the pixel change during it (_moving); out_passage[:n] gets the event count of
    each of the n passages, n returned. motion: (F - 1, n_pixels) bool, interval_t: (F,) int64 (F may be 0 or 1:
    no passage is counted then).
    """
    last = np.empty(n_pixels, np.int64)
    first = np.empty(n_pixels, np.int64)
    count = np.zeros(n_pixels, np.int64)
    n_out = 0
    for i in range(t.size):
        p = pixel[i]
        ti = t[i]
        if count[p] > 0:
            dt = ti - last[p]
            out_interval[i] = dt
            if dt > gap_us:
                if _moving(first[p], last[p], p, interval_t, motion):
                    out_passage[n_out] = count[p]
                    n_out += 1
                count[p] = 0
        else:
            out_interval[i] = NO_INTERVAL
        if count[p] == 0:
            first[p] = ti
        count[p] += 1
        last[p] = ti
    for p in range(n_pixels):
        if count[p] > 0 and _moving(first[p], last[p], p, interval_t, motion):
            out_passage[n_out] = count[p]
            n_out += 1
    return n_out
