"""Scoring reconstruction methods on one sequence: the one scoring path of evsim (evsim_eval.evaluate_sequence, the
dataset protocols of evsim_eval and the tuning objective all go through Case)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from akf.inputs import as_crf
from akf.methods import METHODS
from sim.errors import EvsimInputError, InvalidParameterError

from .exposure import exposure_average
from .metrics import METRICS, PER_PIXEL, ROOT_MEAN, SSIM_MAPS, score, score_map
from .pixel_classes import (
    CLASSES,
    TIME_CLASSES,
    nearest_frames,
    pixel_classes,
    range_classes,
    time_classes,
    valid_region,
)
from .tuning import setting_options

if TYPE_CHECKING:
    from collections.abc import Collection, Iterable

    import numpy.typing as npt

    from crf_models import CRF

    #: the reconstruction scores of evaluate_sequence: {method: {metric: mean value}}
    ScoreTable = dict[str, dict[str, float]]

__all__ = ["Case", "evaluate_sequence", "check_names", "white_cap", "reachable_white", "exposure_gains",
           "frames_range", "FULL_WELL"]

def check_names(methods: Iterable[str] = (), metrics: Iterable[str] = ()) -> None:
    """InvalidParameterError naming the methods or metrics that akf does not have.

    Parameters
    ----------
    methods : iterable of str, optional
        Method names (akf.METHODS).
    metrics : iterable of str, optional
        Metric names (evsim_eval.metrics.METRICS).
    """
    unknown = [m for m in methods if m not in METHODS] + [m for m in metrics if m not in METRICS]
    if unknown:
        raise InvalidParameterError(f"unknown methods/metrics {unknown}; methods: {sorted(METHODS)}, "
                                    f"metrics: {sorted(METRICS)}")


#: the full well (x units): the complementary filters' default output bound, and the cap of the [0, 1] metrics'
#: white (the paper's protocol scores an SDR range; the AKF and the smoother are unbounded)
FULL_WELL = 1.0


def exposure_gains(frame_t_start_us: npt.ArrayLike, frame_t_end_us: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """T_0 / T_k of every frame (1 where an exposure time is zero): what brings frame k to frame 0's x units.

    Parameters
    ----------
    frame_t_start_us, frame_t_end_us : array_like
        Every frame's exposure window, int64 us.

    Returns
    -------
    numpy.ndarray
        float64 (N,) gains (dimensionless).
    """
    length = np.asarray(frame_t_end_us, np.float64) - np.asarray(frame_t_start_us, np.float64)
    ok = (length > 0) & (length[0] > 0)
    return np.where(ok, length[0] / np.where(length > 0, length, 1.0), 1.0)


def frames_range(crf: CRF | str, frame_t_start_us: npt.ArrayLike, frame_t_end_us: npt.ArrayLike
                 ) -> tuple[float, float]:
    """The range of intensity the input frames can record, in frame 0's x units.

    Parameters
    ----------
    crf : CRF or str
        The frames' camera response function (a crf_models name or object).
    frame_t_start_us, frame_t_end_us : array_like
        Every input frame's exposure window, int64 microseconds.

    Returns
    -------
    lo, hi : float
        x units: lo = CRF^-1(0) times the smallest exposure gain T_0 / T_k (exposure_gains: the longest
        exposure's floor), hi = CRF^-1(1) times the largest (the shortest exposure's white), "the frames' top":
        brighter x is clipped in every frame, darker than lo is black in every frame.
    """
    crf = as_crf(crf)
    gains = exposure_gains(frame_t_start_us, frame_t_end_us)
    return float(crf.inverse(0.0)) * float(np.min(gains)), float(crf.inverse(1.0)) * float(np.max(gains))


def white_cap(crf: CRF | str, frame_t_start_us: npt.ArrayLike, frame_t_end_us: npt.ArrayLike) -> float:
    """The largest white (x units) of the [0, 1] metrics: FULL_WELL, or frames-only's largest value, the frames'
    top CRF^-1(1) T_0 / T_k of the shortest exposure (frames_range), if larger.

    Parameters
    ----------
    crf : CRF or str
        The frames' camera response function (a crf_models name or object).
    frame_t_start_us, frame_t_end_us : array_like
        Every input frame's exposure window, int64 us.

    Returns
    -------
    float
        The cap (x units).
    """
    return max(FULL_WELL, frames_range(crf, frame_t_start_us, frame_t_end_us)[1])


def reachable_white(scene_white: float, crf: CRF | str, frame_t_start_us: npt.ArrayLike,
                    frame_t_end_us: npt.ArrayLike) -> tuple[float, str]:
    """The [0, 1] metrics' white, min(the scene's white, white_cap): the paper's protocol scores an SDR range; a
    white far above the frames' range (an HDR photo's 98th percentile can be 100 times the full well) would map every
    output below it to a small range where all methods tie. The full-range scores (log_rmse, PU21) look above it.

    Parameters
    ----------
    scene_white : float
        The scene's white (x units).
    crf : CRF or str
        The frames' camera response function.
    frame_t_start_us, frame_t_end_us : array_like
        Every input frame's exposure window, int64 us.

    Returns
    -------
    white : float
        The white (x units).
    description : str
        How it was chosen, one line.
    """
    cap = white_cap(crf, frame_t_start_us, frame_t_end_us)
    white = min(float(scene_white), cap)
    return white, f"white {white:.4g} x = min(scene white {scene_white:.4g} x, full well or frames' top {cap:.4g} x)"


@dataclass
class Case:
    """One sequence as every method sees it, and what it is scored against.

    The range the input frames can record, frames_range (its top sets log_rmse's floor, and the truth against it
    the range classes), follows from the CRF and the exposure times.

    Attributes
    ----------
    events : numpy.ndarray
        Time-sorted sim.EVENT_DTYPE events.
    frames : array_like
        (N, H, W) input frames (raw responses of bit_depth bits).
    t_start, t_end : array_like
        (N,) their exposure windows, int64 us.
    bit_depth : int
        The frames' bits.
    crf : CRF or str
        Their response curve (a crf_models curve or name).
    contrast : array_like
        Nominal contrast thresholds (log units), as akf.reconstruct takes them.
    times : numpy.ndarray
        (T,) scored times, int64 us.
    truth : numpy.ndarray
        (T, H, W) the truth there, in the CRF's scaled-irradiance units x of frame 0's exposure.
    white : float
        The white level (x units) the [0, 1] metrics map to 1.
    clip : numpy.ndarray, optional
        (T, 2) per-time range clip[k] = (lo, hi) in x a held-out frame can measure (reconstructions are clipped to it
        before scoring); None: none.
    options : dict
        {method: {keyword: value}} each method gets beyond the shared inputs.
    windows : numpy.ndarray, optional
        (T, 2) int64 exposure windows [t_start, t_end] us when the truth is a frame that integrated the scene over
        them (a held-out frame); then, with exposure_matched, every reconstruction is the average of the method over
        the window (evsim_eval.exposure), else the method at the scored time (point-in-time).
    exposure_matched : bool
        Average over the windows (default True).
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
    windows: np.ndarray | None = None
    exposure_matched: bool = True
    _classes: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    @property
    def frames_range(self) -> tuple[float, float]:
        """(lo, hi) x the input frames can record (the module's frames_range of the case's CRF and exposures)."""
        return frames_range(self.crf, self.t_start, self.t_end)

    @property
    def scoring(self) -> str:
        """How run() compares reconstructions with the truth: exposure-matched or point-in-time."""
        return "exposure-matched" if self.windows is not None and self.exposure_matched else "point-in-time"

    def run(self, method: str, sel: slice | np.ndarray = slice(None),
            setting: dict[str, float | None] | None = None) -> np.ndarray:
        """The method's reconstructions at times[sel] (exposure-matched: averaged over windows[sel]), with a tuning
        setting (evsim_eval.tuning) applied on top of the case's contrast and options; clipped to the measurable range
        when the case has one (the held-out frame's response applied to the average).

        Parameters
        ----------
        method : str
            An akf.METHODS name.
        sel : slice or numpy.ndarray, optional
            Which scored times (default all).
        setting : dict, optional
            A tuning setting {name: value} (evsim_eval.tuning), or None.

        Returns
        -------
        numpy.ndarray
            (len(sel), H, W) linear intensity (x units).
        """
        contrast, options = self.contrast, self.options.get(method, {})
        if setting:
            contrast, options = setting_options(method, setting, contrast, options)

        def at(times):
            return METHODS[method](self.events, self.frames, self.t_start, self.t_end, self.crf, times,
                                   contrast=contrast, bit_depth=self.bit_depth, **options)

        if self.scoring == "exposure-matched":
            images, _ = exposure_average(at, self.events, self.windows[sel], self.truth.shape[1:])
        else:
            images = at(self.times[sel])
        if self.clip is not None:
            images = np.stack([np.clip(img, lo, hi) for img, (lo, hi) in zip(images, self.clip[sel])])
        return images

    def scores(self, images: np.ndarray, sel: slice | np.ndarray, metrics: Iterable[str],
               by_class: bool = False) -> dict[str, float]:
        """{metric: mean over the frames} of images (at times[sel]) against the truth (of a ROOT_MEAN metric,
        log_rmse, the root of the mean square over the frames: the RMSE of all the frames' pixels pooled); with
        by_class also "metric@class" for every per-pixel metric (evsim_eval.metrics.PER_PIXEL) and class
        (evsim_eval.pixel_classes.CLASSES: the class's pixels pooled over the frames, a ROOT_MEAN metric the root of
        their mean square; NaN for an empty class) and "share@class", the class's share of the scored pixels.

        Parameters
        ----------
        images : numpy.ndarray
            (len(sel), H, W) reconstructions (x units), as run returns them.
        sel : slice or numpy.ndarray
            Which scored times they are.
        metrics : iterable of str
            Metric names (evsim_eval.metrics.METRICS).
        by_class : bool, optional
            Also the per-class scores (default False).

        Returns
        -------
        dict
            {name: value}.
        """
        metrics = list(metrics)
        truth = self.truth[sel]
        top = self.frames_range[1]
        out = {}
        for m in metrics:
            values = np.array([score(m, r, t, self.white, top) for r, t in zip(images, truth)])
            out[m] = float(np.sqrt(np.mean(values**2))) if m in ROOT_MEAN else float(np.mean(values))
        if by_class:
            out.update(self._class_scores(images, np.arange(self.times.size)[sel], [m for m in metrics
                                                                                   if m in PER_PIXEL]))
        return out

    def classes(self, k: int) -> dict[str, np.ndarray]:
        """{class: (H, W) bool mask} of scored time k (evsim_eval.pixel_classes: pixel, range and time classes), cached
        per white level (the flat class depends on it).

        Parameters
        ----------
        k : int
            Index of the scored time.

        Returns
        -------
        dict
            {class: (H, W) bool mask} for every class of evsim_eval.pixel_classes.CLASSES.
        """
        key = (k, self.white)
        if key not in self._classes:
            mid = (np.asarray(self.t_start, np.int64) + np.asarray(self.t_end, np.int64)) // 2
            before, after = nearest_frames(mid, int(self.times[k]))
            masks = pixel_classes(np.asarray(self.frames[before]), np.asarray(self.frames[after]), as_crf(self.crf),
                                  self.bit_depth, self.truth[k], self.white)
            masks.update(range_classes(self.truth[k], *self.frames_range))
            when = time_classes(int(self.times[k]), self.t_start, self.t_end)
            for name in TIME_CLASSES:
                masks[name] = np.full(self.truth.shape[1:], name == when)
            self._classes[key] = masks
        return self._classes[key]

    def _class_scores(self, images: np.ndarray, index: np.ndarray, metrics: list[str]) -> dict[str, float]:
        shape = self.truth.shape[1:]
        regions = {ssim: valid_region(shape, ssim) for ssim in (False, True)}
        top = self.frames_range[1]
        sums = {(m, c): 0.0 for m in metrics for c in CLASSES}
        counts = {(ssim, c): 0 for ssim in (False, True) for c in CLASSES}
        for img, k in zip(images, index):
            masks = self.classes(int(k))
            for ssim, region in regions.items():
                for c in CLASSES:
                    counts[ssim, c] += int(np.count_nonzero(masks[c] & region))
            for m in metrics:
                smap = score_map(m, img, self.truth[k], self.white, top)
                region = regions[m in SSIM_MAPS]
                for c in CLASSES:
                    sums[m, c] += float(smap[masks[c] & region].sum())
        out = {}
        for m in metrics:
            for c in CLASSES:
                n = counts[m in SSIM_MAPS, c]
                mean = sums[m, c] / n if n else math.nan
                out[f"{m}@{c}"] = math.sqrt(mean) if m in ROOT_MEAN else mean
        total = index.size * shape[0] * shape[1]
        out.update({f"share@{c}": counts[False, c] / total for c in CLASSES})
        return out


