"""Event denoising filters: each returns a boolean keep-mask over a time-sorted sim.EVENT_DTYPE array.

evsim's own reference filters (no library has them in this form):
- "correlation": the spatio-temporal correlation filter (the background-activity filter of Delbruck 2008
  [Delbruck2008] with support = 1, the STCF of Guo and Delbruck 2022 [Guo2022] with support >= 2). An event is kept when
  at least `support` of its 8 neighbouring pixels fired within window_us before it (t - t_neighbour <= window_us); the
  pixel's own past events never support it. Every event, kept or not, updates its pixel's last time. O(1) per event
  (numba).
- "hot_pixel": the hot-pixel rate filter. A pixel is hot when its event rate over the stream (events / the
  stream's span) exceeds the mean rate of its neighbouring pixels by more than threshold_hz and is more than
  `ratio` times it (a hot pixel fires alone; an edge makes its neighbours fire too, and background noise raises
  them all alike; defaults 20 Hz and 2); every event of a hot pixel is dropped. Two O(1) passes per event
  (count, then look up): it learns from the events it is given, like the learning phase of jAER's
  HotPixelFilter, so it is an offline filter. In busy textured regions, where signal rates vary from pixel to
  pixel as much as a hot pixel's excess, it misses hot pixels (the ROC shows it).

Wrappers that run the maintained libraries users already run, unchanged (imported on first use; a missing one
raises DenoiseDependencyError naming `pip install "evsim[denoise]"`):
- "dv_ba", "dv_knoise", "dv_fast_decay": dv-processing's noise.BackgroundActivityNoiseFilter (parameter: its
  backgroundActivityDuration), noise.KNoiseFilter (timeDelta) and noise.FastDecayNoiseFilter (halfLife, with
  subdivisionFactor and noiseThreshold as options). Each event goes through the filter's retain(), which is what
  its accept() / generateEvents() runs, so the mask is exactly the library's decision per event.
- "tonic_denoise": tonic.functional.denoise_numpy (what tonic.transforms.Denoise calls), parameter filter_time;
  the events carry their index through it to give the mask.

Every filter's main parameter (FILTERS[name].param) makes it more permissive as it grows (a longer correlation
window, a higher hot-pixel rate threshold): sweeping it from FILTERS[name].grid traces an ROC curve.
Times are int64 microseconds; rates in Hz.

References (docs/models/references.md): Delbruck 2008 [Delbruck2008], the background-activity filter; Guo and Delbruck
2022 [Guo2022], the STCF; dv-processing [DvProcessing]; Lenz et al. 2021 [Lenz2021], Tonic.
"""

from __future__ import annotations

import datetime
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numba import njit

from sim.errors import EvsimInputError, InvalidParameterError, check_number
from sim.events import EVENT_DTYPE, validate_events

if TYPE_CHECKING:
    import numpy.typing as npt

    #: a keep-mask: one bool per event, True where the event is kept
    KeepMask = npt.NDArray[np.bool_]

__all__ = ["FILTERS", "DenoiseFilter", "get_filter", "filter_available", "keep_mask", "TIME_GRID_US",
           "CorrelationFilter", "correlation_filter", "hot_pixel_map", "hot_pixel_filter", "dv_background_activity",
           "dv_knoise", "dv_fast_decay", "tonic_denoise", "DenoiseDependencyError", "DENOISE_EXTRA_HINT"]

#: how to install the optional libraries of the wrapped filters (said by DenoiseDependencyError)
DENOISE_EXTRA_HINT = 'pip install "evsim[denoise]"'
_NEVER_US = np.iinfo(np.int64).min // 4  # "no event yet": older than any window


class DenoiseDependencyError(EvsimInputError):
    """A denoising library (dv-processing, tonic) is not installed; the message names the extra to install."""


def _check(events, height: int, width: int) -> np.ndarray:
    events = validate_events(events)
    if not (isinstance(height, (int, np.integer)) and isinstance(width, (int, np.integer)) and height > 0
            and width > 0):
        raise InvalidParameterError(f"height and width must be positive integers, got {height!r} x {width!r}")
    if events.size and (int(events["x"].max()) >= width or int(events["y"].max()) >= height):
        raise EvsimInputError(f"event coordinates exceed the sensor size {width}x{height} (W x H)")
    return events


# ----- evsim's reference filters ---------------------------------------------------------------------------------

