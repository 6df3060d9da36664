"""Choosing the times at which the DVS samples a radiance source.

The DVS emulator interpolates log intensity linearly between the samples it is fed, so samples must be dense
enough that log intensity is close to linear between them. Two strategies, both iterators of (t_us, radiance)
pairs (one image alive at a time, so memory stays flat) that count the samples they produce:

- AdaptiveSampler (ESIM's idea): the next step is predicted from the last two samples so that the largest
  per-pixel change of L = log(I + log_eps) stays below `fraction * threshold`; a sample that turns out to exceed it
  is discarded and the step halved (bisection) until it fits or reaches min_step_us. Steps never exceed
  max_step_us. With quantile < 1 the bound holds for that quantile of the per-pixel changes instead of the
  maximum, so that a few high-contrast pixels (a fine edge, a dark pixel) do not set the step of the whole image:
  the DVS interpolates their log intensity linearly over a step that is longer for them, which moves their event
  times within the step but rarely the count (generation uses 0.95: tests/test_generate_ahdr.py checks the
  agreement with the maximum). The quantile is taken over every second row and column (a quarter of the
  pixels: the step control then costs a quarter as much); the maximum over all pixels.
  A source that is log-linear between known times (a video upsampled into key frames: scenes.video) says so
  with log_linear_until(t_us) -> the end of the piece that starts at t_us; the sampler then steps from piece end
  to piece end without the bound: the DVS emulator interpolates log intensity linearly between its samples, so
  samples inside a log-linear piece would change nothing.
  A source with max_frequency_hz (a flickering light) caps the step at 1 / (SAMPLES_PER_PERIOD x that
  frequency): the prediction from two samples one flicker period apart would see no change.
- FixedRateSampler: a regular grid at rate_hz, plus the end time.

read_ahead runs a sampler on a thread of its own a few samples ahead of its consumer, so that rendering the scene
overlaps with feeding the DVS.

Times are int64 microseconds, strictly increasing, from t_start_us to t_end_us inclusive, and include every
time of `breakpoints_us` in that range (e.g. the reference-frame times, so that the DVS state is exact there).

References (docs/models/references.md): Rebecq et al. 2018 [Rebecq2018], Gehrig et al. 2020 [Gehrig2020].
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Iterable, Iterator
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from sim import InvalidParameterError

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from sim.source import RadianceSource

T = TypeVar("T")
# Fraction of the predicted step actually taken, so that a constant rate of change lands below the bound.
_SAFETY = 0.9
#: AdaptiveSampler's longest step for a source with max_frequency_hz (a flickering light): this many per period, so
#: that no step aliases the flicker and its peaks are sampled within cos(pi / 16) = 98 % of their height
SAMPLES_PER_PERIOD = 16


def _time_range(source, t_start_us, t_end_us) -> tuple[int, int]:
    t_end_us = source.duration_us if t_end_us is None else int(t_end_us)
    if not 0 <= t_start_us < t_end_us <= source.duration_us:
        raise InvalidParameterError(f"sampling range [{t_start_us}, {t_end_us}] us must satisfy "
                                    f"0 <= start < end <= duration_us={source.duration_us}")
    return int(t_start_us), t_end_us


def _breakpoints(breakpoints_us, t_start: int, t_end: int) -> np.ndarray:
    b = np.unique(np.asarray(breakpoints_us, dtype=np.int64).ravel())
    return b[(b > t_start) & (b < t_end)]


def _positive_int(name: str, v) -> int:
    if isinstance(v, bool) or int(v) != v or v < 1:
        raise InvalidParameterError(f"{name} must be a positive integer (microseconds), got {v!r}")
    return int(v)


class AdaptiveSampler:
    """Samples of `source` such that max |L(t_{k+1}) - L(t_k)| <= fraction * threshold (unless at min_step_us, or
    within a log-linear piece of a source with log_linear_until: module docstring); with quantile < 1, that
    quantile of the per-pixel |L(t_{k+1}) - L(t_k)| instead of the maximum (0.5 <= quantile <= 1).

    threshold: the DVS contrast threshold (natural-log units); fraction: its share allowed between samples
    (0 < fraction <= 1); min_step_us, max_step_us: step bounds (microseconds); log_eps: the offset in log(I + eps),
    in radiance units (use the DVS's dark level); log_offset: yield log(radiance + log_offset) (the source's
    offset_log; sources with log_linear_until only) instead of radiance. After iteration: n_samples (yielded),
    n_evaluations (renders, including rejected trials) and n_at_min_step (steps accepted at min_step_us although
    above the bound).
    """

    def __init__(self, source: RadianceSource, *, threshold: float, fraction: float = 0.5, min_step_us: int = 10,
                 max_step_us: int = 10_000, log_eps: float = 1e-4, t_start_us: int = 0, t_end_us: int | None = None,
                 breakpoints_us: ArrayLike = (), quantile: float = 1.0, log_offset: float | None = None):
        if not threshold > 0 or not 0 < fraction <= 1:
            raise InvalidParameterError(f"need threshold > 0 and 0 < fraction <= 1, got threshold={threshold!r}, "
                                        f"fraction={fraction!r}")
        if not log_eps > 0:
            raise InvalidParameterError(f"log_eps must be > 0, got {log_eps!r}")
        if not 0.5 <= quantile <= 1:
            raise InvalidParameterError(f"quantile must be in [0.5, 1], got {quantile!r}")
        self.quantile = float(quantile)
        self.source = source
        self.max_change = float(threshold) * float(fraction)
        self.min_step = _positive_int("min_step_us", min_step_us)
        self.max_step = _positive_int("max_step_us", max_step_us)
        if self.max_step < self.min_step:
            raise InvalidParameterError(f"max_step_us={max_step_us} is below min_step_us={min_step_us}")
        frequency = getattr(source, "max_frequency_hz", lambda: 0.0)()
        if frequency > 0:  # a flicker: steps that could alias it are not tried
            self.max_step = max(self.min_step, min(self.max_step, int(1e6 / (SAMPLES_PER_PERIOD * frequency))))
        self.log_eps = np.float32(log_eps)
        self.t_start, self.t_end = _time_range(source, t_start_us, t_end_us)
        self.breakpoints = _breakpoints(breakpoints_us, self.t_start, self.t_end)
        self.n_samples = self.n_evaluations = self.n_at_min_step = 0
        if log_offset is not None and getattr(source, "log_linear_until", None) is None:
            raise InvalidParameterError("log_offset: log samples need a source that is log-linear between known "
                                        "times (log_linear_until): the step control of other sources reads radiance")
        self._sample = _sample_of(source, log_offset)

    def _log(self, img: np.ndarray) -> np.ndarray:
        if self.quantile < 1 and min(img.shape) > 1:
            img = img[::2, ::2]
        return np.log(img + self.log_eps)

    def _change(self, log_new: np.ndarray, log_prev: np.ndarray) -> float:
        d = np.abs(log_new - log_prev).ravel()
        if self.quantile == 1:
            return float(d.max())
        k = min(d.size - 1, int(self.quantile * d.size))
        return float(np.partition(d, k)[k])

    def __iter__(self) -> Iterator[tuple[int, np.ndarray]]:
        self.n_samples = self.n_evaluations = self.n_at_min_step = 0
        t = self.t_start
        linear_until = getattr(self.source, "log_linear_until", None)
        img = self._sample(t)
        log_prev = self._log(img) if linear_until is None else None
        self.n_evaluations += 1
        self.n_samples += 1
        yield t, img
        rate = None  # largest per-pixel |dL/dt| seen between the last two samples, per microsecond
        while t < self.t_end:
            dt = (self.max_step if not rate
                  else int(np.clip(_SAFETY * self.max_change / rate, self.min_step, self.max_step)))
            k = np.searchsorted(self.breakpoints, t, side="right")
            to_break = (self.breakpoints[k] if k < self.breakpoints.size else self.t_end) - t
            if linear_until is not None:  # a log-linear piece: step to its end (or a breakpoint), no bound check
                dt = min(max(int(linear_until(t)) - t, 1), self.max_step, to_break)
                t += dt
                img = self._sample(t)
                self.n_evaluations += 1
                self.n_samples += 1
                yield t, img
                continue
            dt = min(dt, to_break)
            while True:
                img = self.source.radiance(t + dt)
                log_new = self._log(img)
                self.n_evaluations += 1
                change = self._change(log_new, log_prev)
                if change <= self.max_change or dt <= self.min_step:
                    break
                dt = max(self.min_step, dt // 2)
            if change > self.max_change:
                self.n_at_min_step += 1
            rate = change / dt
            t += dt
            log_prev = log_new
            self.n_samples += 1
            yield t, img


class FixedRateSampler:
    """Samples of `source` every round(1e6 / rate_hz) microseconds from t_start_us, at the breakpoints, and at
    t_end_us; with log_offset, log(radiance + log_offset) (the source's offset_log) instead of radiance."""

    def __init__(self, source: RadianceSource, *, rate_hz: float, t_start_us: int = 0, t_end_us: int | None = None,
                 breakpoints_us: ArrayLike = (), log_offset: float | None = None):
        if not rate_hz > 0 or not np.isfinite(rate_hz):
            raise InvalidParameterError(f"rate_hz must be a finite positive number, got {rate_hz!r}")
        self.source = source
        self.step = max(1, round(1e6 / rate_hz))
        self.t_start, self.t_end = _time_range(source, t_start_us, t_end_us)
        self.breakpoints = _breakpoints(breakpoints_us, self.t_start, self.t_end)
        self.n_samples = 0
        self._sample = _sample_of(source, log_offset)

    def times(self) -> np.ndarray:
        """The sample times (int64 microseconds)."""
        grid = np.arange(self.t_start, self.t_end, self.step, dtype=np.int64)
        return np.union1d(np.append(grid, self.breakpoints), [self.t_end])

    def __iter__(self) -> Iterator[tuple[int, np.ndarray]]:
        self.n_samples = 0
        for t in self.times():
            self.n_samples += 1
            yield int(t), self._sample(int(t))


def _sample_of(source: RadianceSource, log_offset: float | None) -> Callable[[int], np.ndarray]:
    """What a sampler yields at a time: the source's radiance, or with log_offset its log(radiance + log_offset)
    (source.offset_log: a scene that interpolates in log space has it without an exp and a log)."""
    if log_offset is None:
        return source.radiance
    offset_log = getattr(source, "offset_log", None)
    if offset_log is None:
        raise InvalidParameterError(f"log_offset: {type(source).__name__} has no offset_log(t_us, offset)")
    return lambda t: offset_log(t, log_offset)


def make_sampler(source: RadianceSource, mode: str = "adaptive", **kwargs: Any) -> AdaptiveSampler | FixedRateSampler:
    """AdaptiveSampler (mode "adaptive") or FixedRateSampler (mode "fixed") with the given keyword arguments."""
    samplers = {"adaptive": AdaptiveSampler, "fixed": FixedRateSampler}
    if mode not in samplers:
        raise InvalidParameterError(f"sampling mode must be one of {sorted(samplers)}, got {mode!r}")
    return samplers[mode](source, **kwargs)


def read_ahead(items: Iterable[T], depth: int) -> Iterator[T]:
    """The items of `items` in order, produced on a thread of their own up to `depth` ahead of the consumer.

    A scene's rendering (numba kernels and OpenCV, which release the GIL) then overlaps with what the consumer does
    with each sample (the DVS update): both cores stay busy. The thread is the only one iterating `items`. An
    exception raised by `items` is raised to the consumer at the item where it happened; closing the iterator early
    (a break, an exception or an interruption in the consumer) stops the thread after its current item.

    Parameters
    ----------
    items : iterable
        What to iterate (a sampler).
    depth : int
        The most items held ready, >= 1.

    Yields
    ------
    object
        The items of `items`.
    """
    ready: queue.Queue = queue.Queue(maxsize=max(1, int(depth)))
    stop = threading.Event()
    end = object()

    def put(entry) -> bool:
        while not stop.is_set():
            try:
                ready.put(entry, timeout=0.05)
                return True
            except queue.Full:
                continue
        return False

    def produce() -> None:
        try:
            for item in items:
                if not put((item, None)):
                    return
            put((end, None))
        except BaseException as e:  # noqa: BLE001 (raised to the consumer)
            put((end, e))

    thread = threading.Thread(target=produce, name="evsim-samples", daemon=True)
    thread.start()
    try:
        while True:
            item, error = ready.get()
            if item is end:
                if error is not None:
                    raise error
                return
            yield item
    finally:
        stop.set()
        thread.join()
