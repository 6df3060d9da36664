"""HDR reconstruction: frame augmentation, the Asynchronous Kalman Filter, baselines and metrics."""

from .baselines import complementary_filter, direct_integration, frames_only, high_pass_filter
from .evaluate import METHODS, evaluate_sequence
from .filter import AugmentedMeasurement, augmented_measurement, reconstruct
from .metrics import METRICS, mse, psnr, pu21_encode, pu21_psnr, pu21_ssim, ssim
from .params import AKFParams
