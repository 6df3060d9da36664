"""Confidence-weighted edge-preserving smoothing of the AKF's published images (not in the paper).

Where no frame measures a pixel (clipped frames), its estimate is the integral of its own events, and neighbouring
pixels of a flat surface disagree by up to a contrast threshold or more (each pixel's reference level sits at its
own phase within a threshold, and bandwidth-limited or mismatched pixels under- or over-report): event speckle.
A bilateral filter (Tomasi and Manduchi 1998) of the log image with a range sigma of a few thresholds averages
that speckle while keeping edges larger than it; each pixel takes the filtered value with the weight
max(0, 1 - floor / P), P its state variance (log^2), the floor infinite where the last frame measured the pixel
(akf.reconstruct): a pixel a well-exposed frame has measured keeps its value exactly, an uncertain pixel no frame
measures takes its neighbourhood's, never crossing the level of the clipped frame (the truth lies beyond it).

References (docs/models/references.md): Tomasi and Manduchi 1998 [Tomasi1998], the bilateral filter; Bradski 2000
[Bradski2000], OpenCV (cv2.bilateralFilter).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

DIAMETER = 5  # pixels: the bilateral filter's window (5 x 5)
SPATIAL_SIGMA = 1.5  # pixels: the bilateral filter's spatial Gaussian
#: log: the largest range sigma akf.reconstruct smooths a pixel with when the next frame measures it (it sits at the
#: edge of a clipped area, where things move in and out): on the DAVIS346 road recording a range of 4 log there
#: raised mse01 by 0.7 %, while the pixels between two clipped frames gain from it on the AHDR photos
EDGE_RANGE = 1.0
#: the largest intensity (x) taken as is: an estimate run out of float32 range (a hot pixel integrated where every
#: frame is clipped) counts as this, so the filter's window never meets an infinity (NaN)
LARGEST = float(np.finfo(np.float32).max) / 2


def finite_log(intensity: npt.ArrayLike, i0: float) -> npt.NDArray[np.float64]:
    """log(I + i0) in float64, finite: an estimate run out of float32 range counts as LARGEST (x units)."""
    return np.log(np.clip(np.asarray(intensity, np.float64) + i0, i0 * 1e-3, LARGEST))


def smooth_uncertain(intensity: npt.NDArray[np.float32], variance: npt.NDArray[np.float32], i0: float,
                     range_sigma: float, variance_floor: npt.NDArray[np.float32], low: npt.NDArray[np.float32],
                     high: npt.NDArray[np.float32]) -> None:
    """In place, for an (H, W) image I = exp(L) - i0 (x units) with state variance P (log^2): L <- L + w (B(L) - L),
    B the bilateral filter of L (range_sigma in log units, DIAMETER x DIAMETER window, SPATIAL_SIGMA pixels), w =
    max(0, 1 - variance_floor / P) (variance_floor: (H, W) log^2, > 0, inf: never smoothed), the result kept within
    [min(low, L), max(high, L)] (log; the levels of clipped frames the truth lies beyond)."""
    import cv2

    log = np.log(np.clip(intensity + np.float32(i0), i0 * 1e-3, LARGEST)).astype(np.float32)  # finite
    smooth = cv2.bilateralFilter(log, DIAMETER, float(range_sigma), SPATIAL_SIGMA, borderType=cv2.BORDER_REFLECT)
    w = np.maximum(np.float32(1) - variance_floor / np.maximum(variance, np.float32(1e-30)), np.float32(0))
    on = w > 0  # the other pixels keep their value bit for bit
    lo, hi = np.minimum(low[on], log[on]), np.maximum(high[on], log[on])
    intensity[on] = np.exp(np.clip(log[on] + w[on] * (smooth[on] - log[on]), lo, hi)) - np.float32(i0)
