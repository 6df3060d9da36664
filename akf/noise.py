"""Frame uncertainty (eqs. 6, 8, 9). The event noise Q (eq. 2) is realised per event inside akf.kernels.akf_events.

References (docs/models/references.md): Wang et al. 2021 [Wang2021]; Robertson et al. 2003 [Robertson2003].
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .params import AKFParams

if TYPE_CHECKING:
    from crf_models import CRF


@dataclass(frozen=True)
class FrameMeasurement:
    """One frame mapped to the filter's log space; all arrays float64 (H, W).

    intensity: I = CRF^-1(y), scaled irradiance (x units).
    rbar: Rbar = sigma_im2 / f^w(y), saturated at max_variance (x^2, eq. 6).
    r: R = Rbar / (I + I0)^2, the log-space variance (log^2, eq. 9).
    log: L^F = log(I + I0) - min(R, bias_max_variance) / 2, the bias-corrected log frame (eq. 8); log(I + I0)
        where clipped.
    clipped: True where Rbar reached max_variance (the frame carries no usable information there).
    side: int8, +1 / -1 where clipped at a high / low response (y >= 0.5 / y < 0.5), else 0.
    """

    intensity: np.ndarray
    rbar: np.ndarray
    r: np.ndarray
    log: np.ndarray
    clipped: np.ndarray
    side: np.ndarray


def frame_measurement(y: np.ndarray, crf: CRF, params: AKFParams, gain: float = 1.0) -> FrameMeasurement:
    """Map a normalised response y = DN / (2^bits - 1) through the CRF object's inverse and variance model.

    gain scales the scaled irradiance (and Rbar by gain^2), e.g. T_0 / T_k to bring frames of different exposure
    times to common units (the paper's "exposure time is linearly scaled to obtain the scaled irradiance").
    """
    intensity = gain * np.asarray(crf.inverse(y), dtype=np.float64)
    rbar_raw = np.asarray(crf.variance(y, params.sigma_im2, params.max_variance), dtype=np.float64)
    rbar = gain**2 * rbar_raw
    shifted = intensity + params.i0
    r = rbar / shifted**2
    clipped = rbar_raw >= params.max_variance
    # eq. 8's second-order bias correction; none at a clipped (censored) response, where the truth lies beyond the
    # clip level and shifting the measurement further toward the middle would only add bias
    log = np.log(shifted) - 0.5 * np.where(clipped, 0.0, np.minimum(r, params.bias_max_variance))
    side = np.where(clipped, np.where(np.asarray(y) >= 0.5, 1, -1), 0).astype(np.int8)
    return FrameMeasurement(intensity, rbar, r, log, clipped, side)
