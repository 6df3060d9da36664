"""Scoring reconstruction methods on one sequence: the one scoring path of evsim (akf.evaluate_sequence, the
dataset protocols of evsim_eval and the tuning objective all go through Case)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sim.errors import EvsimInputError, InvalidParameterError

from .baselines import BASELINES
from .filter import reconstruct
from .metrics import METRICS, score
from .tuning import setting_options

#: name -> callable(events, frames, frame_t_start_us, frame_t_end_us, crf, output_times_us, *, contrast,
#: bit_depth, **method options) -> float32 (T, H, W) linear intensity
METHODS = {"akf": reconstruct, **BASELINES}


def check_names(methods=(), metrics=()) -> None:
    """InvalidParameterError naming the methods or metrics that akf does not have."""
    unknown = [m for m in methods if m not in METHODS] + [m for m in metrics if m not in METRICS]
    if unknown:
        raise InvalidParameterError(f"unknown methods/metrics {unknown}; methods: {sorted(METHODS)}, "
                                    f"metrics: {sorted(METRICS)}")


@dataclass
class Case:
    """One sequence as every method sees it, and what it is scored against.

    The inputs (events, frames with their exposure times in int64 us, bit depth, CRF, nominal contrast thresholds
    in log units), the scored times (int64 us), the truth there (T, H, W) in the CRF's scaled-irradiance units x of
    frame 0's exposure, the white level (x) the [0, 1] metrics map to 1, and optionally the per-time range
    clip[k] = (lo, hi) in x a held-out frame can measure (reconstructions are clipped to it before scoring).
    options: {method: {keyword: value}} each method gets beyond the shared inputs.
    """

    events: np.ndarray
    frames: np.ndarray
    t_start: np.ndarray
    t_end: np.ndarray
    bit_depth: int
    crf: object
    contrast: object
    times: np.ndarray
    truth: np.ndarray
    white: float
    clip: np.ndarray | None = None
    options: dict = field(default_factory=dict)

    def run(self, method: str, sel=slice(None), setting: dict | None = None) -> np.ndarray:
        """The method's reconstructions at times[sel], with a tuning setting (akf.tuning) applied on top of the
        case's contrast and options; clipped to the measurable range when the case has one."""
        contrast, options = self.contrast, self.options.get(method, {})
        if setting:
            contrast, options = setting_options(method, setting, contrast, options)
        images = METHODS[method](self.events, self.frames, self.t_start, self.t_end, self.crf, self.times[sel],
                                 contrast=contrast, bit_depth=self.bit_depth, **options)
        if self.clip is not None:
            images = np.stack([np.clip(img, lo, hi) for img, (lo, hi) in zip(images, self.clip[sel])])
        return images

    def scores(self, images: np.ndarray, sel, metrics) -> dict:
        """{metric: mean over the frames} of images (at times[sel]) against the truth."""
        truth = self.truth[sel]
        return {m: float(np.mean([score(m, r, t, self.white) for r, t in zip(images, truth)])) for m in metrics}


def evaluate_sequence(events, frames, frame_t_start_us, frame_t_end_us, crf, reference, reference_times_us, *,
                      methods=("akf", "cf", "frames"), metrics=("mse", "psnr", "ssim", "pu21_psnr", "pu21_ssim"),
                      contrast=0.2, bit_depth: int = 8, method_options: dict | None = None,
                      return_images: bool = False, white: float | None = None):
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
    check_names(methods, metrics)
    if white is None:
        white = float(np.percentile(reference, 98))
    case = Case(events, frames, frame_t_start_us, frame_t_end_us, bit_depth, crf, contrast, times, reference, white,
                options=method_options or {})
    table, images = {}, {}
    every = np.arange(times.size)
    for name in methods:
        rec = case.run(name, every)
        table[name] = case.scores(rec, every, metrics)
        if return_images:
            images[name] = rec
    return (table, images) if return_images else table
