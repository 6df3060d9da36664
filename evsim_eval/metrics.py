"""Image quality metrics for HDR reconstructions, and how each one normalises its inputs.

- log_rmse: the full-range error, on every pixel however bright: the root mean square of
  ln(max(I, f)) - ln(max(R, f)) (natural log, reconstruction I, reference R), with the floor
  f = LOG_FLOOR_FRACTION (1e-3) times `top`, the largest x the input frames can record (given by the caller:
  CRF^-1(1) times the largest exposure gain T_0 / T_k, evsim_eval.scoring.frames_range), so that values too dark for any
  frame to tell apart count alike and a ratio error counts the same in the shadows and in the highlights.
- mse / psnr: on the raw linear intensities as given (no tone mapping, no rescaling). psnr uses
  data_range = reference max unless given: PSNR = 10 log10(data_range^2 / MSE).
- ssim: skimage.metrics.structural_similarity on the raw intensities with an explicit data_range (default: the
  reference's max - min), 7x7 uniform window (skimage's default), float64.
- PU21 (Mantiuk & Azimi, PCS 2021): intensities are first mapped to absolute luminance Y = s * I in cd/m^2, one
  scale s for the reconstruction and the reference: s = PU21_WHITE (100 cd/m^2 per x: I = 1 is SDR reference
  white) while the reference's max is at most PU21_Y_MAX / PU21_WHITE = 100 x, else s = PU21_Y_MAX / (the
  reference's max), so that the reference's brightest pixel maps to 10000 cd/m^2, the top of PU21's range, and no
  part of the reference is clamped (pu21_luminance_scale). Y is clamped to [0.005, 10000] cd/m^2 and encoded with
  the 'banding_glare' PU21 curve (100 cd/m^2 -> about 256); pu21_psnr uses a peak of 256 (the encoded value of
  100 cd/m^2, as in the authors' pu_psnr) and pu21_ssim a data_range of 256.
- mse01 / ssim01: the AKF paper's protocol, clipped at the white. Reconstruction and reference are both brought to
  [0, 1] by one rule, v = clip(I / white, 0, 1), with `white` the intensity that maps to 1 (given by the caller:
  for AHDR data the radiance the generator recorded as white, at most what the methods reach, for held-out frames
  CRF^-1(1)); SSIM with data_range 1. Whatever lies above the white scores as the white: kept for parity with the
  paper's numbers, not a full-range score.
- log_mse: mean squared difference of log(I + LOG_EPS) (natural log, LOG_EPS = 1e-3 x units, the AKF's I0) on
  absolute values: errors of highlights and shadows count by ratio, not by absolute size.
Every metric's normalisation in one line is NORMALISATION[name]; score() applies any metric by name, with the
white (NEEDS_WHITE) or the frames' top (NEEDS_TOP) it needs. Every metric takes two real-valued (H, W) images of
one shape, finite and >= 0 (linear intensities; anything else raises EvsimInputError naming the image), and its
parameters (data_range, white, top, luminance_scale) finite and > 0.

References (docs/models/references.md): Mantiuk and Azimi 2021 [Mantiuk2021], PU21; Wang et al. 2004 [Wang2004], SSIM;
van der Walt et al. 2014 [vanderWalt2014], scikit-image; Wang et al. 2021 [Wang2021], the AKF paper's protocol; Narwaria
et al. 2015 [Narwaria2015], HDR-VDP-2.2.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from skimage.metrics import structural_similarity

from sim.errors import EvsimInputError, check_number, check_real_array

if TYPE_CHECKING:
    import numpy.typing as npt

# PU21 'banding_glare' parameters p1..p7 (Mantiuk & Azimi 2021, pu21_encoder.m)
PU21_PARAMS = (0.353487901, 0.3734658629, 8.277049286e-05, 0.9062562627, 0.09150303166, 0.9099517204, 596.3148142)
PU21_Y_MIN, PU21_Y_MAX = 0.005, 10000.0
PU21_PEAK = 256.0
#: cd/m^2 per x of the PU21 metrics while the reference's max is at most PU21_Y_MAX / PU21_WHITE = 100 x (x = 1
#: is SDR reference white, 100 cd/m^2)
PU21_WHITE = 100.0


def _pair(x: npt.ArrayLike, ref: npt.ArrayLike) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Both images as float64, checked: real-valued (H, W) of one shape, finite and >= 0 (linear intensities)."""
    x = check_real_array("the image", x)
    ref = check_real_array("the reference", ref)
    if x.shape != ref.shape or x.ndim != 2:
        raise EvsimInputError(f"metrics need two (H, W) images of the same shape, got {x.shape} and {ref.shape}")
    for name, img in (("the image", x), ("the reference", ref)):
        if not np.all(np.isfinite(img)):
            raise EvsimInputError(f"metrics need finite images: {name} holds NaN or infinite values")
        if img.size and img.min() < 0:
            row, col = (int(i) for i in np.unravel_index(int(np.argmin(img)), img.shape))
            raise EvsimInputError(f"metrics need linear intensities >= 0: {name} has {img.min():.4g} at row {row}, "
                                  f"column {col}")
    return x, ref


