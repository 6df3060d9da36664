"""HDR reconstruction: frame augmentation, the Asynchronous Kalman Filter, baselines and metrics."""

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
