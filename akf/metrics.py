"""Image quality metrics for HDR reconstructions, and how each one normalises its inputs.

- mse / psnr: on the raw linear intensities as given (no tone mapping, no rescaling). psnr uses
  data_range = reference max unless given: PSNR = 10 log10(data_range^2 / MSE).
- ssim: skimage.metrics.structural_similarity on the raw intensities with an explicit data_range (default: the
  reference's max - min), 7x7 uniform window (skimage's default), float64.
- PU21 (Mantiuk & Azimi, PCS 2021): intensities are first mapped to absolute luminance Y = luminance_scale * I in
  cd/m^2 (default 100: I = 1 is SDR reference white), clamped to [0.005, 10000] cd/m^2 and encoded with the
  'banding_glare' PU21 curve (100 cd/m^2 -> about 256); pu21_psnr uses a peak of 256 (the encoded value of
  100 cd/m^2, as in the authors' pu_psnr) and pu21_ssim a data_range of 256.
"""

from __future__ import annotations

import numpy as np
from skimage.metrics import structural_similarity

from sim.errors import EvsimInputError

# PU21 'banding_glare' parameters p1..p7 (Mantiuk & Azimi 2021, pu21_encoder.m)
PU21_PARAMS = (0.353487901, 0.3734658629, 8.277049286e-05, 0.9062562627, 0.09150303166, 0.9099517204, 596.3148142)
PU21_Y_MIN, PU21_Y_MAX = 0.005, 10000.0
PU21_PEAK = 256.0


def _pair(x, ref):
    x = np.asarray(x, np.float64)
    ref = np.asarray(ref, np.float64)
    if x.shape != ref.shape or x.ndim != 2:
        raise EvsimInputError(f"metrics need two (H, W) images of the same shape, got {x.shape} and {ref.shape}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(ref))):
        raise EvsimInputError("metrics need finite images")
    return x, ref


def mse(x, ref) -> float:
    """Mean squared error of the raw intensities."""
    x, ref = _pair(x, ref)
    return float(np.mean((x - ref) ** 2))


def psnr(x, ref, data_range: float | None = None) -> float:
    """PSNR (dB) = 10 log10(data_range^2 / MSE); data_range defaults to the reference's max."""
    x, ref = _pair(x, ref)
    peak = float(ref.max()) if data_range is None else float(data_range)
    err = mse(x, ref)
    return float("inf") if err == 0 else float(10 * np.log10(peak**2 / err))


def ssim(x, ref, data_range: float | None = None) -> float:
    """SSIM (Wang et al. 2004) with data_range defaulting to the reference's max - min."""
    x, ref = _pair(x, ref)
    rng = float(ref.max() - ref.min()) if data_range is None else float(data_range)
    if rng <= 0:
        raise EvsimInputError("ssim needs a positive data_range (the reference is constant)")
    return float(structural_similarity(x, ref, data_range=rng))


def pu21_encode(luminance) -> np.ndarray:
    """PU21 encoding of absolute luminance (cd/m^2): V = p7 * (((p1 + p2 Y^p4) / (1 + p3 Y^p4))^p5 - p6), with Y
    clamped to [0.005, 10000] and V clipped at 0."""
    p1, p2, p3, p4, p5, p6, p7 = PU21_PARAMS
    y = np.clip(np.asarray(luminance, np.float64), PU21_Y_MIN, PU21_Y_MAX)
    yp = y**p4
    return np.maximum(p7 * (((p1 + p2 * yp) / (1 + p3 * yp)) ** p5 - p6), 0.0)


def pu21_psnr(x, ref, luminance_scale: float = 100.0) -> float:
    """PSNR of the PU21-encoded images (peak 256), after Y = luminance_scale * I."""
    x, ref = _pair(x, ref)
    return psnr(pu21_encode(luminance_scale * x), pu21_encode(luminance_scale * ref), data_range=PU21_PEAK)


def pu21_ssim(x, ref, luminance_scale: float = 100.0) -> float:
    """SSIM of the PU21-encoded images (data_range 256), after Y = luminance_scale * I."""
    x, ref = _pair(x, ref)
    return ssim(pu21_encode(luminance_scale * x), pu21_encode(luminance_scale * ref), data_range=PU21_PEAK)


METRICS = {"mse": mse, "psnr": psnr, "ssim": ssim, "pu21_psnr": pu21_psnr, "pu21_ssim": pu21_ssim}