def mse(x: npt.ArrayLike, ref: npt.ArrayLike) -> float:
    """Mean squared error of the raw intensities.

    Parameters
    ----------
    x, ref : array_like
        Reconstruction and reference, (H, W) linear intensity (x units), >= 0.

    Returns
    -------
    float
        The MSE (x units squared).
    """
    x, ref = _pair(x, ref)
    return float(np.mean((x - ref) ** 2))


def psnr(x: npt.ArrayLike, ref: npt.ArrayLike, data_range: float | None = None) -> float:
    """PSNR (dB) = 10 log10(data_range^2 / MSE); data_range defaults to the reference's max.

    Parameters
    ----------
    x, ref : array_like
        Reconstruction and reference, (H, W) linear intensity (x units), >= 0.
    data_range : float, optional
        The peak (x units), > 0; default the reference's max.

    Returns
    -------
    float
        PSNR in dB (inf for identical images).
    """
    x, ref = _pair(x, ref)
    peak = float(ref.max()) if data_range is None else check_number("data_range", data_range, positive=True)
    err = mse(x, ref)
    return float("inf") if err == 0 else float(20 * np.log10(peak) - 10 * np.log10(err))  # no overflow of peak**2


def ssim(x: npt.ArrayLike, ref: npt.ArrayLike, data_range: float | None = None) -> float:
    """SSIM (Wang et al. 2004 [Wang2004]) with data_range defaulting to the reference's max - min.

    Parameters
    ----------
    x, ref : array_like
        Reconstruction and reference, (H, W) linear intensity (x units), >= 0.
    data_range : float, optional
        The range (x units), > 0; default the reference's max - min (a constant reference raises EvsimInputError).

    Returns
    -------
    float
        Mean SSIM, 1 for identical images.
    """
    x, ref = _pair(x, ref)
    rng = (float(ref.max() - ref.min()) if data_range is None
           else check_number("data_range", data_range, positive=True))
    if rng <= 0:
        raise EvsimInputError("ssim needs a positive data_range (the reference is constant)")
    return float(structural_similarity(x, ref, data_range=rng))


def pu21_encode(luminance: npt.ArrayLike) -> npt.NDArray[np.float64] | np.float64:
    """PU21 encoding of absolute luminance (cd/m^2): V = p7 * (((p1 + p2 Y^p4) / (1 + p3 Y^p4))^p5 - p6), with Y
    clamped to [0.005, 10000] and V clipped at 0.

    Parameters
    ----------
    luminance : array_like
        Absolute luminance Y (cd/m^2).

    Returns
    -------
    numpy.ndarray or numpy.float64
        PU21 values V of luminance's shape (100 cd/m^2 encodes to about 256).
    """
    p1, p2, p3, p4, p5, p6, p7 = PU21_PARAMS
    y = np.clip(np.asarray(luminance, np.float64), PU21_Y_MIN, PU21_Y_MAX)
    yp = y**p4
    return np.maximum(p7 * (((p1 + p2 * yp) / (1 + p3 * yp)) ** p5 - p6), 0.0)