@njit(cache=True)
def _correlation_kernel(t, x, y, last, window_us, support, keep):
    h, w = last.shape
    for i in range(t.size):
        ti, xi, yi = t[i], np.int64(x[i]), np.int64(y[i])
        n = 0
        for yy in range(max(yi - 1, 0), min(yi + 2, h)):
            for xx in range(max(xi - 1, 0), min(xi + 2, w)):
                if (yy != yi or xx != xi) and ti - last[yy, xx] <= window_us:
                    n += 1
        keep[i] = n >= support
        last[yi, xi] = ti


class CorrelationFilter:
    """The spatio-temporal correlation filter with its state (each pixel's last event time), for streams fed in
    chunks: filter(events) -> keep-mask; chunks must follow each other in time. See the module docstring.

    Parameters
    ----------
    height, width : int
        Sensor size (pixels), > 0.
    window_us : float, optional
        The correlation window (us), >= 0, rounded to whole microseconds (default 2000).
    support : int, optional
        How many of the 8 neighbours must have fired within it, 1..8 (default 1).
    """

    def __init__(self, height: int, width: int, window_us: float = 2000, support: int = 1) -> None:
        check_number("window_us", window_us, positive=False)
        if not (isinstance(support, (int, np.integer)) and 1 <= support <= 8):
            raise InvalidParameterError(f"support must be an integer in 1..8 (neighbouring pixels), got {support!r}")
        _check(np.empty(0, EVENT_DTYPE), height, width)
        self.window_us, self.support = int(round(window_us)), int(support)
        self._last = np.full((int(height), int(width)), _NEVER_US, np.int64)

    def __call__(self, events: np.ndarray) -> KeepMask:
        events = _check(events, *self._last.shape)
        keep = np.empty(events.size, np.bool_)
        _correlation_kernel(events["t"], events["x"], events["y"], self._last, self.window_us, self.support, keep)
        return keep


def correlation_filter(events: np.ndarray, height: int, width: int, window_us: float = 2000, *,
                       support: int = 1) -> KeepMask:
    """Keep-mask of the spatio-temporal correlation filter. support = 1 is the background-activity filter (Delbruck
    2008 [Delbruck2008]), support >= 2 the STCF (Guo and Delbruck 2022 [Guo2022]).

    Parameters
    ----------
    events : numpy.ndarray
        Time-sorted sim.EVENT_DTYPE events.
    height, width : int
        Sensor size (pixels).
    window_us : float, optional
        The correlation window (us; default 2000).
    support : int, optional
        How many of the 8 neighbours must have fired within it, 1..8 (default 1).

    Returns
    -------
    numpy.ndarray
        bool keep-mask, one per event.
    """
    return CorrelationFilter(height, width, window_us, support)(events)


def hot_pixel_map(events: np.ndarray, height: int, width: int, threshold_hz: float = 20.0, *,
                  ratio: float = 2.0) -> npt.NDArray[np.bool_]:
    """(H, W) bool: the pixels whose event rate r exceeds the mean rate m of their neighbours (8, fewer at the
    border) by more than threshold_hz (r - m > threshold_hz) and r > ratio * m; rates (Hz) are event counts over
    the span of the events (first to last).

    Parameters
    ----------
    events : numpy.ndarray
        Time-sorted sim.EVENT_DTYPE events.
    height, width : int
        Sensor size (pixels).
    threshold_hz : float, optional
        Least excess rate over the neighbours' mean (Hz), >= 0 (default 20).
    ratio : float, optional
        Least ratio of the rate to the neighbours' mean, >= 0 (default 2).

    Returns
    -------
    numpy.ndarray
        (H, W) bool, True at hot pixels.
    """
    events = _check(events, height, width)
    check_number("threshold_hz", threshold_hz, positive=False)
    check_number("ratio", ratio, positive=False)
    if events.size == 0:
        return np.zeros((height, width), bool)
    span_s = (int(events["t"][-1]) - int(events["t"][0]) + 1) * 1e-6
    counts = np.bincount(events["y"].astype(np.int64) * width + events["x"], minlength=height * width)
    rate = counts.reshape(height, width) / span_s
    padded = np.pad(rate, 1)
    ones = np.pad(np.ones_like(rate), 1)
    neighbours = sum(padded[1 + dy:1 + dy + height, 1 + dx:1 + dx + width]
                     for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx)
    n = sum(ones[1 + dy:1 + dy + height, 1 + dx:1 + dx + width] for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx)
    mean = neighbours / n
    return (rate - mean > threshold_hz) & (rate > ratio * mean)


