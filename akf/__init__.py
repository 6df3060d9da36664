"""HDR reconstruction: frame augmentation, the Asynchronous Kalman Filter, the smoother and the baselines.

Exports:
- the filter: reconstruct, AKFParams; the smoother (offline: the filter forward and backward, fused):
  reconstruct_smoothed; augmented_measurement, AugmentedMeasurement (its frame augmentation);
- baselines (reconstruct's inputs and outputs): complementary_filter, frames_only, direct_integration, and the
  events-only high_pass_filter; estimate_contrast, estimate_log_offset, ContrastEstimate (the contrast threshold and
  the pixel's log offset from the data); estimate_read_noise, FrameNoise (the frames' read noise, which sets the
  frame update's variance);
- METHODS: every method by name (akf.methods), one signature.
Submodules with more:
- akf.frame_noise: the frames' read noise from the frames (quantisation-corrected robust median of aligned
  frame differences) and the frame update's variance it implies;
- akf.flat_field, akf.clip_prior, akf.anchoring: the thresholds' flat field, the prior of clipped pixels and the
  Poisson anchoring of never-measured pixels.
Scoring, metrics and tuning are in evsim_eval (evsim_eval.metrics, evsim_eval.scoring, evsim_eval.tuning); event
denoising filters in sim.denoise.

References (docs/models/references.md): Wang et al. 2021 [Wang2021], the AKF; Pan et al. 2019 [Pan2019], EDI;
Scheerlinck et al. 2018 [Scheerlinck2018], the complementary and high-pass filters. Metrics (evsim_eval.metrics) and
denoising filters (sim.denoise) cite theirs.
"""

from .baselines import complementary_filter, direct_integration, frames_only, high_pass_filter
from .contrast import ContrastEstimate, estimate_contrast, estimate_log_offset
from .filter import AugmentedMeasurement, augmented_measurement, reconstruct
from .frame_noise import FrameNoise, estimate_read_noise
from .methods import METHODS
from .params import AKFParams
from .smoother import reconstruct_smoothed

__all__ = [
    "reconstruct", "reconstruct_smoothed", "AKFParams", "augmented_measurement", "AugmentedMeasurement",
    "complementary_filter", "frames_only", "direct_integration", "high_pass_filter",
    "estimate_contrast", "estimate_log_offset", "ContrastEstimate", "estimate_read_noise", "FrameNoise", "METHODS",
]