def pu21_luminance_scale(ref: npt.ArrayLike) -> float:
    """The PU21 metrics' luminance scale of a reference image.

    Parameters
    ----------
    ref : array_like
        The reference image, linear intensity (x units), >= 0.

    Returns
    -------
    float
        Luminance per unit intensity, cd/m^2 per x: PU21_WHITE (100) when the reference's max is at most
        PU21_Y_MAX / PU21_WHITE (100 x), else PU21_Y_MAX / max, which maps the reference's max to 10000 cd/m^2,
        the top of PU21's range (Mantiuk & Azimi 2021), so that no part of the reference is clamped.
    """
    top = float(np.max(ref)) if np.size(ref) else 0.0
    return PU21_WHITE if top * PU21_WHITE <= PU21_Y_MAX else PU21_Y_MAX / top


def _pu21_pair(x: npt.ArrayLike, ref: npt.ArrayLike, luminance_scale: float | None
               ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Both images PU21-encoded with one scale: luminance_scale, or pu21_luminance_scale(ref) when None."""
    x, ref = _pair(x, ref)
    scale = (pu21_luminance_scale(ref) if luminance_scale is None
             else check_number("luminance_scale", luminance_scale, positive=True))
    return pu21_encode(scale * x), pu21_encode(scale * ref)


def pu21_psnr(x: npt.ArrayLike, ref: npt.ArrayLike, luminance_scale: float | None = None) -> float:
    """PSNR of the PU21-encoded images (peak 256), after Y = luminance_scale * I.

    Parameters
    ----------
    x, ref : array_like
        Reconstruction and reference, (H, W) linear intensity (x units), >= 0.
    luminance_scale : float, optional
        cd/m^2 per x; default pu21_luminance_scale(ref) (100, or less for a reference above 100 x).

    Returns
    -------
    float
        PSNR in dB (inf for identical images).
    """
    return psnr(*_pu21_pair(x, ref, luminance_scale), data_range=PU21_PEAK)


def pu21_ssim(x: npt.ArrayLike, ref: npt.ArrayLike, luminance_scale: float | None = None) -> float:
    """SSIM of the PU21-encoded images (data_range 256), after Y = luminance_scale * I.

    Parameters
    ----------
    x, ref : array_like
        Reconstruction and reference, (H, W) linear intensity (x units), >= 0.
    luminance_scale : float, optional
        cd/m^2 per x; default pu21_luminance_scale(ref) (100, or less for a reference above 100 x).

    Returns
    -------
    float
        Mean SSIM (Wang et al. 2004), 1 for identical images.
    """
    return ssim(*_pu21_pair(x, ref, luminance_scale), data_range=PU21_PEAK)


LOG_EPS = 1e-3


def to_unit_range(x: npt.ArrayLike, white: float) -> npt.NDArray[np.float64] | np.float64:
    """The paper protocol's normalisation: clip(x / white, 0, 1)."""
    check_number("white (the [0, 1] normalisation's white level)", white, positive=True)
    return np.clip(np.asarray(x, np.float64) / white, 0.0, 1.0)


def mse01(x: npt.ArrayLike, ref: npt.ArrayLike, white: float = 1.0) -> float:
    """MSE after clip(I / white, 0, 1) of both images.

    Parameters
    ----------
    x, ref : array_like
        Reconstruction and reference, (H, W) linear intensity (x units), >= 0.
    white : float, optional
        The intensity that maps to 1 (x units), > 0 (default 1).

    Returns
    -------
    float
        The MSE of the [0, 1] images.
    """
    x, ref = _pair(x, ref)
    return mse(to_unit_range(x, white), to_unit_range(ref, white))


def ssim01(x: npt.ArrayLike, ref: npt.ArrayLike, white: float = 1.0) -> float:
    """SSIM (data_range 1) after clip(I / white, 0, 1) of both images.

    Parameters
    ----------
    x, ref : array_like
        Reconstruction and reference, (H, W) linear intensity (x units), >= 0.
    white : float, optional
        The intensity that maps to 1 (x units), > 0 (default 1).

    Returns
    -------
    float
        Mean SSIM of the [0, 1] images.
    """
    x, ref = _pair(x, ref)
    return ssim(to_unit_range(x, white), to_unit_range(ref, white), data_range=1.0)


def log_mse(x: npt.ArrayLike, ref: npt.ArrayLike) -> float:
    """Mean squared difference of log(I + LOG_EPS).

    Parameters
    ----------
    x, ref : array_like
        Reconstruction and reference, (H, W) linear intensity (x units), >= 0.

    Returns
    -------
    float
        The mean squared log difference (natural-log units squared).
    """
    x, ref = _pair(x, ref)
    return float(np.mean((np.log(x + LOG_EPS) - np.log(ref + LOG_EPS)) ** 2))


#: log_rmse's floor as a fraction of the frames' top: 1e-3, ten stops below the brightest value the frames record
#: (a 10-bit linear frame's step); tied to the frames' top rather than to x = 1, so that it follows the CRF's range
#: and the exposures
LOG_FLOOR_FRACTION = 1e-3


def _squared_log_error(x: np.ndarray, ref: np.ndarray, top: float | None) -> npt.NDArray[np.float64]:
    floor = LOG_FLOOR_FRACTION * check_number("top (the largest x the input frames record)", top, positive=True)
    return (np.log(np.maximum(x, floor)) - np.log(np.maximum(ref, floor))) ** 2


def log_rmse(x: npt.ArrayLike, ref: npt.ArrayLike, top: float) -> float:
    """Full-range log error: sqrt(mean((ln max(I, f) - ln max(R, f))^2)) with f = LOG_FLOOR_FRACTION * top.

    Parameters
    ----------
    x, ref : array_like
        Reconstruction I and reference R, (H, W) linear intensity (x units), >= 0.
    top : float
        The largest intensity the input frames can record (x units), CRF^-1(1) times the largest exposure gain
        T_0 / T_k (evsim_eval.scoring.frames_range); the floor f = 1e-3 top (LOG_FLOOR_FRACTION) keeps values darker
        than any frame resolves from dominating the score.

    Returns
    -------
    float
        The root mean square log ratio (natural-log units: 0.1 is a 10.5 % error on every pixel), nothing clipped
        at the top.
    """
    x, ref = _pair(x, ref)
    return float(np.sqrt(np.mean(_squared_log_error(x, ref, top))))


#: metric name -> function(x, ref, ...) of an image against its reference (see NORMALISATION)
METRICS = {"log_rmse": log_rmse, "mse01": mse01, "ssim01": ssim01, "mse": mse, "psnr": psnr, "ssim": ssim,
           "log_mse": log_mse, "pu21_psnr": pu21_psnr, "pu21_ssim": pu21_ssim}
#: the metrics that take the white level of the [0, 1] protocol (and are clipped at it)
NEEDS_WHITE = frozenset({"mse01", "ssim01"})
#: the metrics that take the frames' top, the largest x the input frames can record (log_rmse's floor)
NEEDS_TOP = frozenset({"log_rmse"})
_PU21_SCALE = "Y = s I cd/m^2, s = 100, or 10000 / (reference max) where that exceeds 100 x (nothing clamped)"
#: how each metric normalises its inputs, one line each (printed with evsim evaluate's tables)
NORMALISATION = {
    "log_rmse": f"full range, absolute values: RMS of ln(max(I, f)) - ln(max(R, f)), floor f = "
                f"{LOG_FLOOR_FRACTION:g} x the frames' top (the largest x the input frames record)",
    "mse01": "clipped at the white (paper protocol): clip(I / white, 0, 1) of both images, then MSE",
    "ssim01": "clipped at the white (paper protocol): clip(I / white, 0, 1) of both images, SSIM with data_range 1",
    "mse": "raw linear intensities, no rescaling",
    "psnr": "raw linear intensities, peak = reference max",
    "ssim": "raw linear intensities, data_range = reference max - min",
    "log_mse": "absolute values: MSE of ln(I + 1e-3)",
    "pu21_psnr": f"absolute values: PU21 of {_PU21_SCALE}, peak 256",
    "pu21_ssim": f"absolute values: PU21 of {_PU21_SCALE}, data_range 256",
}
#: larger is better for these (the others are errors)
HIGHER_IS_BETTER = frozenset({"psnr", "ssim", "ssim01", "pu21_psnr", "pu21_ssim"})


def _check_metric(metric: str, white: float | None, top: float | None) -> None:
    if metric not in METRICS:
        raise EvsimInputError(f"unknown metric {metric!r}; one of {', '.join(METRICS)}")
    if metric in NEEDS_WHITE and white is None:
        raise EvsimInputError(f"metric {metric!r} needs the white level of the [0, 1] protocol")
    if metric in NEEDS_TOP and top is None:
        raise EvsimInputError(f"metric {metric!r} needs the frames' top (the largest x the input frames record) "
                              "for its floor")


def score(metric: str, x: npt.ArrayLike, ref: npt.ArrayLike, white: float | None = None,
          top: float | None = None) -> float:
    """A metric of an image against its reference, by name.

    Parameters
    ----------
    metric : str
        A METRICS name.
    x, ref : array_like
        Reconstruction and reference, (H, W) linear intensity (x units), >= 0.
    white : float, optional
        The [0, 1] protocol's white (x units); required by the NEEDS_WHITE metrics (mse01, ssim01).
    top : float, optional
        The largest x the input frames can record; required by the NEEDS_TOP metrics (log_rmse's floor).

    Returns
    -------
    float
        The metric's value (see NORMALISATION; larger is better for HIGHER_IS_BETTER).
    """
    _check_metric(metric, white, top)
    if metric in NEEDS_WHITE:
        return METRICS[metric](x, ref, white=white)
    if metric in NEEDS_TOP:
        return METRICS[metric](x, ref, top=top)
    return METRICS[metric](x, ref)


#: SSIM's window: skimage's default 7x7; its local map is valid (and averaged) SSIM_MARGIN pixels from the border
SSIM_WINDOW = 7
SSIM_MARGIN = (SSIM_WINDOW - 1) // 2
#: the metrics that are a mean of a per-pixel map (score_map), or its square root (ROOT_MEAN), so that they can be
#: pooled over a pixel class
PER_PIXEL = frozenset({"log_rmse", "mse01", "ssim01", "mse", "ssim", "log_mse", "pu21_ssim"})
#: the PER_PIXEL metrics that are the square root of their map's mean: pooled over pixels (a class, the frames of a
#: sequence) as the root of the pooled mean, not as a mean of roots
ROOT_MEAN = frozenset({"log_rmse"})
#: the PER_PIXEL metrics whose map is a local SSIM (valid SSIM_MARGIN pixels in from the border)
SSIM_MAPS = frozenset({"ssim01", "ssim", "pu21_ssim"})


def _ssim_map(x: np.ndarray, ref: np.ndarray, data_range: float) -> npt.NDArray[np.float64]:
    _, smap = structural_similarity(x, ref, data_range=data_range, full=True)
    return np.asarray(smap, np.float64)


def score_map(metric: str, x: npt.ArrayLike, ref: npt.ArrayLike, white: float | None = None,
              top: float | None = None) -> npt.NDArray[np.float64]:
    """The per-pixel map of a PER_PIXEL metric, whose mean (root mean for ROOT_MEAN) is the metric.

    Parameters
    ----------
    metric : str
        A PER_PIXEL metric name.
    x, ref : array_like
        Reconstruction and reference, (H, W) linear intensity (x units), >= 0.
    white, top : float, optional
        As for score().

    Returns
    -------
    ndarray
        (H, W) float64: the squared error (mse01, mse, log_mse, and log_rmse's squared log error, each in its
        normalisation) or the local SSIM (ssim01, ssim, pu21_ssim: Wang et al. 2004, 7x7 window). score() of an
        SSIM metric is the mean of its map SSIM_MARGIN pixels in from the border (skimage's rule); of log_rmse the
        square root of its map's mean; of the others the mean of the whole map.
    """
    _check_metric(metric, white, top)
    if metric not in PER_PIXEL:
        raise EvsimInputError(f"metric {metric!r} is not a mean over pixels; per-pixel maps exist for "
                              f"{', '.join(sorted(PER_PIXEL))}")
    x, ref = _pair(x, ref)
    if metric in ("mse01", "ssim01"):
        x, ref = to_unit_range(x, white), to_unit_range(ref, white)
    if metric == "ssim01":
        return _ssim_map(x, ref, 1.0)
    if metric == "ssim":
        rng = float(ref.max() - ref.min())
        if rng <= 0:
            raise EvsimInputError("ssim needs a positive data_range (the reference is constant)")
        return _ssim_map(x, ref, rng)
    if metric == "pu21_ssim":
        return _ssim_map(*_pu21_pair(x, ref, None), PU21_PEAK)
    if metric == "log_rmse":
        return _squared_log_error(x, ref, top)
    if metric == "log_mse":
        return (np.log(x + LOG_EPS) - np.log(ref + LOG_EPS)) ** 2
    return (x - ref) ** 2
