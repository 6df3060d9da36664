"""HDR reconstruction: frame augmentation, the Asynchronous Kalman Filter, baselines and metrics.

Exports:
- the filter: reconstruct, AKFParams; augmented_measurement, AugmentedMeasurement (its frame augmentation);
- baselines (reconstruct's inputs and outputs): complementary_filter, frames_only, direct_integration, and the
  events-only high_pass_filter; estimate_contrast, ContrastEstimate (the contrast threshold from the data);
- metrics: mse, psnr, ssim, mse01, ssim01, log_mse, pu21_encode, pu21_psnr, pu21_ssim, score, METRICS (by name),
  NORMALISATION (how each one normalises);
- evaluation and tuning: evaluate_sequence, METHODS (name -> method); tune, Tuned, SEARCH_SPACES.
Submodules with more:
- akf.evaluate: Case, the one scoring path (evaluate_sequence, evsim_eval's dataset protocols and the tuning
  objective all score through it);
- akf.tuning: setting_options, default_setting, describe_setting, and tune_cases (the objective over Cases);
- akf.denoise: event denoising filters, each a keep-mask over an event array (correlation, hot_pixel, wrappers of
  dv-processing and tonic; FILTERS, keep_mask).
"""

from .baselines import complementary_filter, direct_integration, frames_only, high_pass_filter
from .contrast import ContrastEstimate, estimate_contrast
from .evaluate import METHODS, evaluate_sequence
from .filter import AugmentedMeasurement, augmented_measurement, reconstruct
from .metrics import (
    METRICS,
    NORMALISATION,
    log_mse,
    mse,
    mse01,
    psnr,
    pu21_encode,
    pu21_psnr,
    pu21_ssim,
    score,
    ssim,
    ssim01,
)
from .params import AKFParams
from .tuning import SEARCH_SPACES, Tuned, tune

__all__ = [
    "reconstruct", "AKFParams", "augmented_measurement", "AugmentedMeasurement",
    "complementary_filter", "frames_only", "direct_integration", "high_pass_filter",
    "estimate_contrast", "ContrastEstimate",
    "mse", "psnr", "ssim", "mse01", "ssim01", "log_mse", "pu21_encode", "pu21_psnr", "pu21_ssim", "score",
    "METRICS", "NORMALISATION",
    "evaluate_sequence", "METHODS", "tune", "Tuned", "SEARCH_SPACES",
]