def hot_pixel_filter(events: np.ndarray, height: int, width: int, threshold_hz: float = 20.0, *,
                     ratio: float = 2.0) -> KeepMask:
    """Keep-mask of the hot-pixel rate filter: every event of a pixel of hot_pixel_map(...) is dropped.

    Parameters
    ----------
    events, height, width, threshold_hz, ratio
        As hot_pixel_map's.

    Returns
    -------
    numpy.ndarray
        bool keep-mask, one per event.
    """
    hot = hot_pixel_map(events, height, width, threshold_hz, ratio=ratio)
    return ~hot[events["y"], events["x"]]


# ----- the maintained libraries -----------------------------------------------------------------------------------

def _import(module: str, package: str):
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise DenoiseDependencyError(f"this filter runs {package}, which is not installed: {DENOISE_EXTRA_HINT}") \
            from None


def _dv_mask(make_filter, events, height, width) -> np.ndarray:
    dv = _import("dv_processing", "dv-processing")
    events = _check(events, height, width)
    filt = make_filter(dv, (int(width), int(height)))
    event = dv.Event
    return np.fromiter((filt.retain(event(t, x, y, p > 0)) for t, x, y, p in
                        zip(events["t"].tolist(), events["x"].tolist(), events["y"].tolist(), events["p"].tolist())),
                       dtype=np.bool_, count=events.size)


def _us(value) -> datetime.timedelta:
    check_number("time window", value, positive=True)
    return datetime.timedelta(microseconds=int(round(value)))


def dv_background_activity(events: np.ndarray, height: int, width: int, duration_us: float = 2000) -> KeepMask:
    """Keep-mask of dv-processing's noise.BackgroundActivityNoiseFilter(backgroundActivityDuration=duration_us).

    Parameters
    ----------
    events : numpy.ndarray
        Time-sorted sim.EVENT_DTYPE events.
    height, width : int
        Sensor size (pixels).
    duration_us : float, optional
        backgroundActivityDuration (us), > 0, rounded to whole microseconds (default 2000).

    Returns
    -------
    numpy.ndarray
        bool keep-mask, one per event.
    """
    return _dv_mask(lambda dv, res: dv.noise.BackgroundActivityNoiseFilter(res, _us(duration_us)),
                    events, height, width)


def dv_knoise(events: np.ndarray, height: int, width: int, time_delta_us: float = 1000) -> KeepMask:
    """Keep-mask of dv-processing's noise.KNoiseFilter(timeDelta=time_delta_us).

    Parameters
    ----------
    events : numpy.ndarray
        Time-sorted sim.EVENT_DTYPE events.
    height, width : int
        Sensor size (pixels).
    time_delta_us : float, optional
        timeDelta (us), > 0 (default 1000).

    Returns
    -------
    numpy.ndarray
        bool keep-mask, one per event.
    """
    return _dv_mask(lambda dv, res: dv.noise.KNoiseFilter(res, _us(time_delta_us)), events, height, width)


def dv_fast_decay(events: np.ndarray, height: int, width: int, half_life_us: float = 10000, *,
                  subdivision_factor: int = 4, noise_threshold: float = 6.0) -> KeepMask:
    """Keep-mask of dv-processing's noise.FastDecayNoiseFilter(halfLife=half_life_us, subdivisionFactor,
    noiseThreshold) (the library's defaults).

    Parameters
    ----------
    events : numpy.ndarray
        Time-sorted sim.EVENT_DTYPE events.
    height, width : int
        Sensor size (pixels).
    half_life_us : float, optional
        halfLife (us), > 0 (default 10000).
    subdivision_factor : int, optional
        subdivisionFactor (default 4).
    noise_threshold : float, optional
        noiseThreshold (default 6).

    Returns
    -------
    numpy.ndarray
        bool keep-mask, one per event.
    """
    return _dv_mask(lambda dv, res: dv.noise.FastDecayNoiseFilter(res, _us(half_life_us), int(subdivision_factor),
                                                                  float(noise_threshold)), events, height, width)


def tonic_denoise(events: np.ndarray, height: int, width: int, filter_time_us: float = 10000) -> KeepMask:
    """Keep-mask of tonic's Denoise(filter_time=filter_time_us) (tonic.functional.denoise_numpy, 4-neighbourhood;
    as in tonic, events before the first filter_time_us are kept).

    Parameters
    ----------
    events : numpy.ndarray
        Time-sorted sim.EVENT_DTYPE events.
    height, width : int
        Sensor size (pixels).
    filter_time_us : float, optional
        filter_time (us), >= 0 (default 10000).

    Returns
    -------
    numpy.ndarray
        bool keep-mask, one per event.
    """
    functional = _import("tonic.functional", "tonic")
    events = _check(events, height, width)
    check_number("filter_time_us", filter_time_us, positive=False)
    keep = np.zeros(events.size, np.bool_)
    if events.size:
        tagged = np.empty(events.size, EVENT_DTYPE.descr + [("index", np.int64)])
        for name in EVENT_DTYPE.names:
            tagged[name] = events[name]
        tagged["index"] = np.arange(events.size)
        keep[functional.denoise_numpy(tagged, filter_time=float(filter_time_us))["index"]] = True
    return keep


