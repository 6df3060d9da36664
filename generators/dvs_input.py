"""The DVS's input from a scene: one pass over the scene shared by generation, conversion and calibration.

DVSInput holds how a scene is sampled for the DVS (generators.sampling: the adaptive sampler, or a fixed rate, with
the AHDRConfig's settings) and the warm-up of a scene that started before its t = 0 (a recorded clip: its first
warm_up_us mirrored in time before t = 0, so that the DVS enters t = 0 running; warm_up_input). scene_events puts
the pass's events in the scene's own time base (the warm-up's dropped, the scene's time origin added).
generators.ahdr.generate_ahdr streams the samples into the DVS chunk by chunk; evsim_eval.calibrate keeps them in
memory to simulate many sensors over the same input.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from sim import InvalidParameterError

from .sampling import make_sampler

if TYPE_CHECKING:
    from collections.abc import Iterable, Iterator

    import sim
    from sim.source import RadianceSource

__all__ = ["DVSInput", "SamplingSettings", "sampling_options", "warm_up_input", "MAX_FIXED_SAMPLES"]

MAX_FIXED_SAMPLES = 10_000_000  # DVS input frames of fixed-rate sampling per sequence (each a full render)


class SamplingSettings(Protocol):
    """What the DVS pass reads of a generators.ahdr.AHDRConfig: how the scene is sampled.

    Attributes
    ----------
    sampling : str
        "adaptive" or "fixed".
    sampling_fraction : float
        Adaptive: the fraction of the smaller mean threshold (log units) allowed per sample.
    sampling_quantile : float
        Adaptive: the quantile of the per-pixel log change that fraction bounds.
    min_step_us, max_step_us : int
        Adaptive: the bounds of a step (us).
    rate_hz : float
        Fixed: samples per second (Hz).
    """

    sampling: str
    sampling_fraction: float
    sampling_quantile: float
    min_step_us: int
    max_step_us: int
    rate_hz: float


def warm_up_input(images: list, times_us: list[int] | np.ndarray) -> tuple[list, np.ndarray]:
    """The DVS input that brings a sensor into the running state of t = 0: the samples (images at times_us, the
    first at t = 0) of the scene's first moments mirrored in time, at times -t (oldest first), t = 0 left out.

    A real sensor recording a clip was running before it: its references sit wherever the last events put them
    and its leak drifts are phased by them. A sensor initialised at t = 0 instead (reference = the first image,
    uniform random leak phase) fires a start-up burst as the noise in the input meets references at their
    initial levels (30x the steady rate of static pixels on a DAVIS346 recording). Feeding the mirrored start
    first gives the sensor the input's own statistics; its events are dropped.

    Parameters
    ----------
    images : list of ndarray
        The scene's first samples, (H, W) radiance each.
    times_us : array_like of int
        Their times in microseconds, increasing from 0.

    Returns
    -------
    images : list of ndarray
        The samples after the first, newest first.
    times_us : ndarray of int64
        Their mirrored times, -t (negative, increasing).
    """
    times = np.asarray(times_us, np.int64)
    if times.size < 2 or times[0] != 0:
        raise InvalidParameterError("a warm-up needs at least 2 samples, the first at t = 0")
    return list(images[:0:-1]), -times[:0:-1]


def sampling_options(config: SamplingSettings, dvs: sim.DVSParams, duration_us: int) -> dict[str, Any]:
    """The sampler's keyword arguments for `config` (generators.sampling.make_sampler): the adaptive sampler's
    threshold (the smaller of the DVS's), fraction, quantile, step bounds and log offset, or the fixed rate.

    Parameters
    ----------
    config : SamplingSettings
        The sampling settings (sampling, sampling_fraction, sampling_quantile, min/max_step_us, rate_hz).
    dvs : sim.DVSParams
        The resolved DVS (its thresholds and dark level set the adaptive step).
    duration_us : int
        The scene's duration in microseconds (bounds a fixed rate's sample count by MAX_FIXED_SAMPLES).

    Returns
    -------
    dict
        Keyword arguments of make_sampler besides the mode.
    """
    if config.sampling == "adaptive":
        return {"threshold": min(dvs.pos_threshold, dvs.neg_threshold), "fraction": config.sampling_fraction,
                "quantile": config.sampling_quantile, "min_step_us": config.min_step_us,
                "max_step_us": config.max_step_us, "log_eps": dvs.dark_fraction * dvs.full_illumination}
    if duration_us * 1e-6 * config.rate_hz > MAX_FIXED_SAMPLES:
        raise InvalidParameterError(f"fixed sampling at {config.rate_hz:g} Hz over {duration_us} us needs more "
                                    f"than {MAX_FIXED_SAMPLES} DVS input frames")
    return {"rate_hz": config.rate_hz}


class DVSInput:
    """How a scene is fed to the DVS: its samples, its warm-up and the time base of its events.

    Parameters
    ----------
    scene : RadianceSource
        The scene; its warm_up_us (default 0) and time_origin_us (default 0) are read.
    config : SamplingSettings
        The sampling settings.
    dvs : sim.DVSParams
        The resolved DVS parameters (after auto illumination).
    breakpoints_us : iterable of int
        Times the samples must include (frame and reference times: the DVS state is exact there).
    source : RadianceSource, optional
        What is rendered in the scene's place (a timing proxy of it); default the scene.
    """

    def __init__(self, scene: RadianceSource, config: SamplingSettings, dvs: sim.DVSParams, *,
                 breakpoints_us: Iterable[int] = (), source: RadianceSource | None = None):
        self.source = scene if source is None else source
        duration = int(scene.duration_us)
        self.mode = config.sampling
        self.options = sampling_options(config, dvs, duration)
        self.breakpoints_us = sorted(set(int(t) for t in breakpoints_us))
        self.warm_up_us = min(int(getattr(scene, "warm_up_us", 0)), duration)
        self.time_origin_us = int(getattr(scene, "time_origin_us", 0))

    def sampler(self, log_offset: float | None = None) -> Iterator[tuple[int, np.ndarray]]:
        """The sampler over the whole scene, from t = 0 to the end, with the breakpoints.

        Parameters
        ----------
        log_offset : float, optional
            Sample log(radiance + log_offset) (the source's offset_log) instead of radiance.

        Returns
        -------
        iterator of (int, numpy.ndarray)
            (t_us, image) pairs: scene time (us) and (H, W) float32 linear radiance (or its log); its n_samples
            counts them.
        """
        return make_sampler(self.source, self.mode, breakpoints_us=self.breakpoints_us, log_offset=log_offset,
                            **self.options)

    def warm_up(self) -> tuple[list, np.ndarray]:
        """The warm-up input (warm_up_input over the scene's first warm_up_us); ([], empty) without a warm-up.

        Returns
        -------
        images : list of ndarray
            (H, W) radiance samples to feed before t = 0.
        times_us : ndarray of int64
            Their times (negative).
        """
        if self.warm_up_us <= 0:
            return [], np.zeros(0, np.int64)
        pre = list(make_sampler(self.source, self.mode, t_end_us=self.warm_up_us, **self.options))
        return warm_up_input([img for _, img in pre], [t for t, _ in pre])

    def scene_events(self, events: np.ndarray, labels: np.ndarray | None = None
                     ) -> tuple[np.ndarray, np.ndarray | None]:
        """The events of this pass (times sorted, in scene time) in the scene's time base: the warm-up's (t <= 0)
        dropped, the time origin added (in place).

        Parameters
        ----------
        events : ndarray
            sim.EVENT_DTYPE events, sorted by time.
        labels : ndarray, optional
            Their per-event labels.

        Returns
        -------
        events, labels : ndarray
            The kept events (times in the scene's time base) and their labels (None when none were given).
        """
        if self.warm_up_us > 0 and events.size and events["t"][0] <= 0:  # the warm-up's last interval ends at t = 0
            keep = events["t"] > 0
            events, labels = events[keep], (labels[keep] if labels is not None else None)
        if self.time_origin_us:
            events["t"] += self.time_origin_us
        return events, labels
