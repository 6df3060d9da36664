"""Image quality metrics for HDR reconstructions, and how each one normalises its inputs.

- mse / psnr: on the raw linear intensities as given (no tone mapping, no rescaling). psnr uses
  data_range = reference max unless given: PSNR = 10 log10(data_range^2 / MSE).
- ssim: skimage.metrics.structural_similarity on the raw intensities with an explicit data_range (default: the
  reference's max - min), 7x7 uniform window (skimage's default), float64.
- PU21 (Mantiuk & Azimi, PCS 2021): intensities are first mapped to absolute luminance Y = luminance_scale * I in
  cd/m^2 (default 100: I = 1 is SDR reference white), clamped to [0.005, 10000] cd/m^2 and encoded with the
  'banding_glare' PU21 curve (100 cd/m^2 -> about 256); pu21_psnr uses a peak of 256 (the encoded value of
  100 cd/m^2, as in the authors' pu_psnr) and pu21_ssim a data_range of 256.
- mse01 / ssim01: the AKF paper's protocol. Reconstruction and reference are both brought to [0, 1] by one rule,
  v = clip(I / white, 0, 1), with `white` the intensity that maps to 1 (given by the caller: for AHDR data the
  radiance the generator recorded as white, for held-out frames CRF^-1(1)); SSIM with data_range 1.
- log_mse: mean squared difference of log(I + LOG_EPS) (natural log, LOG_EPS = 1e-3 x units, the AKF's I0) on
  absolute values: errors of highlights and shadows count by ratio, not by absolute size.
Every metric's normalisation in one line is NORMALISATION[name]; score() applies any metric by name. Every metric
takes two real-valued (H, W) images of one shape, finite and >= 0 (linear intensities; anything else raises
EvsimInputError naming the image), and its parameters (data_range, white, luminance_scale) finite and > 0.

References (full citations also in docs/models/references.md):

- Mantiuk RK, Azimi M (2021). PU21: a novel perceptually uniform encoding for adapting existing quality
  metrics for HDR. Picture Coding Symposium (PCS).
- Wang Z, Bovik AC, Sheikh HR, Simoncelli EP (2004). Image quality assessment: from error visibility to
  structural similarity. IEEE Transactions on Image Processing 13(4):600-612. doi:10.1109/TIP.2003.819861
- van der Walt S, Schoenberger JL, Nunez-Iglesias J, Boulogne F, Warner JD, Yager N, Gouillart E, Yu T, and
  the scikit-image contributors (2014). scikit-image: image processing in Python. PeerJ 2:e453.
  doi:10.7717/peerj.453
- Wang Z, Ng Y, Scheerlinck C, Mahony R (2021). An asynchronous Kalman filter for hybrid event cameras.
  IEEE/CVF International Conference on Computer Vision (ICCV), 448-457, and its supplementary material.
  arXiv:2012.05590
- Narwaria M, Mantiuk RK, Da Silva MP, Le Callet P (2015). HDR-VDP-2.2: a calibrated method for objective
  quality prediction of high-dynamic range and standard images. Journal of Electronic Imaging 24(1):010501.
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
    """Mean squared error of the raw intensities."""
    x, ref = _pair(x, ref)
    return float(np.mean((x - ref) ** 2))


def psnr(x: npt.ArrayLike, ref: npt.ArrayLike, data_range: float | None = None) -> float:
    """PSNR (dB) = 10 log10(data_range^2 / MSE); data_range defaults to the reference's max."""
    x, ref = _pair(x, ref)
    peak = float(ref.max()) if data_range is None else check_number("data_range", data_range, positive=True)
    err = mse(x, ref)
    return float("inf") if err == 0 else float(20 * np.log10(peak) - 10 * np.log10(err))  # no overflow of peak**2


def ssim(x: npt.ArrayLike, ref: npt.ArrayLike, data_range: float | None = None) -> float:
    """SSIM (Wang et al. 2004) with data_range defaulting to the reference's max - min."""
    x, ref = _pair(x, ref)
    rng = (float(ref.max() - ref.min()) if data_range is None
           else check_number("data_range", data_range, positive=True))
    if rng <= 0:
        raise EvsimInputError("ssim needs a positive data_range (the reference is constant)")
    return float(structural_similarity(x, ref, data_range=rng))


def pu21_encode(luminance: npt.ArrayLike) -> npt.NDArray[np.float64] | np.float64:
    """PU21 encoding of absolute luminance (cd/m^2): V = p7 * (((p1 + p2 Y^p4) / (1 + p3 Y^p4))^p5 - p6), with Y
    clamped to [0.005, 10000] and V clipped at 0."""
    p1, p2, p3, p4, p5, p6, p7 = PU21_PARAMS
    y = np.clip(np.asarray(luminance, np.float64), PU21_Y_MIN, PU21_Y_MAX)
    yp = y**p4
    return np.maximum(p7 * (((p1 + p2 * yp) / (1 + p3 * yp)) ** p5 - p6), 0.0)


def pu21_psnr(x: npt.ArrayLike, ref: npt.ArrayLike, luminance_scale: float = 100.0) -> float:
    """PSNR of the PU21-encoded images (peak 256), after Y = luminance_scale * I."""
    check_number("luminance_scale", luminance_scale, positive=True)
    x, ref = _pair(x, ref)
    return psnr(pu21_encode(luminance_scale * x), pu21_encode(luminance_scale * ref), data_range=PU21_PEAK)


