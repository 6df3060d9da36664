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

References (full citations also in docs/models/references.md):

- Wang Z, Ng Y, Scheerlinck C, Mahony R (2021). An asynchronous Kalman filter for hybrid event cameras.
  IEEE/CVF International Conference on Computer Vision (ICCV), 448-457, and its supplementary material.
  arXiv:2012.05590
- Pan L, Scheerlinck C, Yu X, Hartley R, Liu M, Dai Y (2019). Bringing a blurry frame alive at high frame-rate
  with an event camera (EDI). IEEE/CVF Conference on Computer Vision and Pattern Recognition (CVPR), 6820-6829.
  arXiv:1811.10180
- Scheerlinck C, Barnes N, Mahony R (2018). Continuous-time intensity estimation using event cameras. Asian
  Conference on Computer Vision (ACCV), Lecture Notes in Computer Science 11365, 308-324. arXiv:1811.00386
- Mantiuk RK, Azimi M (2021). PU21: a novel perceptually uniform encoding for adapting existing quality
  metrics for HDR. Picture Coding Symposium (PCS).
- Wang Z, Bovik AC, Sheikh HR, Simoncelli EP (2004). Image quality assessment: from error visibility to
  structural similarity. IEEE Transactions on Image Processing 13(4):600-612. doi:10.1109/TIP.2003.819861
- Delbruck T (2008). Frame-free dynamic digital vision. Proceedings of the International Symposium on
  Secure-Life Electronics, Advanced Electronics for Quality Life and Society, University of Tokyo, 21-26.
  (The background-activity filter.)
- Guo S, Delbruck T (2022). Low cost and latency event camera background activity denoising (STCF). IEEE
  Transactions on Pattern Analysis and Machine Intelligence 45(1):785-795 (2023 issue).
  doi:10.1109/TPAMI.2022.3152999
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
