"""Per-pixel contrast thresholds from the event counts of a pixel and its neighbours (not in the paper).

A DVS pixel's ON and OFF thresholds differ from the nominal ones by a few tens of percent (threshold mismatch;
sim.DVSParams.threshold_sigma), and the AKF integrates every event with the threshold it assumes. Where frames
measure a pixel, the eq. 12 calibration corrects it (akf.augmentation.ContrastCalibration); where every frame is
clipped, nothing does, and the error grows with the number of events: on the AHDR pan of the real HDR photo Desk
(davis346 sensor) a pixel of the stained-glass window with an ON threshold of 0.108 instead of 0.2 fired 107 ON and
54 OFF events for a true log change of -0.55, which the nominal thresholds read as +10.6 log (4e4 x).

Neighbouring pixels watching a moving scene see about the same total log change up and down over a sequence, so a
pixel's count relative to its neighbourhood's measures its threshold (applied where the frames clip the pixel in at
least half of them, MOSTLY_CLIPPED: elsewhere the frames correct the mismatch): c_p = c * (m_p + k) / (n_p + k),
where n_p is the pixel's ON (OFF) count over the whole input, m_p the mean count of its SIZE x SIZE neighbourhood
(itself included) and k = PRIOR_COUNT shrinks pixels with few events toward the nominal threshold. The ratio is
clipped to the AKF's accepted calibration range (AKFParams.calib_scale_range). On that Desk sequence the estimate
correlates 0.75 (ON) and 0.81 (OFF) with the true per-pixel thresholds, and the mean error of the net event change
of the always-bright pixels falls from 1.81 log (nominal) to 0.84 (0.66 with the true thresholds). This is a flat-
field correction of the event stream (as is done for the fixed-pattern gain of image sensors) that needs no frame;
it assumes the counts differ between neighbours by their thresholds, not by what they saw, which holds for motion
over texture and fails at a lone edge that only some pixels of the neighbourhood see move (there the prior count and
the clip bound it). """

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy.ndimage import uniform_filter

from .inputs import contrast_maps

if TYPE_CHECKING:
    import numpy.typing as npt

    from crf_models import CRF

    from .params import AKFParams

__all__ = ["SIZE", "PRIOR_COUNT", "MOSTLY_CLIPPED", "count_scales", "flat_field_scales", "thresholds"]

SIZE = 5  # pixels: the neighbourhood whose mean count stands for what the pixel saw
PRIOR_COUNT = 10.0  # events: a pixel with this many events is half its own count, half its neighbourhood's
#: the share of the frames in which a pixel is clipped from which its thresholds are flat-fielded: below it, the
#: frames measure the pixel often enough for the eq. 12 calibration and the frame update to correct the mismatch
#: (on the real DAVIS346 road recording, flat-fielding every pixel cost 3 % of mse01)
MOSTLY_CLIPPED = 0.5


def count_scales(events: np.ndarray, shape: tuple[int, int], scale_range: tuple[float, float]
                 ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(ON, OFF) threshold scale of every pixel (flat, y * W + x): (m + PRIOR_COUNT) / (n + PRIOR_COUNT) of its own
    count n and its neighbourhood's mean m (see the module), clipped to scale_range; 1 everywhere without events.

    Parameters
    ----------
    events : numpy.ndarray
        sim.EVENT_DTYPE events (the whole input).
    shape : tuple of int
        (H, W), pixels.
    scale_range : tuple of float
        (lowest, highest) scale (AKFParams.calib_scale_range).

    Returns
    -------
    on, off : numpy.ndarray
        float64 (H W,) threshold scales (dimensionless), flat.
    """
    h, w = shape
    scales = []
    for on in (True, False):
        sel = events["p"] > 0 if on else events["p"] < 0
        n = np.bincount(events["y"][sel].astype(np.int64) * w + events["x"][sel], minlength=h * w).astype(np.float64)
        m = uniform_filter(n.reshape(h, w), SIZE, mode="reflect").ravel()
        scales.append(np.clip((m + PRIOR_COUNT) / (n + PRIOR_COUNT), *scale_range))
    return scales[0], scales[1]


def flat_field_scales(events: np.ndarray, frames: npt.ArrayLike, full_scale: int, crf: CRF,
                      scale_range: tuple[float, float]) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(ON, OFF) threshold scale of every pixel (flat): count_scales where the pixel is clipped (its response at or
    beyond an end of the CRF's invertible range [crf.y_lo, crf.y_hi], within one DN) in at least MOSTLY_CLIPPED of
    the frames, 1 elsewhere.

    Parameters
    ----------
    events : numpy.ndarray
        sim.EVENT_DTYPE events (the whole input).
    frames : array_like
        (N, H, W) raw responses, up to full_scale.
    full_scale : int
        The frames' largest raw value (2^bits - 1).
    crf : CRF
        The frames' response curve.
    scale_range : tuple of float
        (lowest, highest) scale (AKFParams.calib_scale_range).

    Returns
    -------
    on, off : numpy.ndarray
        float64 (H W,) threshold scales (dimensionless), flat.
    """
    frames = np.asarray(frames)
    step = 1.0 / float(full_scale)
    count = np.zeros(frames.shape[1] * frames.shape[2], np.int64)
    for frame in frames:  # one frame's responses at a time: no (N, H, W) float copy
        y = frame.ravel() / float(full_scale)
        count += (y <= crf.y_lo + step) | (y >= crf.y_hi - step)
    clipped = count / frames.shape[0] >= MOSTLY_CLIPPED
    on, off = count_scales(events, frames.shape[1:], scale_range)
    return np.where(clipped, on, 1.0), np.where(clipped, off, 1.0)


def thresholds(contrast: npt.ArrayLike, events: np.ndarray, frames: npt.ArrayLike, full_scale: int, crf: CRF,
               params: AKFParams) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The (ON, OFF) thresholds (log, flat maps) the AKF integrates a sensor's events with: the contrast as given
    (akf.inputs.contrast_maps), scaled by flat_field_scales when params.flat_field and the contrast is a scalar or an
    (ON, OFF) pair (per-pixel maps are taken as they are).

    Parameters
    ----------
    contrast : array_like
        Nominal log contrast threshold(s): a scalar, (c_on, c_off) or (2, H, W) maps (c_off as a magnitude).
    events, frames, full_scale, crf
        As flat_field_scales'.
    params : AKFParams
        The filter's parameters (flat_field, calib_scale_range).

    Returns
    -------
    c_on, c_off : numpy.ndarray
        float64 (H W,) thresholds (log units, OFF as a magnitude), flat.
    """
    frames = np.asarray(frames)
    c_on, c_off = contrast_maps(contrast, frames.shape[1:])
    if params.flat_field and np.ndim(contrast) < 2:
        on, off = flat_field_scales(events, frames, full_scale, crf, params.calib_scale_range)
        c_on, c_off = c_on * on, c_off * off
    return c_on, c_off