def pu21_ssim(x: npt.ArrayLike, ref: npt.ArrayLike, luminance_scale: float = 100.0) -> float:
    """SSIM of the PU21-encoded images (data_range 256), after Y = luminance_scale * I."""
    check_number("luminance_scale", luminance_scale, positive=True)
    x, ref = _pair(x, ref)
    return ssim(pu21_encode(luminance_scale * x), pu21_encode(luminance_scale * ref), data_range=PU21_PEAK)


LOG_EPS = 1e-3


def to_unit_range(x: npt.ArrayLike, white: float) -> npt.NDArray[np.float64] | np.float64:
    """The paper protocol's normalisation: clip(x / white, 0, 1)."""
    check_number("white (the [0, 1] normalisation's white level)", white, positive=True)
    return np.clip(np.asarray(x, np.float64) / white, 0.0, 1.0)


def mse01(x: npt.ArrayLike, ref: npt.ArrayLike, white: float = 1.0) -> float:
    """MSE after clip(I / white, 0, 1) of both images."""
    x, ref = _pair(x, ref)
    return mse(to_unit_range(x, white), to_unit_range(ref, white))


def ssim01(x: npt.ArrayLike, ref: npt.ArrayLike, white: float = 1.0) -> float:
    """SSIM (data_range 1) after clip(I / white, 0, 1) of both images."""
    x, ref = _pair(x, ref)
    return ssim(to_unit_range(x, white), to_unit_range(ref, white), data_range=1.0)


def log_mse(x: npt.ArrayLike, ref: npt.ArrayLike) -> float:
    """Mean squared difference of log(I + LOG_EPS)."""
    x, ref = _pair(x, ref)
    return float(np.mean((np.log(x + LOG_EPS) - np.log(ref + LOG_EPS)) ** 2))


#: metric name -> function(x, ref, ...) of an image against its reference (see NORMALISATION)
METRICS = {"mse01": mse01, "ssim01": ssim01, "mse": mse, "psnr": psnr, "ssim": ssim, "log_mse": log_mse,
           "pu21_psnr": pu21_psnr, "pu21_ssim": pu21_ssim}
#: the metrics that take the white level of the [0, 1] protocol
NEEDS_WHITE = frozenset({"mse01", "ssim01"})
#: how each metric normalises its inputs, one line each (printed with evsim evaluate's tables)
NORMALISATION = {
    "mse01": "paper protocol: clip(I / white, 0, 1) of both images, then MSE",
    "ssim01": "paper protocol: clip(I / white, 0, 1) of both images, SSIM with data_range 1",
    "mse": "raw linear intensities, no rescaling",
    "psnr": "raw linear intensities, peak = reference max",
    "ssim": "raw linear intensities, data_range = reference max - min",
    "log_mse": "absolute values: MSE of ln(I + 1e-3)",
    "pu21_psnr": "absolute values: PU21 of Y = 100 I cd/m^2, peak 256",
    "pu21_ssim": "absolute values: PU21 of Y = 100 I cd/m^2, data_range 256",
}
#: larger is better for these (the others are errors)
HIGHER_IS_BETTER = frozenset({"psnr", "ssim", "ssim01", "pu21_psnr", "pu21_ssim"})


def _check_metric(metric: str, white: float | None) -> None:
    if metric not in METRICS:
        raise EvsimInputError(f"unknown metric {metric!r}; one of {', '.join(METRICS)}")
    if metric in NEEDS_WHITE and white is None:
        raise EvsimInputError(f"metric {metric!r} needs the white level of the [0, 1] protocol")


def score(metric: str, x: npt.ArrayLike, ref: npt.ArrayLike, white: float | None = None) -> float:
    """metric (a METRICS name) of image x against ref; white is required by the NEEDS_WHITE metrics."""
    _check_metric(metric, white)
    if metric in NEEDS_WHITE:
        return METRICS[metric](x, ref, white=white)
    return METRICS[metric](x, ref)


#: SSIM's window: skimage's default 7x7; its local map is valid (and averaged) SSIM_MARGIN pixels from the border
SSIM_WINDOW = 7
SSIM_MARGIN = (SSIM_WINDOW - 1) // 2
#: the metrics that are a mean of a per-pixel map (score_map), so that they can be averaged over a pixel class
PER_PIXEL = frozenset({"mse01", "ssim01", "mse", "ssim", "log_mse", "pu21_ssim"})
#: the PER_PIXEL metrics whose map is a local SSIM (valid SSIM_MARGIN pixels in from the border)
SSIM_MAPS = frozenset({"ssim01", "ssim", "pu21_ssim"})


def _ssim_map(x: np.ndarray, ref: np.ndarray, data_range: float) -> npt.NDArray[np.float64]:
    _, smap = structural_similarity(x, ref, data_range=data_range, full=True)
    return np.asarray(smap, np.float64)


def score_map(metric: str, x: npt.ArrayLike, ref: npt.ArrayLike, white: float | None = None
              ) -> npt.NDArray[np.float64]:
    """The per-pixel map whose mean is the PER_PIXEL metric: the squared error (mse01, mse, log_mse, each in its
    normalisation) or the local SSIM (ssim01, ssim, pu21_ssim: Wang et al. 2004, 7x7 window). score() of an SSIM
    metric is the mean of its map SSIM_MARGIN pixels in from the border (skimage's rule); of the others the mean of
    the whole map."""
    _check_metric(metric, white)
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
        return _ssim_map(pu21_encode(100.0 * x), pu21_encode(100.0 * ref), PU21_PEAK)
    if metric == "log_mse":
        return (np.log(x + LOG_EPS) - np.log(ref + LOG_EPS)) ** 2
    return (x - ref) ** 2
