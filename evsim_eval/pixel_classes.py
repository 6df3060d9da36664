"""Pixel and time classes of a scored reconstruction, so that a score can say where each method wins.

Pixel classes of a scored time t, from the two input frames nearest to it (the last whose mid-exposure is <= t
and the first whose mid-exposure is >= t; one frame when t is at or beyond a frame):
- "high": clipped high in either frame: response within CLIP_MARGIN_DN digital numbers of the top of the CRF's
  invertible range (y >= y_hi - margin): the frames saw only that the scene was at least this bright;
- "low": not high, and within CLIP_MARGIN_DN of the bottom (y <= y_lo + margin) in either frame: under-exposed;
- "well": neither (well-exposed in both frames): where the frames alone are good.
And a split of the truth's local structure, independent of the first: "flat" where the truth, mapped to [0, 1]
by clip(I / white, 0, 1), has a local standard deviation below FLAT_STD over the 7x7 SSIM window, "textured"
elsewhere.
Range classes (RANGE_CLASSES, a partition of every scored time's pixels by the truth alone, range_classes): the
truth against the range of x the input frames can record, [lo, hi] in frame 0's x units
(evsim_eval.scoring.frames_range:
CRF^-1(0) and CRF^-1(1) times the smallest and the largest exposure gain T_0 / T_k): "below_range" where the truth
is below lo (darker than any frame's floor), "in_range" inside [lo, hi], "above_range" above hi (brighter than any
frame can record: only the events can tell it).
Time classes (every pixel of a scored time): "at_frames" when t lies inside an input frame's exposure window
[t_start, t_end], "between" otherwise (a frames-only method has not seen the scene then).
Class scores pool every pixel of the class over the scored times (evsim_eval.metrics.score_map, SSIM maps
SSIM_MARGIN pixels in from the border) and report the class's share of the scored pixels.

References (docs/models/references.md): Wang et al. 2004 [Wang2004], SSIM.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy.ndimage import uniform_filter

from .metrics import SSIM_MARGIN, SSIM_WINDOW, to_unit_range

if TYPE_CHECKING:
    import numpy.typing as npt

    from crf_models import CRF

__all__ = ["PIXEL_CLASSES", "RANGE_CLASSES", "TIME_CLASSES", "CLASSES", "CLIP_MARGIN_DN", "FLAT_STD",
           "nearest_frames", "pixel_classes", "range_classes", "time_classes", "valid_region"]

PIXEL_CLASSES = ("well", "high", "low", "flat", "textured")  # well/high/low partition; flat/textured too
RANGE_CLASSES = ("below_range", "in_range", "above_range")  # the truth below / inside / above the frames' range
TIME_CLASSES = ("at_frames", "between")  # scored times inside / outside an input frame's exposure
CLASSES = PIXEL_CLASSES + RANGE_CLASSES + TIME_CLASSES  # every class a score is split by
CLIP_MARGIN_DN = 2  # a response this close to an end of the CRF's range counts as clipped (noise, quantisation)
FLAT_STD = 0.02  # local standard deviation of the [0, 1] truth below which it is flat


def nearest_frames(frame_mid_us: npt.ArrayLike, t_us: int) -> tuple[int, int]:
    """Indices (before, after) of the frames nearest to t_us by mid-exposure time: the last at or before t and the
    first at or after (the same frame at t, and the end frame beyond either end).

    Parameters
    ----------
    frame_mid_us : array_like
        The frames' mid-exposure times, ascending int64 us.
    t_us : int
        The scored time (us).

    Returns
    -------
    before, after : int
        The frame indices.
    """
    mid = np.asarray(frame_mid_us, np.int64)
    after = int(np.searchsorted(mid, t_us, side="left"))
    before = int(np.searchsorted(mid, t_us, side="right")) - 1
    last = mid.size - 1
    return min(max(before, 0), last), min(max(after, 0), last)


def pixel_classes(before: npt.ArrayLike, after: npt.ArrayLike, crf: CRF, bit_depth: int, truth: npt.ArrayLike,
                  white: float) -> dict[str, npt.NDArray[np.bool_]]:
    """{class: (H, W) bool mask} of PIXEL_CLASSES for one scored time (see the module).

    Parameters
    ----------
    before, after : array_like
        (H, W) the nearest input frames (digital numbers).
    crf : CRF
        The frames' response curve.
    bit_depth : int
        The frames' bits.
    truth : array_like
        (H, W) the reference, linear intensity (x units).
    white : float
        Its [0, 1] white (x units).

    Returns
    -------
    dict
        {class: (H, W) bool mask} for "well", "high", "low" (a partition) and "flat", "textured" (another).
    """
    full = float((1 << bit_depth) - 1)
    margin = CLIP_MARGIN_DN / full
    y = [np.asarray(f, np.float64) / full for f in (before, after)]
    high = (y[0] >= crf.y_hi - margin) | (y[1] >= crf.y_hi - margin)
    low = ~high & ((y[0] <= crf.y_lo + margin) | (y[1] <= crf.y_lo + margin))
    u = to_unit_range(truth, white)
    mean = uniform_filter(u, SSIM_WINDOW, mode="reflect")
    var = np.maximum(uniform_filter(u * u, SSIM_WINDOW, mode="reflect") - mean**2, 0.0)
    flat = var < FLAT_STD**2
    return {"well": ~high & ~low, "high": high, "low": low, "flat": flat, "textured": ~flat}


def range_classes(truth: npt.ArrayLike, lo: float, hi: float) -> dict[str, npt.NDArray[np.bool_]]:
    """The truth against the range the input frames can record.

    Parameters
    ----------
    truth : array_like
        (H, W) reference of one scored time, linear intensity (x units of frame 0's exposure).
    lo, hi : float
        The range of x the input frames can record (x units; evsim_eval.scoring.frames_range).

    Returns
    -------
    dict
        {class: (H, W) bool mask} of RANGE_CLASSES, a partition: "below_range" truth < lo, "in_range"
        lo <= truth <= hi, "above_range" truth > hi.
    """
    truth = np.asarray(truth, np.float64)
    below, above = truth < lo, truth > hi
    return {"below_range": below, "in_range": ~below & ~above, "above_range": above}


def time_classes(t_us: int, frame_t_start_us: npt.ArrayLike, frame_t_end_us: npt.ArrayLike) -> str:
    """The time class of t_us: at_frames when it lies inside an input frame's exposure window, else between.

    Parameters
    ----------
    t_us : int
        The scored time (us).
    frame_t_start_us, frame_t_end_us : array_like
        The input frames' exposure windows (int64 us).

    Returns
    -------
    str
        "at_frames" or "between".
    """
    inside = (np.asarray(frame_t_start_us) <= t_us) & (t_us <= np.asarray(frame_t_end_us))
    return "at_frames" if inside.any() else "between"


def valid_region(shape: tuple[int, int], ssim: bool) -> npt.NDArray[np.bool_]:
    """Where a score map counts: everywhere, or SSIM_MARGIN pixels in from the border for an SSIM map.

    Parameters
    ----------
    shape : tuple of int
        (H, W), pixels.
    ssim : bool
        An SSIM map (its border is left out).

    Returns
    -------
    numpy.ndarray
        (H, W) bool mask.
    """
    valid = np.zeros(shape, bool)
    m = SSIM_MARGIN if ssim else 0
    valid[m:shape[0] - m, m:shape[1] - m] = True
    return valid