# ----- the registry -------------------------------------------------------------------------------------------------

#: the time windows (microseconds) an ROC sweeps for the filters whose parameter is a time
TIME_GRID_US = (100, 300, 1000, 3000, 10_000, 30_000, 100_000, 300_000)


@dataclass(frozen=True)
class DenoiseFilter:
    """A filter of the registry: run(events, height, width, value, **options) -> bool keep-mask.

    Attributes
    ----------
    name : str
        Its FILTERS name.
    run : callable
        The filter function: run(events, height, width, value, ...) -> keep-mask.
    param : str
        The main parameter's name (larger keeps more).
    unit : str
        Its unit ("us", "Hz").
    default : float
        Its default.
    grid : tuple of float
        The values an ROC sweeps.
    library : str or None
        The PyPI package it runs (None: evsim's own).
    summary : str
        One line describing it.
    """

    name: str
    run: Callable[..., KeepMask]
    param: str
    unit: str
    default: float
    grid: tuple[float, ...]
    library: str | None
    summary: str


#: filter name -> DenoiseFilter (its function, main parameter, default and ROC grid)
FILTERS = {f.name: f for f in (
    DenoiseFilter("correlation", correlation_filter, "window_us", "us", 2000, TIME_GRID_US, None,
                  "evsim spatio-temporal correlation (8 neighbours, support 1)"),
    DenoiseFilter("hot_pixel", hot_pixel_filter, "threshold_hz", "Hz", 20.0, (1, 3, 10, 20, 50, 100, 300, 1000),
                  None, "evsim hot-pixel rate (rate - neighbours' mean > threshold, rate > 2x that mean)"),
    DenoiseFilter("dv_ba", dv_background_activity, "duration_us", "us", 2000, TIME_GRID_US, "dv-processing",
                  "dv-processing BackgroundActivityNoiseFilter"),
    DenoiseFilter("dv_knoise", dv_knoise, "time_delta_us", "us", 1000, TIME_GRID_US, "dv-processing",
                  "dv-processing KNoiseFilter"),
    DenoiseFilter("dv_fast_decay", dv_fast_decay, "half_life_us", "us", 10_000, TIME_GRID_US, "dv-processing",
                  "dv-processing FastDecayNoiseFilter (4x subdivision, threshold 6)"),
    DenoiseFilter("tonic_denoise", tonic_denoise, "filter_time_us", "us", 10_000, TIME_GRID_US, "tonic",
                  "tonic Denoise (4 neighbours)"),
)}


def get_filter(name: str) -> DenoiseFilter:
    """FILTERS[name], or InvalidParameterError listing the known names.

    Parameters
    ----------
    name : str
        A FILTERS name.

    Returns
    -------
    DenoiseFilter
        The filter.
    """
    try:
        return FILTERS[name]
    except KeyError:
        raise InvalidParameterError(f"unknown denoising filter {name!r}; one of {', '.join(FILTERS)}") from None


def filter_available(name: str) -> bool:
    """Whether the library a filter runs is installed (always True for evsim's own filters).

    Parameters
    ----------
    name : str
        A FILTERS name.

    Returns
    -------
    bool
        True when it can run.
    """
    import importlib.util

    module = {"dv-processing": "dv_processing", "tonic": "tonic"}.get(get_filter(name).library)
    return module is None or importlib.util.find_spec(module) is not None


def keep_mask(events: np.ndarray, height: int, width: int, name: str = "correlation", value: float | None = None,
              **options: Any) -> KeepMask:
    """Keep-mask of filter `name` at main-parameter value (default FILTERS[name].default) with extra options.

    Parameters
    ----------
    events : numpy.ndarray
        Time-sorted sim.EVENT_DTYPE events.
    height, width : int
        Sensor size (pixels).
    name : str, optional
        A FILTERS name (default "correlation").
    value : float, optional
        The main parameter (in FILTERS[name].unit; default FILTERS[name].default).
    **options
        The filter's other keyword arguments.

    Returns
    -------
    numpy.ndarray
        bool keep-mask, one per event.
    """
    f = get_filter(name)
    return f.run(events, height, width, f.default if value is None else value, **options)
