"""Pixel classes of a recording without frames, read from its events alone: quiet pixels (no signal near them, so
their events are noise) and hot pixels (firing far above the quiet rate).

Without frames nothing says where the scene changed; what marks signal is that it is correlated in space: a moving
edge fires every pixel along it, noise fires pixels independently. So a pixel is quiet when the events of its
neighbourhood are as few as noise alone would give. Steps, on the per-pixel event counts (ON + OFF) over the scored
windows:

1. Hot pixels: count >= max(HOT_MIN_EVENTS, HOT_FACTOR x the noise floor (mean count per quiet pixel)) while the
   other pixels of the box around it (step 2) fire no more than noise (the bound of step 3; other such pixels
   counted at the floor, at most HOT_MAX_IN_BOX of them in the box): an isolated pixel, not a part of a moving
   edge. Their counts are replaced by the floor before step 2, so a hot pixel does not hide its
   neighbours.
2. Activity: the mean count over the (2 ACTIVITY_RADIUS_PX + 1)^2 box around each pixel.
3. Quiet: every pixel within QUIET_RADIUS_PX (Chebyshev) of it has an activity at most the Poisson quantile
   1 - QUIET_FALSE_ALARM of the box's count under the floor (noise alone exceeds it that rarely), divided by the box's
   pixels.
The floor starts at the FLOOR_START_QUANTILE quantile of the activity (a scene rarely moves over all of the sensor)
and is then the mean count of the quiet, not hot pixels; steps 1-3 are repeated ITERATIONS times. Pixels that are
never quiet (a busy recording) leave the quiet class empty: no noise rate is then measured.

Events alone do not tell dark pixels (no intensity) or passages (no frame saw a pixel change): FrameMasks of events
have no dark pixels and no motion.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage, stats

from .masks import FrameMasks

HOT_FACTOR = 50.0  # a pixel firing this many times the quiet mean count (and >= HOT_MIN_EVENTS) is hot
HOT_MIN_EVENTS = 10
HOT_MAX_IN_BOX = 3  # at most this many candidates in a box are hot pixels; more are a part of the scene
ACTIVITY_RADIUS_PX = 4  # activity: mean count over a 9x9 box
QUIET_RADIUS_PX = 2  # quiet: every pixel within this distance has a low activity (as the frames' quiet pixels)
QUIET_FALSE_ALARM = 1e-3  # noise alone puts a box above the quiet bound this rarely
FLOOR_START_QUANTILE = 20.0  # percentile of the activity the noise floor starts at
ITERATIONS = 4


@dataclass(frozen=True)
class QuietPixels:
    """Quiet and hot pixels found from the events (see the module).

    Attributes
    ----------
    quiet : numpy.ndarray
        (H, W) bool: quiet pixels (hot ones included: the class is a place, not a rate).
    hot : numpy.ndarray
        (H, W) bool: hot pixels (among the quiet ones: elsewhere a hot pixel and signal look alike).
    floor_count : float
        Mean events per quiet, not hot pixel over the windows.
    bound_count : float
        The activity (mean events per pixel of the box) above which a box is not quiet.
    """

    quiet: np.ndarray
    hot: np.ndarray
    floor_count: float
    bound_count: float

    @property
    def quiet_cold(self) -> np.ndarray:
        """(H, W) bool: quiet pixels that are not hot."""
        return self.quiet & ~self.hot


def quiet_pixels(counts: np.ndarray) -> QuietPixels:
    """The quiet and hot pixels of per-pixel event counts (see the module).

    Parameters
    ----------
    counts : numpy.ndarray
        (H, W) events per pixel (ON + OFF) over the scored windows, or (2, H, W) ON and OFF counts (summed).

    Returns
    -------
    QuietPixels
        The pixel classes.
    """
    c = np.asarray(counts, dtype=np.float64)
    if c.ndim == 3:
        c = c.sum(axis=0)
    side = 2 * ACTIVITY_RADIUS_PX + 1
    n_box = side * side
    floor = float(np.percentile(ndimage.uniform_filter(c, side, mode="nearest"), FLOOR_START_QUANTILE))
    quiet = np.ones(c.shape, bool)
    hot = np.zeros(c.shape, bool)
    bound = 0.0
    for _ in range(ITERATIONS):
        bound = float(stats.poisson.ppf(1.0 - QUIET_FALSE_ALARM, max(floor, 1e-9) * n_box)) / n_box
        # hot: far above the floor, amid neighbours that fire no more than noise (the box's other candidates, at
        # most HOT_MAX_IN_BOX of them, counted at the floor)
        candidate = c >= max(HOT_MIN_EVENTS, HOT_FACTOR * floor)
        capped = np.where(candidate, floor, c)
        others = (ndimage.uniform_filter(capped, side, mode="nearest") * n_box - capped) / (n_box - 1)
        crowd = ndimage.uniform_filter(candidate.astype(np.float64), side, mode="nearest") * n_box
        hot = candidate & (others <= bound + 1e-9) & (crowd <= HOT_MAX_IN_BOX + 0.5)
        activity = ndimage.uniform_filter(np.where(hot, floor, c), side, mode="nearest")
        low = activity <= bound + 1e-9
        quiet = ndimage.minimum_filter(low.astype(np.uint8), size=2 * QUIET_RADIUS_PX + 1, mode="nearest") > 0
        cold = quiet & ~hot
        if not cold.any():
            break
        floor = float(c[cold].mean())
    return QuietPixels(quiet, hot & quiet, floor, bound)


def event_masks(counts: np.ndarray) -> FrameMasks:
    """FrameMasks of a recording without frames, from its per-pixel event counts (see the module): static and quiet
    are the quiet pixels, no pixel is dark, no motion (no passage is counted), source "events".

    Parameters
    ----------
    counts : numpy.ndarray
        (2, H, W) ON and OFF events per pixel over the scored windows (or (H, W) their sum).

    Returns
    -------
    FrameMasks
        The pixel classes.
    """
    q = quiet_pixels(counts)
    h, w = q.quiet.shape
    return FrameMasks(static=q.quiet, quiet=q.quiet, dark=np.zeros((h, w), bool), motion=np.zeros((0, h * w), bool),
                      frame_t_us=np.zeros(0, np.int64), median_dn=np.zeros((h, w), np.float32),
                      change_dn=float("nan"), read_noise_dn=float("nan"), frames_used=0, source="events",
                      hot=q.hot)
