"""Array-level evaluation: run several reconstruction methods on one sequence and score them against a reference."""

from __future__ import annotations

import numpy as np

from sim.errors import EvsimInputError, InvalidParameterError

from .baselines import BASELINES
from .filter import reconstruct
from .metrics import METRICS, score

#: name -> callable(events, frames, frame_t_start_us, frame_t_end_us, crf, output_times_us, *, contrast,
#: bit_depth, **method options) -> float32 (T, H, W) linear intensity
METHODS = {"akf": reconstruct, **BASELINES}


def evaluate_sequence(events, frames, frame_t_start_us, frame_t_end_us, crf, reference, reference_times_us, *,
                      methods=("akf", "cf", "frames"), metrics=("mse", "psnr", "ssim", "pu21_psnr", "pu21_ssim"),
                      contrast=0.2, bit_depth=8, method_options=None, return_images=False, white=None):
    """Reconstruct at reference_times_us with each method and score against reference (T, H, W) linear intensity
    in the CRF's scaled-irradiance units of frame 0's exposure (for frames from sim.LDRCamera: x = radiance *
    params.electrons_per_radiance_us * exposure_us of frame 0 / params.full_well_e).

    Each metric is computed per reference frame (see akf.metrics for each one's normalisation) and averaged over
    the frames. method_options: {method: {keyword: value}} passed to that method (e.g. {"akf": {"params": ...}}).
    white: the intensity the [0, 1] protocol metrics (mse01, ssim01) map to 1; default the 98th percentile of the
    reference (all frames pooled).
    Returns {method: {metric: mean value}}, and also {method: images} when return_images.
    """
    reference = np.asarray(reference)
    times = np.asarray(reference_times_us)
    if reference.ndim != 3 or reference.shape[0] != times.shape[0]:
        raise EvsimInputError(f"reference must be (T, H, W) with T = len(reference_times_us), got {reference.shape} "
                              f"and {times.shape[0]} times")
    unknown = [m for m in methods if m not in METHODS] + [m for m in metrics if m not in METRICS]
    if unknown:
        raise InvalidParameterError(f"unknown methods/metrics {unknown}; methods: {sorted(METHODS)}, "
                                    f"metrics: {sorted(METRICS)}")
    method_options = method_options or {}
    if white is None:
        white = float(np.percentile(reference, 98))
    table, images = {}, {}
    for name in methods:
        rec = METHODS[name](events, frames, frame_t_start_us, frame_t_end_us, crf, times, contrast=contrast,
                            bit_depth=bit_depth, **method_options.get(name, {}))
        table[name] = {m: float(np.mean([score(m, r, ref, white) for r, ref in zip(rec, reference)]))
                       for m in metrics}
        if return_images:
            images[name] = rec
    return (table, images) if return_images else table