def evaluate_sequence(events: np.ndarray, frames: npt.ArrayLike, frame_t_start_us: npt.ArrayLike,
                      frame_t_end_us: npt.ArrayLike, crf: CRF | str, reference: npt.ArrayLike,
                      reference_times_us: npt.ArrayLike, *, methods: Collection[str] = ("akf", "cf", "frames"),
                      metrics: Collection[str] = ("mse", "psnr", "ssim", "pu21_psnr", "pu21_ssim"),
                      contrast: npt.ArrayLike = 0.2, bit_depth: int = 8,
                      method_options: dict[str, dict[str, Any]] | None = None, return_images: bool = False,
                      white: float | None = None
                      ) -> ScoreTable | tuple[ScoreTable, dict[str, npt.NDArray[np.float32]]]:
    """Reconstruct at reference_times_us with each method and score against the reference.

    Each metric is computed per reference frame (see evsim_eval.metrics for each one's normalisation) and averaged over
    the frames.

    Parameters
    ----------
    events, frames, frame_t_start_us, frame_t_end_us, crf
        The inputs, as akf.reconstruct takes them: time-sorted sim.EVENT_DTYPE events, (N, H, W) raw frames, their
        exposure windows (int64 us) and the CRF (a curve or its name).
    reference : array_like
        (T, H, W) linear intensity in the CRF's scaled-irradiance units of frame 0's exposure (for frames from
        sim.LDRCamera: x = radiance params.electrons_per_radiance_us exposure_us of frame 0 / params.full_well_e).
    reference_times_us : array_like
        (T,) its times, int64 us.
    methods : collection of str, optional
        akf.METHODS names (default "akf", "cf", "frames").
    metrics : collection of str, optional
        evsim_eval.metrics.METRICS names (default mse, psnr, ssim, pu21_psnr, pu21_ssim).
    contrast : array_like, optional
        Nominal contrast threshold(s), log units (default 0.2).
    bit_depth : int, optional
        The frames' bits (default 8).
    method_options : dict, optional
        {method: {keyword: value}} passed to that method (e.g. {"akf": {"params": ...}}).
    return_images : bool, optional
        Also return the reconstructions (default False).
    white : float, optional
        The intensity (x units) the [0, 1] protocol metrics (mse01, ssim01) map to 1; default reachable_white of the
        98th percentile of the reference (all frames pooled): at most what the methods can output.

    Returns
    -------
    table : dict
        {method: {metric: mean value}}.
    images : dict
        Only with return_images: {method: (T, H, W) float32 reconstructions}.
    """
    reference = np.asarray(reference)
    times = np.asarray(reference_times_us)
    if reference.ndim != 3 or reference.shape[0] != times.shape[0]:
        raise EvsimInputError(f"reference must be (T, H, W) with T = len(reference_times_us), got {reference.shape} "
                              f"and {times.shape[0]} times")
    check_names(methods, metrics)
    if white is None:
        white = reachable_white(float(np.percentile(reference, 98)), crf, frame_t_start_us, frame_t_end_us)[0]
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
