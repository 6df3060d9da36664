"""Scoring reconstruction methods on one sequence: the one scoring path of evsim (akf.evaluate_sequence, the
dataset protocols of evsim_eval and the tuning objective all go through Case)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from sim.errors import EvsimInputError, InvalidParameterError

from .baselines import BASELINES
from .filter import reconstruct
from .metrics import METRICS, score
from .tuning import setting_options

if TYPE_CHECKING:
    from collections.abc import Collection, Iterable

    import numpy.typing as npt

    from crf_models import CRF

    #: the reconstruction scores of evaluate_sequence: {method: {metric: mean value}}
    ScoreTable = dict[str, dict[str, float]]

__all__ = ["Case", "evaluate_sequence", "METHODS", "check_names"]

#: name -> callable(events, frames, frame_t_start_us, frame_t_end_us, crf, output_times_us, *, contrast,
#: bit_depth, **method options) -> float32 (T, H, W) linear intensity
METHODS = {"akf": reconstruct, **BASELINES}


def check_names(methods: Iterable[str] = (), metrics: Iterable[str] = ()) -> None:
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
    frames: npt.ArrayLike
    t_start: npt.ArrayLike
    t_end: npt.ArrayLike
    bit_depth: int
    crf: CRF | str
    contrast: npt.ArrayLike
    times: np.ndarray
    truth: np.ndarray
    white: float
    clip: np.ndarray | None = None
    options: dict[str, dict[str, Any]] = field(default_factory=dict)

    def run(self, method: str, sel: slice | np.ndarray = slice(None),
            setting: dict[str, float | None] | None = None) -> np.ndarray:
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

    def scores(self, images: np.ndarray, sel: slice | np.ndarray, metrics: Iterable[str]) -> dict[str, float]:
        """{metric: mean over the frames} of images (at times[sel]) against the truth."""
        truth = self.truth[sel]
        return {m: float(np.mean([score(m, r, t, self.white) for r, t in zip(images, truth)])) for m in metrics}


def evaluate_sequence(events: np.ndarray, frames: npt.ArrayLike, frame_t_start_us: npt.ArrayLike,
                      frame_t_end_us: npt.ArrayLike, crf: CRF | str, reference: npt.ArrayLike,
                      reference_times_us: npt.ArrayLike, *, methods: Collection[str] = ("akf", "cf", "frames"),
                      metrics: Collection[str] = ("mse", "psnr", "ssim", "pu21_psnr", "pu21_ssim"),
                      contrast: npt.ArrayLike = 0.2, bit_depth: int = 8,
                      method_options: dict[str, dict[str, Any]] | None = None, return_images: bool = False,
                      white: float | None = None
                      ) -> ScoreTable | tuple[ScoreTable, dict[str, npt.NDArray[np.float32]]]:
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
