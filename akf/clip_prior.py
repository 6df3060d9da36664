"""The level of pixels no frame has measured yet, from the pixels clipped on the same side that a frame did measure
(not in the paper).

A pixel clipped since the first frame has never been measured: its events give only changes, and the one-sided
rule of the filter (akf.kernels.propagate_one_sided) keeps its estimate at the clip level or beyond, so the
estimate is a bound (a lower bound for a pixel clipped high, an upper bound for one clipped low), not a level.
The pixels of the picture between two frames clipped on that side that an earlier frame measured do have a
level (their events carried it across the clip level): their levels beyond the clip are a sample of what
lies beyond it in this scene. Each never-measured pixel takes the median of the sampled levels beyond its own
bound (the conditional median of the truth given the bound, under the sample's distribution); where no sampled
level lies beyond its bound, or the sample is smaller than MIN_SAMPLE pixels, it keeps its bound. The order of the
never-measured pixels' estimates is kept (the conditional median is non-decreasing in the bound).

This treats the clipped response as a censored observation (Tobit: Tobin 1958 [Tobin1958]; in Kalman filtering
Allik et al. 2016 [Allik2016]), with the prior of the censored values taken from the measured ones of the same
picture instead of a parametric one.

References (docs/models/references.md): Tobin 1958 [Tobin1958]; Allik et al. 2016 [Allik2016].
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .smoothing import finite_log

if TYPE_CHECKING:
    import numpy.typing as npt

__all__ = ["MIN_SAMPLE", "conditional_median", "fill_unmeasured"]

#: pixels: the fewest measured clipped pixels (a 5 x 5 patch) whose levels stand for what lies beyond a picture's clip
MIN_SAMPLE = 25


def conditional_median(bounds: npt.ArrayLike, sample: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """For each lower bound b, the median of the sample values >= b (the upper median of an even count), or b itself
    where no sample value reaches it. Non-decreasing in b, and never below b.

    Parameters
    ----------
    bounds : array_like
        Lower bounds (any shape; log units where the clip prior uses it).
    sample : array_like
        The sample values, same units (any shape).

    Returns
    -------
    numpy.ndarray
        float64 conditional medians of bounds' shape.
    """
    bounds = np.asarray(bounds, np.float64)
    s = np.sort(np.asarray(sample, np.float64).ravel())
    i = np.searchsorted(s, bounds, side="left")
    n = s.size
    if n == 0:
        return bounds.copy()
    q = s[np.minimum((i + n) // 2, n - 1)]
    return np.where(i < n, np.maximum(q, bounds), bounds)


def fill_unmeasured(intensity: npt.NDArray[np.float32], i0: float, side: npt.NDArray[np.float64],
                    measured: npt.NDArray[np.bool_]) -> None:
    """In place, for an image I (x units, any shape) with log L = log(I + i0): every pixel on a clip side (side +1:
    both frames of its interval clipped high, -1: low, 0 otherwise) that no frame has measured (measured False) takes
    the conditional median (conditional_median) of the log levels of the pixels on the same side that a frame has
    measured, beyond its own bound (above it for +1, below for -1); nothing changes where fewer than MIN_SAMPLE
    such measured pixels exist.

    Parameters
    ----------
    intensity : numpy.ndarray
        float32 image I (x units, any shape), changed in place.
    i0 : float
        The log offset (x units).
    side : numpy.ndarray
        The pixels' clip side (+1, -1 or 0), of intensity's shape.
    measured : numpy.ndarray
        bool, of intensity's shape: a frame has measured the pixel.
    """
    for s in (1.0, -1.0):
        on = side == s
        sample = on & measured
        unknown = on & ~measured
        if not unknown.any() or np.count_nonzero(sample) < MIN_SAMPLE:
            continue
        # on the low side the bound is an upper one: the same rule on -L
        level = s * conditional_median(s * finite_log(intensity[unknown], i0), s * finite_log(intensity[sample], i0))
        intensity[unknown] = (np.exp(level) - i0).astype(intensity.dtype)
